"""`resus scan` against the RTDE emulator when things go wrong: a dropped link and a protective
stop mid-sweep, and a plan that leaves the workspace box. The scan subprocess uses the real
ur_rtde client; this process watches the controller through its own RTDE client.

The faults strike FAULT_AFTER seconds after the scan's first motion command, mid-way through
its 9 s sweep: the approach and the contact take about 3.5 s of robot time from that command,
while the scan process's start-up before it (imports, render worker) takes from 6 s to well
over 13 s of wall time depending on the machine's load, which is why the faults are not timed
from the emulator's start.
"""

from __future__ import annotations

import re
import time

import numpy as np
import pytest
from scan_session import last_line, pose_at_rest, scan_and_watch, write_linear_plan

from resus.sweep.io import read_sweep
from sim.rtde.launch import launch

pytestmark = [pytest.mark.slow, pytest.mark.hang_guard]


FAULT_AFTER = 7.0
"""Seconds after the first motion command at which the faults strike (`motion+T`): about
3.5 s into the sweep, which runs from about 3.5 s to 12.5 s after that command."""
STOP_WITHIN = 0.05
"""Robot-clock seconds within which the arm is at rest (below 1 mm/s) after a protective
stop: the emulator freezes the servo setpoint at the stop, and the arm's servos and the gel
under the probe settle in about 25 ms from the smoothed sweep."""
DROP_FOR = 1.0
"""How long the dropped link refuses connections (s)."""
EXIT_WITHIN = 15.0
"""Wall-clock seconds from the fault to the scan command's exit. The command reacts within a
cycle (the robot and the frames are checked by the watcher below); what follows is cleanup:
stopping the render worker (0.5 s, at most 5 s before it is terminated), letting ur_rtde's own
reconnection settle after a lost link (2 s), ur_rtde's disconnects (0.5 s slept per
interface) and the interpreter's exit; about 4 s on an idle machine, two or three times that
when it has to share two cores."""
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


def check_frames_kept_until(sweep_path, fault_time: float, line: str) -> None:
    """The Sweep reads back with every frame the error line says it keeps, in time order, up to
    the fault. The spacing of the frames is not checked: a scan sharing two busy cores may miss
    a render for half a second mid-sweep, which is the host's timing, not the abort path's."""
    sweep = read_sweep(sweep_path)
    times = sweep.timestamps
    kept = re.search(r"keeps the (\d+) frames recorded before it", line)
    assert kept is not None, line
    assert len(sweep) == int(kept.group(1)) >= 5
    assert np.all(np.diff(times) > 0)
    assert times[-1] < fault_time, "a frame was recorded after the fault"
    assert fault_time - times[-1] < IN_FLIGHT, f"last frame {fault_time - times[-1]:.3f} s early"


def test_dropped_link_mid_sweep_stops_keeps_the_frames_and_fails_in_one_line(tmp_path):
    faults = (f"drop@motion+{FAULT_AFTER}+{DROP_FOR}",)
    with launch(arm="mujoco", scene="default", faults=faults) as emulator:
        watched = scan_and_watch(emulator.host, tmp_path, *scan_arguments(tmp_path))
        fault_at, dropped_at = emulator.fault_time(), emulator.fault_emulator_time()
        assert fault_at is not None
        assert watched.ended_at - fault_at < EXIT_WITHIN
        assert watched.returncode == 2
        line = last_line(watched.stderr)
        assert line.startswith("error: scan stopped: ") and "lost" in line, watched.stderr
        # What ur_rtde's own threads print when they find the link gone stays in its process's
        # log (`rtde_link`): the console shows the one line.
        assert "keeps the" in line and watched.stderr.strip() == line, watched.stderr
        check_frames_kept_until(tmp_path / "sweep.h5", dropped_at, line)
        # The link is back: the arm stands still, near where the link dropped (the controller's
        # servo finishes smoothing towards the last target it was given, then holds).
        time.sleep(max(0.0, fault_at + DROP_FOR + 0.2 - time.monotonic()))
        rest, moved = pose_at_rest(emulator.host)
        assert moved < 1e-5
        before_drop = watched.poses[watched.times < dropped_at][-1]
        assert np.linalg.norm(rest[:3, 3] - before_drop[:3, 3]) < 2e-3


def test_protective_stop_mid_sweep_stops_keeps_the_frames_and_fails_in_one_line(tmp_path):
    faults = (f"protective-stop@motion+{FAULT_AFTER}",)
    with launch(arm="mujoco", scene="default", faults=faults) as emulator:
        watched = scan_and_watch(emulator.host, tmp_path, *scan_arguments(tmp_path))
        fault_at, stopped_at = emulator.fault_time(), emulator.fault_emulator_time()
        assert fault_at is not None and watched.ended_at - fault_at < EXIT_WITHIN
        assert watched.returncode == 2
        line = last_line(watched.stderr)
        assert line.startswith("error: scan stopped: ") and "protective stop" in line, line
        # What ur_rtde prints about the stopped script is in the debug log, not on the console.
        assert watched.stderr.strip() == line, watched.stderr
        check_frames_kept_until(tmp_path / "sweep.h5", stopped_at, line)
        # The watcher saw the arm moving at the scan speed until the stop, then at rest.
        sweeping = (watched.times > stopped_at - 0.5) & (watched.times < stopped_at)
        assert np.median(watched.speeds[sweeping]) > 0.003
        moved_on = watched.times[watched.speeds > 1e-3].max() - stopped_at
        assert moved_on < STOP_WITHIN, f"moved {moved_on:.3f} s on"
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
