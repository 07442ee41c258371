"""Scanning the simulated phantom through the acquisition interface, end to end.

Real parts throughout: the MuJoCo UR3e, the synthetic ultrasound, the HDF5 writer.
"""

import dataclasses
import re
import time

import numpy as np
import pytest

from resus.acquisition.backends.simulated import (
    SimulatedProbe,
    SimulatedProbeConfig,
    SimulatedRobot,
)
from resus.acquisition.patterns import linear_sweep
from resus.acquisition.robot import host_clock_offset
from resus.acquisition.safety import SafetyLimits, SafetyViolation
from resus.acquisition.scanner import ScanAborted, Scanner, ScannerSettings
from resus.errors import ResusError
from resus.sweep.io import read_sweep
from sim.transforms import invert_pose
from sim.ultrasound.probe import LinearProbe

SMALL_PROBE = LinearProbe(cols=96, rows=96)


def scan(tmp_path, *, robot=None, config=None, settings=None, limits=None, **pattern):
    robot = robot or SimulatedRobot()
    probe = SimulatedProbe(robot, config or SimulatedProbeConfig(probe=SMALL_PROBE))
    trajectory = linear_sweep(
        probe.phantom, robot.scene.phantom_to_base, **{"length": 0.01, **pattern}
    )
    scanner = Scanner(robot, probe, limits, settings or ScannerSettings(progress=False))
    path = tmp_path / "sweep.h5"
    return robot, probe, scanner, trajectory, path


def label_mismatch(sweep, probe, robot) -> np.ndarray:
    """Per frame: fraction of pixels whose label differs from the phantom's at the recorded
    pose (an independent lookup: pixel -> probe -> base -> phantom -> geometry)."""
    base_to_phantom = invert_pose(robot.scene.phantom_to_base)
    pixels = probe.config.probe.pixel_points().reshape(-1, 3)
    mismatch = []
    for frame in range(len(sweep)):
        pose = base_to_phantom @ sweep.probe_to_base[frame]
        truth = probe.phantom.labels(pixels @ pose[:3, :3].T + pose[:3, 3])
        mismatch.append(np.mean(truth != sweep.labels[frame].ravel()))
    return np.array(mismatch)


def test_recorded_poses_and_force_match_the_simulation(tmp_path) -> None:
    robot, probe, scanner, trajectory, path = scan(tmp_path)
    result = scanner.run(trajectory, path, source="sim", subject="test")
    sweep = read_sweep(path)
    assert len(sweep) == result.frames >= int(trajectory.duration * 30) - 1
    assert sweep.labels is not None and (sweep.labels == 1).any() and (sweep.labels == 2).any()
    # Every frame's labels are the phantom's labels at the pixels mapped through the pose.
    assert label_mismatch(sweep, probe, robot).max() < 1e-3
    # Force mode held the commanded 4 N along the probe axis on every frame.
    along_probe = np.einsum("ni,ni->n", sweep.wrench[:, :3], sweep.probe_to_base[:, :3, 2])
    np.testing.assert_allclose(along_probe, 4.0, rtol=0.1)
    # The probe travelled the planned 10 mm along the phantom's y axis.
    travel = sweep.probe_to_base[-1, :3, 3] - sweep.probe_to_base[0, :3, 3]
    assert np.linalg.norm(travel) == pytest.approx(0.01, abs=0.5e-3)


class LaggingRobot(SimulatedRobot):
    """A simulated arm whose servo loop misses one control period in every `every` passes,
    as on a busy host: the robot's clock runs on while no target is sent."""

    def __init__(self, every: int) -> None:
        super().__init__()
        self.every = every
        self.passes = 0

    def wait_period(self) -> None:
        super().wait_period()
        self.passes += 1
        if self.passes % self.every == 0:
            super().wait_period()


def test_a_loop_that_falls_behind_still_sweeps_the_whole_path_on_time(tmp_path) -> None:
    _, _, scanner, trajectory, path = scan(tmp_path, robot=LaggingRobot(every=4))
    scanner.run(trajectory, path, source="sim")
    sweep = read_sweep(path)
    # A quarter of the periods missed: targets follow the robot's clock, not the pass count,
    # so the probe still covers the planned 10 mm in the planned time.
    travel = sweep.probe_to_base[-1, :3, 3] - sweep.probe_to_base[0, :3, 3]
    assert np.linalg.norm(travel) == pytest.approx(0.01, abs=0.5e-3)
    span = sweep.timestamps[-1] - sweep.timestamps[0]
    assert span == pytest.approx(trajectory.duration, abs=2 / trajectory.frame_rate)


@pytest.mark.parametrize(
    ("setting", "message"),
    [
        ({"frame_rate": 0.0}, "SimulatedProbeConfig.frame_rate must be positive, got 0.0"),
        ({"latency": -0.1}, "SimulatedProbeConfig.latency must be >= 0, got -0.1"),
    ],
)
def test_probe_config_refuses_bad_values_naming_the_setting(setting, message) -> None:
    with pytest.raises(ResusError, match=re.escape(message)):
        SimulatedProbeConfig(**setting)


