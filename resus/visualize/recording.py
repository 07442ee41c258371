"""Opening a rerun recording from command-line choices: save an `.rrd`, serve, or spawn.

- save: every message goes to an `.rrd` file (`--rerun-save FILE`), which `rerun FILE` opens.
- serve: a rerun server process (`python -m rerun --serve-web --bind 127.0.0.1`) hosts the web
  viewer and a gRPC proxy, both on localhost only; the recording streams to it. (In rerun 0.41
  the in-process `rr.serve_web_viewer` always binds every interface, 0.0.0.0.)
- spawn: the native viewer, when there is a display to show it on.

Saving and a live viewer combine: the same messages go to both sinks.
"""

from __future__ import annotations

import contextlib
import os
import signal
import socket
import subprocess
import sys
import time
from contextlib import AbstractContextManager
from pathlib import Path
from urllib.parse import quote

import rerun as rr
import rerun.blueprint as rrb

from resus.errors import ResusError

LIVE_MODES = ("serve", "spawn")
DEFAULT_GRPC_PORT = 9876
DEFAULT_WEB_PORT = 9090
LOCALHOST = "127.0.0.1"
SERVER_START_TIMEOUT = 30.0
"""Seconds to wait for a rerun server process to accept connections."""


def grpc_url(port: int) -> str:
    """The URL of a rerun gRPC proxy on localhost."""
    return f"rerun+http://{LOCALHOST}:{port}/proxy"


def _check_free(name: str, port: int) -> None:
    """ResusError unless `port` on 127.0.0.1 can be bound (`name` is the setting it came from)."""
    if not 0 < port < 65536:
        raise ResusError(f"{name} must be a port number in 1-65535, got {port}")
    with socket.socket(socket.AF_INET, socket.SOCK_STREAM) as probe:
        probe.setsockopt(socket.SOL_SOCKET, socket.SO_REUSEADDR, 1)  # TIME_WAIT is no owner
        try:
            probe.bind((LOCALHOST, port))
        except OSError as error:
            raise ResusError(
                f"{name} {port} on {LOCALHOST} is in use ({error.strerror}); "
                "is another viewer still running?"
            ) from None


class WebViewerServer:
    """A rerun server process hosting the web viewer and a gRPC proxy, on localhost only.

    It runs `python -m rerun --serve-web --bind 127.0.0.1` in a process session of its own
    (that command runs the rerun binary as a child), so `stop` ends both.
    """

    def __init__(
        self,
        grpc_port: int = DEFAULT_GRPC_PORT,
        web_port: int = DEFAULT_WEB_PORT,
        recordings: tuple[Path, ...] = (),
    ) -> None:
        """Start it and wait until both ports accept connections; `recordings` are `.rrd`
        files for it to serve. A port already taken (say by a server left from an earlier run)
        is an error here: otherwise the new server would exit at once and the old one answer."""
        for name, port in (("grpc_port", grpc_port), ("web_port", web_port)):
            _check_free(name, port)
        self.grpc_url = grpc_url(grpc_port)
        self.url = f"http://{LOCALHOST}:{web_port}/?url={quote(self.grpc_url, safe='')}"
        """The web viewer's address, connected to the gRPC proxy."""
        command = [
            sys.executable, "-m", "rerun", "--serve-web", "--bind", LOCALHOST,
            "--port", str(grpc_port), "--web-viewer-port", str(web_port), *map(str, recordings),
        ]  # fmt: skip
        self.process = subprocess.Popen(
            command, stdout=subprocess.DEVNULL, stderr=subprocess.DEVNULL, start_new_session=True
        )
        for port in (grpc_port, web_port):
            self._wait_for(port)

    def _wait_for(self, port: int) -> None:
        deadline = time.monotonic() + SERVER_START_TIMEOUT
        while time.monotonic() < deadline:
            if self.process.poll() is not None:
                raise ResusError(
                    f"the rerun server exited at start (status {self.process.returncode}); "
                    f"is port {port} in use?"
                )
            try:
                with socket.create_connection((LOCALHOST, port), timeout=0.5):
                    return
            except OSError:
                time.sleep(0.1)
        self.stop()
        raise ResusError(f"the rerun server did not listen on {LOCALHOST}:{port}")

    def wait(self) -> None:
        """Block until the server ends or Ctrl-C."""
        with contextlib.suppress(KeyboardInterrupt):
            self.process.wait()

    def stop(self) -> None:
        """End the server and everything it started."""
        with contextlib.suppress(ProcessLookupError):
            os.killpg(self.process.pid, signal.SIGTERM)
        self.process.wait(timeout=10)


class RerunSession(AbstractContextManager):
    """An open recording (`stream`) and the web viewer server it feeds, if any."""

    def __init__(
        self,
        stream: rr.RecordingStream,
        save_path: Path | None,
        server: WebViewerServer | None = None,
    ) -> None:
        self.stream = stream
        self.save_path = save_path
        self.server = server

    @property
    def viewer_url(self) -> str | None:
        """Where to look when serving: the web viewer's address."""
        return None if self.server is None else self.server.url

    def wait_until_interrupted(self) -> None:
        """Keep a served viewer up until Ctrl-C."""
        if self.server is not None:
            self.server.wait()

    def close(self) -> None:
        """Flush every message to its sinks, close them and stop a served viewer."""
        self.stream.flush()
        self.stream.disconnect()
        if self.server is not None:
            self.server.stop()

    def __exit__(self, *exc_info: object) -> None:
        self.close()


def open_recording(
    application_id: str = "resus",
    *,
    save: str | Path | None = None,
    live: str | None = None,
    blueprint: rrb.Blueprint | None = None,
    recording_id: str | None = None,
    grpc_port: int = DEFAULT_GRPC_PORT,
    web_port: int = DEFAULT_WEB_PORT,
) -> RerunSession:
    """A recording going to an `.rrd` file (`save`), a live viewer (`live`: "serve" or
    "spawn"), or both, with `blueprint` as its default layout."""
    if save is None and live is None:
        raise ResusError("nowhere to send the recording: give a file to save or a live viewer")
    if live is not None and live not in LIVE_MODES:
        raise ResusError(f"the live viewer must be one of {', '.join(LIVE_MODES)}, got {live!r}")
    save_path = None if save is None else Path(save)
    if save_path is not None and save_path.suffix != ".rrd":
        raise ResusError("rerun recordings must end in .rrd", save_path)
    sinks: list[rr.FileSink | rr.GrpcSink] = []
    server = None
    stream = rr.RecordingStream(application_id, recording_id=recording_id)
    if live == "serve":
        server = WebViewerServer(grpc_port, web_port)
        sinks.append(rr.GrpcSink(server.grpc_url))
    elif live == "spawn":
        if not (os.environ.get("DISPLAY") or os.environ.get("WAYLAND_DISPLAY")):
            raise ResusError(
                "a spawned viewer needs a display; serve a web viewer or save to a file"
            )
        stream.spawn(port=grpc_port, connect=False)
        sinks.append(rr.GrpcSink(grpc_url(grpc_port)))
    if save_path is not None:
        save_path.parent.mkdir(parents=True, exist_ok=True)
        sinks.append(rr.FileSink(save_path))
    stream.set_sinks(*sinks)
    if blueprint is not None:
        stream.send_blueprint(blueprint)
    return RerunSession(stream, save_path, server)
