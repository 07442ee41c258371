"""`resus view` end to end, and the live web viewer served on localhost only."""

from __future__ import annotations

import signal
import subprocess
import sys
import time
import urllib.request
from pathlib import Path

import numpy as np
import pytest
import rerun as rr
import typer
from cli_runner import free_port, resus
from rerun_readback import Recording
from sweep_samples import sample_sweep
from typer.testing import CliRunner

from resus.cli import view as view_command
from resus.errors import ResusError
from resus.reconstruction.grid import VolumeGrid
from resus.reconstruction.io import write_volume
from resus.reslicing.dataset import ResliceWriter
from resus.reslicing.reslice import Reslice, ResliceSettings
from resus.sweep.io import write_sweep
from resus.visualize import open_recording
from resus.visualize.recording import WebViewerServer

N = 4


@pytest.fixture(scope="module")
def app() -> typer.Typer:
    root = typer.Typer()
    view_command.register(root)
    root.command("noop")(lambda: None)  # a second command, so `view` is addressed by name
    return root


@pytest.fixture(scope="module")
def inputs(tmp_path_factory) -> dict[str, Path]:
    folder = tmp_path_factory.mktemp("view")
    sweep = sample_sweep(N, rows=10, cols=12, seed=5)
    write_sweep(folder / "sweep.h5", sweep)
    grid = VolumeGrid(origin=[0.1, 0.2, 0.05], axes=np.diag([1e-3, 1e-3, 2e-3]), shape=(5, 6, 4))
    rng = np.random.default_rng(0)
    write_volume(folder / "volume.nrrd", rng.integers(0, 255, grid.shape).astype(np.uint8), grid)
    write_volume(folder / "labels.nrrd", rng.integers(0, 3, grid.shape).astype(np.uint8), grid)
    settings = ResliceSettings(size=8)
    with ResliceWriter(folder / "reslices.h5", settings, "volume.nrrd") as writer:
        for k in range(3):
            plane = np.diag([1e-3, 1e-3, 1e-3, 1.0])
            writer.append(
                Reslice(
                    rng.integers(0, 255, (8, 8), dtype=np.uint8),
                    rng.integers(0, 3, (8, 8), dtype=np.uint8),
                    (0.0, 10.0 * k),
                    k,
                    plane,
                )
            )
    files = [("sweep", "h5"), ("volume", "nrrd"), ("labels", "nrrd"), ("reslices", "h5")]
    return {name: folder / f"{name}.{suffix}" for name, suffix in files}


def test_view_logs_sweep_volume_reslices_and_phantom(app, inputs, tmp_path):
    out = tmp_path / "view.rrd"
    arguments = [
        "view",
        str(inputs["sweep"]),
        "--volume",
        str(inputs["volume"]),
        "--labels",
        str(inputs["labels"]),
        "--reslices",
        str(inputs["reslices"]),
        "--scene",
        "default",
        "--dense-volume",
        "--rerun-save",
        str(out),
    ]
    result = CliRunner().invoke(app, arguments)
    assert result.exit_code == 0, result.output
    assert "logged 3 of 3 reslices" in result.output
    recording = Recording(out)
    assert len(recording.temporal["/world/ultrasound/frame"]) == N
    assert len(recording.temporal["/world/robot/wrist_3_link"]) == N
    assert len(recording.temporal["/world/reslices/plane"]) == 3
    expected = {"/world/volume/slices/i", "/world/volume/dense", "/world/phantom/artery"}
    assert expected <= recording.entities
    assert len(recording.blueprints) == 1


@pytest.mark.parametrize(
    ("extra", "message"),
    [
        (["--labels", "LABELS", "--rerun-save", "out.rrd"], "--labels needs --volume"),
        ([], "nowhere to send the recording"),
        (["--predictions", "SWEEP", "--rerun-save", "out.rrd"], "no labels to show"),
        (
            ["--predictions", "SMALLER", "--rerun-save", "out.rrd"],
            f"labels ({N}, 8, 12) do not match the sweep's frames",
        ),
        (["--rerun", "window"], "--rerun must be one of serve, spawn"),
    ],
)
def test_view_refuses_bad_options(app, inputs, tmp_path, extra, message):
    unlabelled = tmp_path / "unlabelled.h5"
    write_sweep(unlabelled, sample_sweep(N, rows=10, cols=12, optional=False))
    smaller = tmp_path / "smaller.h5"
    write_sweep(smaller, sample_sweep(N, rows=8, cols=12))
    names = {"LABELS": str(inputs["labels"]), "SWEEP": str(unlabelled), "SMALLER": str(smaller)}
    extra = [names.get(arg, str(tmp_path / arg) if arg.endswith(".rrd") else arg) for arg in extra]
    result = CliRunner().invoke(app, ["view", str(inputs["sweep"]), *extra])
    assert isinstance(result.exception, ResusError), result.output
    assert message in str(result.exception)


