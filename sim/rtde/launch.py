"""Start an emulator as a subprocess for tests and benchmarks, and always stop it.

ur_rtde's RTDE and script clients connect to fixed ports (30004, 30003), so parallel
emulators cannot be told apart by port. They are told apart by address instead: each one
binds its own loopback address 127.0.0.N (all of 127/8 reaches this host on Linux), found
free by binding. Injected faults are logged with the emulator time and the `time.monotonic()`
at which they struck (one clock for every process on Linux), which `fault_emulator_time()` and
`fault_time()` read back: a motion-relative fault's time is known only once it has struck.
"""

from __future__ import annotations

import os
import random
import re
import select
import socket
import subprocess
import sys
import tempfile
import time
from collections.abc import Iterator
from contextlib import contextmanager
from dataclasses import dataclass
from pathlib import Path

from sim.rtde.server import Ports

START_TIMEOUT = 90.0
"""Seconds to wait for the ready line: the MuJoCo arm builds its scene and phantom first, about
6 s on an idle machine and several times that on two busy cores."""


@dataclass
class RunningEmulator:
    """A live emulator process."""

    host: str
    process: subprocess.Popen
    ready_at: float
    """`time.monotonic()` when it reported ready: about its clock's zero."""
    log_path: Path

    def log(self) -> str:
        """Everything it wrote to stderr so far (its log lines)."""
        return self.log_path.read_text(errors="replace")

    def fault_time(self) -> float | None:
        """`time.monotonic()` at which the first injected fault struck, or None yet."""
        match = re.search(r"injected fault.*?monotonic ([0-9.]+)", self.log())
        return None if match is None else float(match.group(1))

    def fault_emulator_time(self) -> float | None:
        """Emulator time (s, the robot clock RTDE reports) of the first injected fault."""
        match = re.search(r"injected fault at t=([0-9.]+) s", self.log())
        return None if match is None else float(match.group(1))


def _address_free(host: str, ports: Ports) -> bool:
    sockets = []
    try:
        for port in (ports.dashboard, ports.rtde, ports.script):
            sock = socket.socket(socket.AF_INET, socket.SOCK_STREAM)
            sockets.append(sock)
            sock.bind((host, port))
        return True
    except OSError:
        return False
    finally:
        for sock in sockets:
            sock.close()


def _candidate_hosts() -> list[str]:
    hosts = [f"127.0.0.{n}" for n in range(2, 255)]
    random.Random(os.getpid() ^ time.monotonic_ns()).shuffle(hosts)
    return hosts


def free_host() -> str:
    """A loopback address where nothing listens on UR's ports: a controller that is off."""
    for host in _candidate_hosts():
        if _address_free(host, Ports()):
            return host
    raise RuntimeError("no free loopback address")


def _wait_ready(process: subprocess.Popen, deadline: float) -> bool:
    """True when the ready line arrived; False when the process ended first."""
    assert process.stdout is not None  # started with stdout=PIPE
    while time.monotonic() < deadline:
        readable, _, _ = select.select([process.stdout], [], [], 0.1)
        if readable:
            line = process.stdout.readline()
            if line.startswith("emulator ready"):
                return True
            if not line and process.poll() is not None:
                return False
    raise TimeoutError(f"RTDE emulator not ready within {START_TIMEOUT:.0f} s")


def _stop(process: subprocess.Popen) -> None:
    if process.poll() is None:
        process.terminate()
        try:
            process.wait(timeout=5.0)
        except subprocess.TimeoutExpired:
            process.kill()
            process.wait()
    if process.stdout is not None:
        process.stdout.close()


@contextmanager
def launch(
    arm: str = "kinematic",
    faults: tuple[str, ...] = (),
    scene: str | None = None,
    seed: int = 0,
) -> Iterator[RunningEmulator]:
    """Run `python -m sim.rtde` on a free loopback address; stop it on leaving, always."""
    handle, name = tempfile.mkstemp(prefix="rtde-emulator-", suffix=".log")
    os.close(handle)
    log_path = Path(name)
    process = None
    try:
        with log_path.open("w") as log_file:
            for host in _candidate_hosts():
                if not _address_free(host, Ports()):
                    continue
                command = [sys.executable, "-m", "sim.rtde", "--host", host, "--arm", arm]
                command += ["--seed", str(seed)] + [f"--fault={fault}" for fault in faults]
                if scene is not None:
                    command += ["--scene", scene]
                process = subprocess.Popen(
                    command, stdout=subprocess.PIPE, stderr=log_file, text=True
                )
                if _wait_ready(process, time.monotonic() + START_TIMEOUT):
                    yield RunningEmulator(host, process, time.monotonic(), log_path)
                    return
                _stop(process)  # lost a race for the address: try the next one
                if "Address already in use" not in log_path.read_text(errors="replace"):
                    raise RuntimeError(f"RTDE emulator failed to start:\n{log_path.read_text()}")
            raise RuntimeError("no free loopback address for an RTDE emulator")
    finally:
        if process is not None:
            _stop(process)
        log_path.unlink(missing_ok=True)
