"""Temporal calibration recovers a known image-vs-pose delay from a simulated oscillation."""

from __future__ import annotations

import dataclasses
import subprocess
import sys

import numpy as np
import pytest

from resus.acquisition.backends.simulated import (
    SimulatedProbe,
    SimulatedProbeConfig,
    SimulatedRobot,
)
from resus.acquisition.calibration.temporal import calibrate_time, image_shifts, oscillation
from resus.acquisition.patterns import skin_poses
from resus.acquisition.scanner import Scanner, ScannerSettings
from resus.errors import ResusError
from resus.sweep.io import read_sweep
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
