"""A compression plan scanned in simulation: the scanner re-sends force mode along the force
profile, and every frame's recorded wrench shows the press."""

import numpy as np
import pytest

from resus.acquisition.backends.simulated import (
    SimulatedProbe,
    SimulatedProbeConfig,
    SimulatedRobot,
)
from resus.acquisition.patterns import compression_sweep
from resus.acquisition.scanner import Scanner, ScannerSettings
from resus.errors import ResusError
from resus.sweep.io import read_sweep
from sim.ultrasound.probe import LinearProbe

PRESS = {"stations": 2, "station_spacing": 0.01, "press_time": 1.0, "hold_time": 0.5,
         "light_time": 0.5, "frame_rate": 10.0}  # fmt: skip
"""Two stations 10 mm apart, each pressing 2 -> 12 -> 2 N in 3.5 s; 8.2 s in all."""
LAG = 0.2
"""How far (s) the contact force trails its setpoint: the admittance loop's lag on the
phantom, measured 0.2 s (RMS error 0.53 N against the profile 0.2 s late, 1.21 N on time)."""


class _SetpointRecorder(SimulatedRobot):
    """The simulated robot, keeping every force-mode setpoint it is sent."""

    def __init__(self) -> None:
        super().__init__()
        self.setpoints: list[float] = []

    def force_mode(self, force: float) -> None:
        self.setpoints.append(force)
        super().force_mode(force)


def test_the_recorded_force_follows_the_press_profile(tmp_path) -> None:
    robot = _SetpointRecorder()
    config = SimulatedProbeConfig(probe=LinearProbe(cols=32, rows=32), frame_rate=10.0)
    probe = SimulatedProbe(robot, config)
    plan = compression_sweep(probe.phantom, robot.scene.phantom_to_base, **PRESS)
    scanner = Scanner(robot, probe, settings=ScannerSettings(progress=False))
    scanner.run(plan, tmp_path / "press.h5", source="sim")
    sweep = read_sweep(tmp_path / "press.h5")
    # Setpoints: the light force of the descent, then up and down in steps of at most
    # ScannerSettings.force_step (0.1 N; the loop sends the due one), ending at light contact.
    steps = np.diff(robot.setpoints)
    assert robot.setpoints[0] == 2.0 and robot.setpoints[-1] == pytest.approx(2.0)
    assert max(robot.setpoints) == pytest.approx(12.0) and np.abs(steps).max() < 0.15
    assert 300 < len(robot.setpoints) <= 1 + 4 * 100  # 10 N up and down at <= 0.12 N a step
    # Every frame's force along the probe axis follows the profile, LAG late.
    along = sweep.axial_force
    times = sweep.timestamps - sweep.timestamps[0]
    error = along - plan.force_at(times - LAG)
    assert np.sqrt(np.mean(error**2)) < 0.8, error
    assert np.abs(error).max() < 1.8, error  # measured 1.27 N, at the turns of the press
    for start, end in plan.stop_times():
        press = along[(times >= start) & (times <= end)]
        assert press.max() > 11.0 and press[0] == pytest.approx(2.0, abs=0.15)  # 11.5 N, 1.95 N


def test_a_bad_force_step_is_a_clear_error() -> None:
    with pytest.raises(ResusError, match=r"ScannerSettings\.force_step must be positive, got 0"):
        ScannerSettings(force_step=0)