def test_dense_view_of_a_sheared_grid_is_refused_before_recording(app, inputs, tmp_path):
    sheared = VolumeGrid(
        origin=[0.0, 0.0, 0.0], axes=[[1e-3, 0, 0], [5e-4, 1e-3, 0], [0, 0, 1e-3]], shape=(4, 4, 4)
    )
    write_volume(tmp_path / "sheared.nrrd", np.zeros((4, 4, 4), np.uint8), sheared)
    out = tmp_path / "never.rrd"
    arguments = [
        "view",
        str(inputs["sweep"]),
        "--volume",
        str(tmp_path / "sheared.nrrd"),
        "--dense-volume",
        "--rerun-save",
        str(out),
    ]
    result = CliRunner().invoke(app, arguments)
    assert isinstance(result.exception, ResusError)
    assert "orthogonal" in str(result.exception)
    assert not out.exists()


def listening_addresses(port: int) -> set[str]:
    """Local addresses (hex, as /proc/net/tcp writes them) listening on `port`."""
    found = set()
    for table in ("/proc/net/tcp", "/proc/net/tcp6"):
        try:
            lines = Path(table).read_text().splitlines()[1:]
        except OSError:
            continue
        for line in lines:
            local, state = line.split()[1], line.split()[3]
            address, hex_port = local.split(":")
            if state == "0A" and int(hex_port, 16) == port:  # 0A: LISTEN
                found.add(address)
    return found


def test_serve_hosts_web_viewer_and_grpc_on_localhost_only(tmp_path):
    grpc_port, web_port = free_port(), free_port()
    session = open_recording(
        "test", live="serve", save=tmp_path / "live.rrd", grpc_port=grpc_port, web_port=web_port
    )
    try:
        assert session.viewer_url.startswith(f"http://127.0.0.1:{web_port}/?url=rerun%2Bhttp")
        with urllib.request.urlopen(session.viewer_url, timeout=10) as page:
            assert page.status == 200 and b"<html" in page.read(2000).lower()
        for port in (grpc_port, web_port):
            assert listening_addresses(port) == {"0100007F"}  # 127.0.0.1 and nothing else
        session.stream.log("probe", rr.Points3D([[0.0, 0.0, 0.0]]))
    finally:
        session.close()
    assert session.server.process.returncode is not None
    assert "/probe" in Recording(tmp_path / "live.rrd").entities


def test_sigterm_stops_the_served_viewer_and_a_taken_port_is_one_error(inputs):
    """`kill` ends `resus view --rerun serve` like Ctrl-C: its server goes too and frees the
    ports; a port that is still taken is one error line and exit 2, not a silent success."""
    grpc_port, web_port = free_port(), free_port()
    command = [
        sys.executable, "-m", "resus", "view", str(inputs["sweep"]), "--rerun", "serve",
        "--grpc-port", str(grpc_port), "--web-port", str(web_port),
    ]  # fmt: skip
    viewer = subprocess.Popen(command, stdout=subprocess.PIPE, stderr=subprocess.PIPE, text=True)
    try:
        assert viewer.stdout is not None
        for line in viewer.stdout:  # wait until it serves
            if line.startswith("serving"):
                break
        # while it serves, a second viewer on the same ports is refused in one line
        second = resus("view", inputs["sweep"], "--rerun", "serve",
                       "--grpc-port", grpc_port, "--web-port", web_port)  # fmt: skip
        assert second.returncode == 2, second.stdout + second.stderr
        lines = second.stderr.strip().splitlines()
        assert len(lines) == 1 and lines[0].startswith("error: grpc_port"), second.stderr
        assert f"{grpc_port} on 127.0.0.1 is in use" in lines[0]
        viewer.send_signal(signal.SIGTERM)
        assert viewer.wait(timeout=30) == 0  # a served viewer ends on Ctrl-C; kill is the same
    finally:
        viewer.kill()
        viewer.wait(timeout=10)
    deadline = time.monotonic() + 10
    while listening_addresses(grpc_port) or listening_addresses(web_port):
        assert time.monotonic() < deadline, "the rerun server outlived its viewer command"
        time.sleep(0.1)


@pytest.mark.parametrize(
    ("ports", "message"), [((0, 9090), "grpc_port"), ((9876, 70000), "web_port")]
)
def test_a_port_out_of_range_is_refused_before_a_server_starts(ports, message):
    with pytest.raises(ResusError, match=rf"^{message} must be a port number in 1-65535, got"):
        WebViewerServer(*ports)
