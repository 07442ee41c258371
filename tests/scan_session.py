"""Helpers for the `resus scan` tests against the RTDE emulator.

`scan_and_watch` runs `resus scan` as a subprocess while this process watches the same
emulator through its own `RTDEReceiveInterface` (a second, independent RTDE client), so the
tests compare what the scan recorded with what the controller published.
"""

from __future__ import annotations

import contextlib
import subprocess
import sys
import time
from dataclasses import dataclass
from pathlib import Path

import numpy as np
import rtde_receive

from resus.acquisition.backends.rtde_link import read_packet
from resus.acquisition.patterns import linear_sweep
from resus.acquisition.simulation import phantom_spec, resolve_scene
from sim.phantom import Phantom
from sim.transforms import pose_from_ur

SCAN_TIMEOUT = 120.0
"""Seconds after which a hung scan subprocess is killed."""
FRAME_RATE = 10.0
"""Frames per second of the test plans."""
WATCH_PERIOD = 0.002
"""How often the watcher reads the controller (s): one control period."""


def default_scene_and_phantom():
    scene = resolve_scene("default", None, None)
    return scene, Phantom(phantom_spec(scene))


def write_linear_plan(
    path: Path, start: tuple[float, float], direction: tuple[float, float], length: float
) -> Path:
    """A linear sweep over the default phantom (phantom frame `start`, `direction`), starting
    near the emulator's home TCP above the phantom's centre. 10 frames/s: a synthetic frame
    costs about 45 ms of CPU, and the tests share two cores with real-time processes."""
    scene, phantom = default_scene_and_phantom()
    plan = linear_sweep(
        phantom, scene.phantom_to_base, start=start, direction=direction, length=length,
        frame_rate=FRAME_RATE,
    )  # fmt: skip
    plan.to_yaml(path)
    return path


@dataclass
class Watched:
    """What the independent RTDE client saw while the scan ran, and how the scan ended."""

    returncode: int
    stdout: str
    stderr: str
    ended_at: float
    """time.monotonic() when the scan process had exited."""
    times: np.ndarray
    """Controller timestamps (s) of the samples."""
    poses: np.ndarray
    """(N, 4, 4) actual TCP poses."""
    speeds: np.ndarray
    """(N,) actual TCP linear speeds (m/s)."""


def read_state(receive: rtde_receive.RTDEReceiveInterface) -> tuple[float, np.ndarray, np.ndarray]:
    """Timestamp, actual TCP pose (UR vector) and TCP speed, all of one RTDE state packet
    (read as the scanner reads its packets: `read_packet`)."""
    stamp, (pose, speed) = read_packet(receive, "getActualTCPPose", "getActualTCPSpeed")
    return stamp, np.array(pose), np.array(speed)


def scan_and_watch(host: str, tmp_path: Path, *args: str) -> Watched:
    """Run `resus scan --robot HOST ARGS`, sampling the controller until it exits."""
    command = [sys.executable, "-c", "from resus.cli.app import main; main()", "scan"]
    command += ["--robot", host, *map(str, args)]
    receive = rtde_receive.RTDEReceiveInterface(host)
    times, poses, speeds = [], [], []
    out, err = tmp_path / "scan.out", tmp_path / "scan.err"
    try:
        with out.open("w") as stdout, err.open("w") as stderr:
            process = subprocess.Popen(
                command, stdout=stdout, stderr=stderr, stdin=subprocess.DEVNULL
            )
            deadline = time.monotonic() + SCAN_TIMEOUT
            while process.poll() is None:
                if time.monotonic() > deadline:
                    process.kill()
                    process.wait()
                    raise AssertionError("resus scan hung")
                with contextlib.suppress(RuntimeError):
                    if receive.isConnected():
                        stamp, pose, speed = read_state(receive)
                        if not times or stamp > times[-1]:
                            times.append(stamp)
                            poses.append(pose)
                            speeds.append(np.linalg.norm(speed[:3]))
                time.sleep(WATCH_PERIOD)
            ended_at = time.monotonic()
    finally:
        with contextlib.suppress(RuntimeError):
            receive.disconnect()
    return Watched(
        process.returncode, out.read_text(), err.read_text(), ended_at,
        np.array(times), pose_from_ur(np.array(poses).reshape(-1, 6)), np.array(speeds),
    )  # fmt: skip


def pose_at_rest(host: str, duration: float = 0.3) -> tuple[np.ndarray, float]:
    """Connect anew and watch the TCP for `duration`: its pose and the largest move (m)."""
    receive = rtde_receive.RTDEReceiveInterface(host)
    try:
        first = pose_from_ur(np.array(receive.getActualTCPPose()))
        moved = 0.0
        end = time.monotonic() + duration
        while time.monotonic() < end:
            pose = pose_from_ur(np.array(receive.getActualTCPPose()))
            moved = max(moved, float(np.linalg.norm(pose[:3, 3] - first[:3, 3])))
            time.sleep(WATCH_PERIOD)
        return first, moved
    finally:
        receive.disconnect()


def positions_at(watched: Watched, times: np.ndarray) -> np.ndarray:
    """The watcher's TCP positions interpolated at `times` (s, controller clock)."""
    return np.stack(
        [np.interp(times, watched.times, watched.poses[:, axis, 3]) for axis in range(3)], axis=1
    )


def last_line(text: str) -> str:
    lines = [line for line in text.strip().splitlines() if line.strip()]
    return lines[-1] if lines else ""
