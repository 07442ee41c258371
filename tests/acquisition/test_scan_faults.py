"""`resus scan` against the RTDE emulator when things go wrong: a dropped link and a protective
stop mid-sweep, and a plan that leaves the workspace box. The scan subprocess uses the real
ur_rtde client; this process watches the controller through its own RTDE client.

The faults strike at emulator time FAULT_TIME, inside a 9 s sweep that starts 6-9 s after the
emulator is ready (process start-up, render worker, approach and contact), up to 13 s on a
heavily loaded machine.
"""

from __future__ import annotations

import time

import numpy as np
import pytest
from scan_session import last_line, pose_at_rest, scan_and_watch, write_linear_plan

from resus.sweep.io import read_sweep
from sim.rtde.launch import launch

pytestmark = [pytest.mark.slow, pytest.mark.hang_guard]


FAULT_TIME = 14.0
"""Emulator time of the injected faults (s)."""
DROP_FOR = 1.0
"""How long the dropped link refuses connections (s)."""
FRAME_GAP = 0.3
"""Largest gap between consecutive recorded frames (s): 10 Hz, and a frame skipped while the
synthetic probe's render process is busy."""
IN_FLIGHT = 0.45
"""Frames taken this long before a fault may be lost with it: rendering in flight."""


def scan_arguments(tmp_path, *extra: str) -> list[str]:
    plan = write_linear_plan(
        tmp_path / "plan.yaml", start=(0.045, 0.0), direction=(-1.0, 0.0), length=0.09
    )  # home orientation (array along base y): the approach is a straight descent
    return [
        "--probe", "sim:96x96", "--trajectory", str(plan), "--out", str(tmp_path / "sweep.h5"),
        "--yes", "--approach-speed", "0.1", *extra,
    ]  # fmt: skip


def check_frames_kept_until(sweep_path, fault_time: float) -> int:
    """The Sweep reads back, holds frames up to the fault without gaps; returns how many."""
    sweep = read_sweep(sweep_path)
    times = sweep.timestamps
    assert len(sweep) >= 5
    assert times[-1] < fault_time, "a frame was recorded after the fault"
    assert fault_time - times[-1] < IN_FLIGHT, f"last frame {fault_time - times[-1]:.3f} s early"
    assert np.diff(times).max() < FRAME_GAP
    return len(sweep)


def test_dropped_link_mid_sweep_stops_keeps_the_frames_and_fails_in_one_line(tmp_path):
    faults = (f"drop@{FAULT_TIME}+{DROP_FOR}",)
    with launch(arm="mujoco", scene="default", faults=faults) as emulator:
        watched = scan_and_watch(emulator.host, tmp_path, *scan_arguments(tmp_path))
        fault_at = emulator.fault_time()
        assert fault_at is not None
        # the command noticed at once, then gave ur_rtde's own reconnection 2 s to settle
        assert watched.ended_at - fault_at < 6.0
        assert watched.returncode == 2
        line = last_line(watched.stderr)
        assert line.startswith("error: scan stopped: ") and "lost" in line, watched.stderr
        assert "keeps the" in line and watched.stderr.count("error:") == 1
        check_frames_kept_until(tmp_path / "sweep.h5", FAULT_TIME)
        # The link is back: the arm stands still, near where the link dropped (the controller
        # finishes the last servo step it was given, then holds).
        time.sleep(max(0.0, fault_at + DROP_FOR + 0.2 - time.monotonic()))
        rest, moved = pose_at_rest(emulator.host)
        assert moved < 1e-5
        before_drop = watched.poses[watched.times < FAULT_TIME][-1]
        assert np.linalg.norm(rest[:3, 3] - before_drop[:3, 3]) < 2e-3


def test_protective_stop_mid_sweep_stops_keeps_the_frames_and_fails_in_one_line(tmp_path):
    faults = (f"protective-stop@{FAULT_TIME}",)
    with launch(arm="mujoco", scene="default", faults=faults) as emulator:
        watched = scan_and_watch(emulator.host, tmp_path, *scan_arguments(tmp_path))
        fault_at = emulator.fault_time()
        # the arm's stop is measured below from the watcher; the command's exit also waits
        # for the render worker and the interpreter to close, seconds on a loaded machine
        assert fault_at is not None and watched.ended_at - fault_at < 6.0
        assert watched.returncode == 2
        line = last_line(watched.stderr)
        assert line.startswith("error: scan stopped: ") and "protective stop" in line, line
        check_frames_kept_until(tmp_path / "sweep.h5", FAULT_TIME)
        # The watcher saw the arm moving at the scan speed until the stop, then at rest.
        sweeping = (watched.times > FAULT_TIME - 0.5) & (watched.times < FAULT_TIME)
        assert np.median(watched.speeds[sweeping]) > 0.003
        moving = watched.times[watched.speeds > 1e-3]
        assert moving.max() - FAULT_TIME < 0.05, f"moved {moving.max() - FAULT_TIME:.3f} s on"
        _, moved = pose_at_rest(emulator.host)
        assert moved < 1e-5


def test_plan_outside_the_workspace_is_refused_before_anything_moves(tmp_path):
    workspace = "-0.45,-0.45,0.10,0.45,0.45,0.45"  # the phantom top (z 0.06) lies below
    with launch(arm="mujoco", scene="default") as emulator:
        watched = scan_and_watch(
            emulator.host, tmp_path, *scan_arguments(tmp_path, "--workspace", workspace)
        )
        log = emulator.log()
    assert watched.returncode == 2
    assert watched.stderr.strip() == (
        "error: unsafe plan 'linear': pose 0: TCP z = 0.070 m leaves the workspace box "
        "[0.100, 0.450] m"
    )
    assert not (tmp_path / "sweep.h5").exists()
    assert len(watched.times) > 50
    travel = np.linalg.norm(watched.poses[:, :3, 3] - watched.poses[0, :3, 3], axis=1)
    assert travel.max() < 1e-6  # the robot never moved
    assert "program stopped: stopScript" in log  # and the connection was closed properly
