"""Temporal calibration recovers a known image-vs-pose delay from a simulated oscillation."""

from __future__ import annotations

import dataclasses
import subprocess
import sys

import numpy as np
import pytest
from cli_runner import one_line_error, run_main

from resus.acquisition.backends.simulated import (
    SimulatedProbe,
    SimulatedProbeConfig,
    SimulatedRobot,
)
from resus.acquisition.calibration.temporal import calibrate_time, image_shifts, oscillation
from resus.acquisition.patterns import skin_poses
from resus.acquisition.scanner import Scanner, ScannerSettings
from resus.acquisition.trajectory import Trajectory
from resus.errors import ResusError
from resus.sweep.io import read_sweep
from sim.robot.scene_config import load_scene_config, scene_path
from sim.ultrasound.probe import LinearProbe

CLOCK_OFFSET = 0.2
"""The probe stamps frames 0.2 s ahead of the robot clock..."""
LATENCY = 0.05
"""...and delivers them 50 ms late (which must not matter: the stamp is taken at capture)."""
TOLERANCE = 0.004
"""Two control periods (s)."""


@pytest.fixture(scope="module")
def calibration_sweep(tmp_path_factory):
    """Two +-5 mm cycles along the probe's array on the default phantom, scanned with the
    probe clock offset uncorrected (time_offset 0): frames are paired with poses 0.2 s late."""
    robot = SimulatedRobot()
    config = SimulatedProbeConfig(
        probe=LinearProbe(cols=128, rows=128), clock_offset=CLOCK_OFFSET, latency=LATENCY
    )
    probe = SimulatedProbe(robot, config)
    heading = np.array([0.0, 1.0, 0.0])
    centre = skin_poses(
        probe.phantom, robot.scene.phantom_to_base, np.zeros((1, 2)), heading, np.zeros(1)
    )[0]
    path = tmp_path_factory.mktemp("calibration") / "oscillation.h5"
    scanner = Scanner(robot, probe, settings=ScannerSettings(progress=False))
    scanner.run(oscillation(centre, amplitude=0.005, cycles=2), path, source="sim")
    return path


def test_recovers_the_probe_clock_offset_within_two_control_periods(calibration_sweep, tmp_path):
    result = calibrate_time(read_sweep(calibration_sweep))
    # Frames stamped robot time + 0.2 s were taken 0.2 s before their recorded time.
    assert result.offset == pytest.approx(-CLOCK_OFFSET, abs=TOLERANCE)
    assert result.correlation > 0.99
    # the command line prints the same and draws the signals
    plot = tmp_path / "calibration.png"
    command = [sys.executable, "-c", "from resus.cli.app import main; main()", "calibrate-time"]
    done = subprocess.run(
        [*command, str(calibration_sweep), "--range", "-0.4:0.4", "--plot", str(plot)],
        capture_output=True, text=True, timeout=120,
    )  # fmt: skip
    assert done.returncode == 0, done.stderr
    printed = float(done.stdout.split("time offset ")[1].split(" s")[0])
    assert printed == pytest.approx(-CLOCK_OFFSET, abs=TOLERANCE)
    assert plot.stat().st_size > 10_000


def test_image_shifts_measure_a_known_translation():
    rng = np.random.default_rng(0)
    base = rng.normal(size=(96, 140))
    frames = np.stack([base[:, 20:120], base[:, 17:117], base[:, 25:125]])  # content moves
    shifts = image_shifts(frames)
    np.testing.assert_allclose(shifts, [[0, 0], [3, 0], [-5, 0]], atol=0.05)


def test_a_sweep_without_in_plane_motion_or_too_short_is_refused(calibration_sweep):
    sweep = read_sweep(calibration_sweep)
    with pytest.raises(ResusError, match="too short for the search range"):
        calibrate_time(sweep, (-3.0, 3.0))
    still = dataclasses.replace(
        sweep, probe_to_base=np.repeat(sweep.probe_to_base[:1], len(sweep), axis=0)
    )
    with pytest.raises(ResusError, match="did not move in its image plane"):
        calibrate_time(still)


def test_the_calibration_plan_oscillates_along_the_array_on_the_skin(monkeypatch, capsys, tmp_path):
    """`resus calibration-plan` against the geometry worked out by hand: the default scene's
    phantom is a block whose top face (the skin) is its frame's z = 0, placed without rotation,
    so the centre is the start point on that face, the array lies along the asked direction and
    the beam points down; the probe swings the amplitude to either side of it."""
    out = tmp_path / "cal.yaml"
    status, printed, err = run_main(
        monkeypatch, capsys, "calibration-plan", out, "--start", "0.01,-0.02", "--direction",
        "1,1", "--amplitude", "0.004", "--cycles", "2", "--force", "3", "--frame-rate", "20",
    )  # fmt: skip
    assert status == 0, err
    plan = Trajectory.from_yaml(out)
    assert printed == f"wrote {out}: 2 cycles of +-4.0 mm in {plan.duration:.1f} s\n"
    phantom_to_base = load_scene_config(scene_path("default")).phantom_to_base
    np.testing.assert_allclose(phantom_to_base[:3, :3], np.eye(3), atol=1e-12)
    centre = phantom_to_base[:3, 3] + [0.01, -0.02, 0.0]
    array = np.array([1.0, 1.0, 0.0]) / np.sqrt(2.0)
    for pose in plan.waypoints:
        np.testing.assert_allclose(pose[:3, 0], array, atol=1e-9)
        np.testing.assert_allclose(pose[:3, 2], [0.0, 0.0, -1.0], atol=1e-9)
    sides = np.array([1.0, -1.0, 1.0, -1.0, 1.0])  # two cycles: out, back, out, back
    np.testing.assert_allclose(plan.waypoints[:, :3, 3], centre + 0.004 * np.outer(sides, array))
    assert (plan.speed, plan.contact_force, plan.frame_rate) == (0.01, 3.0, 20.0)
    assert plan.pattern == {"pattern": "oscillation", "amplitude": 0.004, "cycles": 2}

    status, _, err = run_main(monkeypatch, capsys, "calibration-plan", out, "--force", "0")
    assert status == 0, err
    assert Trajectory.from_yaml(out).contact_force is None  # position control


@pytest.mark.parametrize(
    ("flag", "value", "message"),
    [
        ("--amplitude", "0", "--amplitude: oscillation amplitude must be positive, got 0.0"),
        ("--cycles", "0", "--cycles: oscillation cycles must be at least 1, got 0"),
        ("--speed", "0", "--speed: Trajectory.speed must be positive, got 0.0"),
        ("--frame-rate", "-1", "--frame-rate: Trajectory.frame_rate must be positive, got -1.0"),
    ],
)
def test_a_refused_calibration_plan_value_is_named_by_its_flag(
    monkeypatch, capsys, tmp_path, flag: str, value: str, message: str
) -> None:
    out = tmp_path / "cal.yaml"
    one_line_error(run_main(monkeypatch, capsys, "calibration-plan", out, flag, value), message)
    assert not out.exists()