def test_late_frames_on_an_offset_clock_are_placed_by_the_time_offset(tmp_path) -> None:
    config = SimulatedProbeConfig(probe=SMALL_PROBE, latency=0.08, clock_offset=0.25)
    settings = ScannerSettings(progress=False, time_offset=-0.25)
    robot, probe, scanner, trajectory, path = scan(
        tmp_path, config=config, settings=settings, length=0.015, tilt_deg=10.0
    )
    scanner.run(trajectory, path, source="sim")
    sweep = read_sweep(path)
    assert len(sweep) > 20
    assert label_mismatch(sweep, probe, robot).max() < 1e-3


def test_uncorrected_clock_offset_misplaces_frames(tmp_path) -> None:
    config = SimulatedProbeConfig(probe=SMALL_PROBE, clock_offset=-0.3)
    robot, probe, scanner, trajectory, path = scan(
        tmp_path, config=config, length=0.015, tilt_deg=10.0
    )
    scanner.run(trajectory, path, source="sim")
    sweep = read_sweep(path)
    # Poses from 0.3 s later (3 mm along the vessels) no longer explain the labels.
    assert label_mismatch(sweep, probe, robot).mean() > 5e-3


def test_force_limit_violation_stops_and_keeps_a_shorter_sweep(tmp_path) -> None:
    # Position control along a path that dives 12 mm into the gel: the contact force grows
    # until it breaks the 8 N limit part-way.
    robot, _probe, scanner, trajectory, path = scan(
        tmp_path, limits=SafetyLimits(max_force=8.0), contact_force=None, length=0.02
    )
    dive = trajectory.waypoints.copy()
    depth = np.linspace(0.0, 0.012, len(dive))
    dive[:, :3, 3] += depth[:, None] * dive[:, :3, 2]
    trajectory = dataclasses.replace(trajectory, waypoints=dive)
    planned = int(trajectory.duration * trajectory.frame_rate)
    with pytest.raises(ScanAborted, match=r"contact force .* exceeds the limit 8\.0 N") as error:
        scanner.run(trajectory, path, source="sim")
    sweep = read_sweep(path)
    assert 0 < len(sweep) == error.value.result.frames < planned
    assert np.abs(robot.ur3e.joint_velocities()).max() < 1e-3  # the robot was stopped


def test_a_light_press_settles_and_sweeps_at_its_force(tmp_path) -> None:
    """1 N, a vascular scan's touch: force mode crosses the approach gap slowly at so small
    a force, and the press must still settle within the default wait (it did not in 5 s)."""
    _robot, _probe, scanner, trajectory, path = scan(tmp_path, contact_force=1.0)
    scanner.run(trajectory, path, source="sim")
    sweep = read_sweep(path)
    along_probe = np.einsum("ni,ni->n", sweep.wrench[:, :3], sweep.probe_to_base[:, :3, 2])
    np.testing.assert_allclose(along_probe, 1.0, rtol=0.1)


def test_a_press_that_does_not_settle_in_time_stops_in_one_line(tmp_path) -> None:
    robot, _probe, scanner, trajectory, path = scan(
        tmp_path, settings=ScannerSettings(settle_time=0.5, progress=False)
    )
    with pytest.raises(
        ScanAborted, match=r"no stable contact: force 0\.00 N after 0\.5 s, wanted 4"
    ) as error:
        scanner.run(trajectory, path, source="sim")
    assert error.value.result.frames == 0
    assert np.abs(robot.ur3e.joint_velocities()).max() < 1e-3  # the robot was stopped


def test_plan_outside_the_workspace_is_refused_before_moving(tmp_path) -> None:
    limits = SafetyLimits(workspace_min=(-0.45, -0.45, 0.10), workspace_max=(0.45, 0.45, 0.45))
    robot, _probe, scanner, trajectory, path = scan(tmp_path, limits=limits)
    start_time = robot.time()
    with pytest.raises(SafetyViolation, match="unsafe plan 'linear': pose 0: TCP z"):
        scanner.run(trajectory, path, source="sim")
    assert robot.time() == start_time
    assert not path.exists()


def test_a_live_rerun_listener_sees_every_recorded_frame(tmp_path) -> None:
    from rerun_readback import Recording

    from resus.visualize import SweepLogger, open_recording

    robot, probe, _, trajectory, path = scan(tmp_path)
    rrd = tmp_path / "live.rrd"
    with open_recording("test", save=rrd) as session:
        logger = SweepLogger(session.stream, probe.image_to_probe)
        scanner = Scanner(
            robot, probe, settings=ScannerSettings(progress=False), listeners=[logger]
        )
        scanner.run(trajectory, path, source="sim")
    sweep = read_sweep(path)
    recording = Recording(rrd)
    assert logger.count == len(sweep)
    np.testing.assert_allclose(recording.times("/frame/image", "time"), sweep.timestamps)


def test_host_clock_offset_puts_the_hosts_clock_on_the_robots() -> None:
    """The simulated robot's clock is the simulation's (0 at the start, still between
    commands), so the offset is minus the host's monotonic time when it was read."""
    robot = SimulatedRobot()
    before = time.monotonic()
    offset = host_clock_offset(robot)
    after = time.monotonic()
    assert robot.time() - after <= offset <= robot.time() - before
