"""Every scan pattern that `resus plan` passes runs to its end on the RTDE emulator (the real
ur_rtde client, the MuJoCo arm on the phantom), and a scan stopped by Ctrl-C says one line.

The compression pattern has a test of its own: its force varies, so the sweep's force is held
to its profile, not to one contact force. The fan is the pattern that was stopped before
(`contact force 22.1 N exceeds the limit 20.0 N`, 4 frames in): its probe rocks about the
face, and a late servo target jerked the arm. The sweeps are short, one emulator serves them
all, and they run one after another on one connection and one synthetic probe, as a session of
scans would.
"""

from __future__ import annotations

import os
import signal
import subprocess
import sys
import time

import numpy as np
import pytest
from scan_session import default_scene_and_phantom, write_linear_plan

from resus.acquisition.factory import RTDERobotConfig, SimulatedProbeConfig, make_probe, make_robot
from resus.acquisition.patterns import PATTERNS, CompressionPattern
from resus.acquisition.safety import SafetyLimits
from resus.acquisition.scanner import Scanner, ScannerSettings
from resus.planning.planner import PlanSettings, check_plan
from resus.sweep.io import read_sweep
from sim.rtde.launch import launch
from sim.ultrasound.probe import LinearProbe

pytestmark = [pytest.mark.slow, pytest.mark.hang_guard]

SHORT = {
    "linear": {"start": (0.0, -0.004), "length": 0.008},
    "fan": {"fan_deg": 20.0},
    "multipass": {"start": (-0.003, -0.003), "length": 0.006, "passes": 2, "offset": 0.006},
    "raster": {"start": (-0.003, -0.003), "length": 0.006, "passes": 2, "offset": 0.006},
}
"""Each pattern's settings for a sweep of one or two seconds over both vessels, at 12 mm/s and
10 frames/s (a synthetic frame costs about 45 ms of CPU on cores shared with the emulator)."""
VOXEL = 1.5e-3
"""Voxel size the plans are checked against (m): frames 1.2 mm apart."""
PRESS = {"stations": 2, "station_spacing": 0.006, "press_force": 10.0, "press_time": 0.75,
         "hold_time": 0.5, "light_time": 0.25, "speed": 0.012, "frame_rate": 10.0}  # fmt: skip
"""A two-station press, 2 -> 10 -> 2 N in 2.5 s at each, 6 mm apart: 5.7 s in all."""


@pytest.fixture(scope="module")
def emulator():
    with launch(arm="mujoco", scene="default") as running:
        yield running


def test_every_pattern_the_planner_passes_runs_to_its_end_on_the_emulator(emulator, tmp_path):
    assert set(SHORT) | {"compression"} == set(PATTERNS), "give every pattern a short sweep"
    scene, phantom = default_scene_and_phantom()
    limits = SafetyLimits()
    plans = {}
    for name, kind in PATTERNS.items():
        if name not in SHORT:
            continue
        pattern = kind(frame_rate=10.0, speed=0.012, **SHORT[name])
        plans[name] = pattern.trajectory(phantom, scene.phantom_to_base)
        analysis = check_plan(plans[name], scene, phantom, PlanSettings(voxel_size=VOXEL))
        assert analysis.passed, [check.line() for check in analysis.checks if not check.passed]
    probe_config = SimulatedProbeConfig(probe=LinearProbe(cols=32, rows=32), frame_rate=10.0)
    settings = ScannerSettings(approach_speed=0.1, progress=False)
    with make_robot(RTDERobotConfig(host=emulator.host)) as robot:
        probe = make_probe(probe_config, robot, scene)
        try:
            scanner = Scanner(robot, probe, limits, settings)
            for name, plan in plans.items():
                result = scanner.run(plan, tmp_path / f"{name}.h5", source="sim")  # no abort
                # At the end: lifted off the path's last pose along the probe axis (from the
                # depth that the contact force pressed it to: about 2 mm).
                end, now = plan.approach_pose(plan.waypoints[-1]), robot.tcp_pose()
                assert np.linalg.norm(now[:3, 3] - end[:3, 3]) < 3e-3, (name, now, end)
                assert now[:3, 2] @ end[:3, 2] > np.cos(np.radians(1.0)), (name, now, end)
                # Frames: the render worker skips them while busy, on a loaded host many.
                sweep = read_sweep(result.path)
                assert len(sweep) >= 3, name
                forces = np.linalg.norm(sweep.wrench[:, :3], axis=1)
                assert forces.max() < 0.5 * limits.max_force, (name, forces.max())
                assert abs(np.median(forces) - plan.contact_force) < 1.0, (name, forces)
        finally:
            probe.close()


def test_a_two_station_press_runs_to_its_end_on_the_emulator(emulator, tmp_path):
    """Force mode re-sent along the press profile through ur_rtde (each re-send holds the
    servo stream for two periods) presses at both stations without tripping a limit."""
    scene, phantom = default_scene_and_phantom()
    plan = CompressionPattern(**PRESS).trajectory(phantom, scene.phantom_to_base)
    analysis = check_plan(plan, scene, phantom, PlanSettings(voxel_size=VOXEL))
    assert analysis.passed, [check.line() for check in analysis.checks if not check.passed]
    limits = SafetyLimits()
    probe_config = SimulatedProbeConfig(probe=LinearProbe(cols=32, rows=32), frame_rate=10.0)
    with make_robot(RTDERobotConfig(host=emulator.host)) as robot:
        probe = make_probe(probe_config, robot, scene)
        try:
            scanner = Scanner(robot, probe, limits, ScannerSettings(approach_speed=0.1,
                                                                    progress=False))  # fmt: skip
            result = scanner.run(plan, tmp_path / "press.h5", source="sim")  # no abort
            end = plan.approach_pose(plan.waypoints[-1])
            assert np.linalg.norm(robot.tcp_pose()[:3, 3] - end[:3, 3]) < 3e-3
        finally:
            probe.close()
    sweep = read_sweep(result.path)
    along = sweep.axial_force
    times = sweep.timestamps - sweep.timestamps[0]
    assert np.linalg.norm(sweep.wrench[:, :3], axis=1).max() < 0.8 * limits.max_force
    for start, stop in plan.stop_times():  # each press shows in the frames taken at it
        pressed = along[(times >= start) & (times <= stop)]
        # Measured 9.5 N of the 10 N press (the force trails its setpoint by about 0.2 s).
        assert len(pressed) >= 5 and pressed.max() > 8.0 and pressed.min() < 3.5, pressed


AS_A_TERMINAL_STARTS_A_JOB = (
    "import os, signal, sys; signal.signal(signal.SIGINT, signal.SIG_DFL); "
    "os.execv(sys.argv[1], sys.argv[1:])"
)
"""Run the command after it with SIGINT back to its default, in the same process (exec keeps
the pid and a default disposition). A shell starts a foreground job so; an xdist worker, by
the time this test runs, has had it ignored (its SigIgn read 0x1001007 in a full suite run:
SIGHUP, SIGINT and SIGQUIT, set by some library below Python's own handler table, which still
showed the default), and a Python started with SIGINT ignored keeps it ignored: the scan
finished its sweep and exited 0. A trampoline rather than `preexec_fn`, which is unsafe in a
parent with threads (the emulator's)."""


def test_ctrl_c_during_a_scan_is_one_line_on_the_console(emulator, tmp_path):
    """Ctrl-C at a terminal reaches the whole foreground process group: the scan process and
    the synthetic probe's render worker, which printed its KeyboardInterrupt traceback beside
    the scan's own line."""
    plan = write_linear_plan(  # 6 s at 10 mm/s: the interrupt, 1 s in, finds it moving
        tmp_path / "plan.yaml", start=(0.0, -0.03), direction=(0.0, 1.0), length=0.06
    )
    out = tmp_path / "sweep.h5"
    command = [sys.executable, "-c", AS_A_TERMINAL_STARTS_A_JOB, sys.executable, "-m", "resus"]
    command += ["scan", "--robot", emulator.host]
    command += ["--probe", "sim:32x32", "--trajectory", str(plan), "--out", str(out)]
    scan = subprocess.Popen(
        [*command, "--yes", "--approach-speed", "0.1"],
        stdin=subprocess.DEVNULL,
        stdout=subprocess.PIPE,
        stderr=subprocess.PIPE,
        text=True,
        start_new_session=True,  # a process group of its own, as a terminal's job has
    )
    deadline = time.monotonic() + 120.0
    while not out.exists() and scan.poll() is None:  # the Sweep opens as the robot moves off
        assert time.monotonic() < deadline, "the scan never started"
        time.sleep(0.1)
    time.sleep(1.0)  # moving: the robot backend and the render worker both run
    assert scan.poll() is None, f"the scan ended (code {scan.returncode}) before the interrupt"
    os.killpg(scan.pid, signal.SIGINT)
    stdout, stderr = scan.communicate(timeout=60.0)
    assert scan.returncode == 2, (stdout, stderr)
    assert stderr.strip().startswith("error: scan stopped: interrupted; the robot was stopped")
    assert len(stderr.strip().splitlines()) == 1, stderr
