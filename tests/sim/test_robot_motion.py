"""UR motion semantics of the simulated UR3e: moveL, moveJ, servo, speed, stops."""

import numpy as np
import pytest

from sim.robot import (
    CONTROL_PERIOD,
    HOME_JOINTS,
    ProtectiveStopError,
    SimulatedUR3e,
)
from sim.robot.profiles import TrapezoidalProfile
from sim.transforms import invert_pose


@pytest.fixture
def robot(shared_robot: SimulatedUR3e) -> SimulatedUR3e:
    shared_robot.reset()
    shared_robot.force_limit = 50.0
    return shared_robot


def run_until_steady(robot: SimulatedUR3e, limit: float = 20.0) -> tuple[np.ndarray, np.ndarray]:
    """Step an asynchronous motion to the end; the actual TCP positions and joints per period."""
    positions, joints = [robot.tcp_pose()[:3, 3]], [robot.joint_positions()]
    end = robot.time() + limit
    while not robot.is_steady() and robot.time() < end:
        robot.step()
        positions.append(robot.tcp_pose()[:3, 3])
        joints.append(robot.joint_positions())
    return np.array(positions), np.array(joints)


def test_trapezoidal_profile() -> None:
    trapezoid = TrapezoidalProfile(0.1, 0.05, 0.5)
    assert trapezoid.duration == pytest.approx(0.1 / 0.05 + 0.05 / 0.5)
    assert trapezoid.position(trapezoid.duration) == pytest.approx(0.1)
    assert trapezoid.velocity(1.0) == pytest.approx(0.05)
    triangle = TrapezoidalProfile(0.01, 1.0, 1.0)
    assert triangle.peak_speed == pytest.approx(0.1)
    assert triangle.duration == pytest.approx(0.2)
    assert triangle.position(0.1) == pytest.approx(0.005)
    with pytest.raises(ValueError, match="positive"):
        TrapezoidalProfile(0.1, 0.0, 1.0)


def test_move_linear_follows_a_straight_line_with_a_trapezoidal_speed(robot) -> None:
    start = robot.probe_pose_on_skin(0.0, -0.04, 0.05)
    robot.move_linear(start)
    goal = robot.probe_pose_on_skin(0.02, 0.05, 0.02)
    speed, acceleration = 0.05, 0.25
    began = robot.time()
    robot.move_linear(goal, speed=speed, acceleration=acceleration, asynchronous=True)
    positions, _ = run_until_steady(robot)
    final = robot.tcp_pose()
    assert np.linalg.norm(final[:3, 3] - goal[:3, 3]) < 2e-4
    assert np.abs(final[:3, :3] - goal[:3, :3]).max() < 1e-3
    line = (goal[:3, 3] - start[:3, 3]) / np.linalg.norm(goal[:3, 3] - start[:3, 3])
    offsets = positions - start[:3, 3]
    off_line = offsets - np.outer(offsets @ line, line)
    assert np.linalg.norm(off_line, axis=1).max() < 3e-4
    speeds = np.linalg.norm(np.diff(positions, axis=0), axis=1) / CONTROL_PERIOD
    assert speeds.max() < speed * 1.05  # the reference keeps the limit; the servo rings a little
    distance = np.linalg.norm(goal[:3, 3] - start[:3, 3])
    profile = TrapezoidalProfile(distance, speed, acceleration)
    times = np.arange(len(speeds)) * CONTROL_PERIOD
    cruise = (times > profile.ramp_time + 0.05) & (times < profile.duration - profile.ramp_time)
    np.testing.assert_allclose(speeds[cruise], speed, rtol=0.02)
    ramp = times < profile.ramp_time - 0.05
    assert np.all(speeds[ramp] < speed * 0.9)
    assert robot.time() - began == pytest.approx(profile.duration, abs=0.1)


def test_move_joint_brings_every_joint_in_together(robot) -> None:
    goal = HOME_JOINTS + np.array([0.6, 0.2, -0.3, 0.1, 0.4, -0.8])
    robot.move_joint(goal, speed=1.0, acceleration=2.0, asynchronous=True)
    _, joints = run_until_steady(robot)
    np.testing.assert_allclose(robot.joint_positions(), goal, atol=2e-3)
    progress = (joints - HOME_JOINTS) / (goal - HOME_JOINTS)
    assert np.abs(progress - progress[:, [5]]).max() < 0.05
    assert robot.time() == pytest.approx(TrapezoidalProfile(0.8, 1.0, 2.0).duration, abs=0.1)


def test_servo_linear_stream_is_tracked(robot) -> None:
    start = robot.probe_pose_on_skin(0.0, -0.03, 0.03)
    robot.move_linear(start)
    periods = 1000
    for i in range(periods):
        target = robot.probe_pose_on_skin(0.0, -0.03 + 0.06 * i / periods, 0.03)
        robot.servo_linear(target, lookahead_time=0.05)
        robot.step()
        if i > 100:
            lag = np.linalg.norm(robot.tcp_pose()[:3, 3] - target[:3, 3])
            assert lag < 0.06 / (periods * CONTROL_PERIOD) * 0.1  # within 0.1 s of travel
    robot.step(500)
    np.testing.assert_allclose(robot.tcp_pose()[:3, 3], target[:3, 3], atol=2e-4)


def test_speed_linear_moves_at_the_commanded_velocity_until_stopped(robot) -> None:
    robot.move_linear(robot.probe_pose_on_skin(0.0, -0.03, 0.04))
    orientation = robot.tcp_pose()[:3, :3]
    velocity = np.array([0.0, 0.02, 0.0, 0.0, 0.0, 0.0])
    robot.speed_linear(velocity, acceleration=0.5)
    robot.step(100)
    before = robot.tcp_pose()[:3, 3]
    robot.step(500)
    after = robot.tcp_pose()[:3, 3]
    np.testing.assert_allclose((after - before) / (500 * CONTROL_PERIOD), velocity[:3], atol=2e-4)
    np.testing.assert_allclose(robot.tcp_velocity(), velocity, atol=5e-4)
    assert np.linalg.norm(robot.target_tcp_pose()[:3, 3] - after) < 1e-3
    robot.stop()
    assert robot.is_steady()
    # at rest the controller's joint reference (getTargetQ) is where the joints are
    np.testing.assert_allclose(robot.target_joint_positions(), robot.joint_positions(), atol=1e-3)
    np.testing.assert_allclose(robot.tcp_pose()[:3, :3], orientation, atol=1e-3)


def test_set_tcp_moves_the_reported_pose(robot) -> None:
    flange = robot.flange_pose()
    offset = np.eye(4)
    offset[:3, 3] = (0.0, 0.0, 0.2)
    robot.set_tcp(offset)
    np.testing.assert_allclose(robot.tcp_pose(), flange @ offset, atol=1e-12)
    np.testing.assert_allclose(
        robot.tcp_pose_in_phantom(), invert_pose(robot.phantom_to_base) @ flange @ offset
    )
    with pytest.raises(ValueError, match="rigid"):
        robot.set_tcp(np.eye(4) * 2)


def test_unreachable_targets_are_refused_before_moving(robot) -> None:
    far = robot.probe_pose_on_skin(0.0, 0.0, 0.0)
    far[:3, 3] = (0.7, 0.0, 0.2)
    with pytest.raises(ValueError, match="workspace"):
        robot.move_linear(far)
    with pytest.raises(ValueError, match="out of reach"):
        robot.servo_linear(far)
    with pytest.raises(ValueError, match="move_joint"):
        robot.move_joint(np.full(6, 7.0))
    np.testing.assert_allclose(robot.joint_positions(), HOME_JOINTS, atol=1e-9)
    assert robot.time() == 0.0


def test_pressing_too_hard_is_a_protective_stop(robot) -> None:
    robot.move_linear(robot.probe_pose_on_skin(0.0, 0.0, 0.01))
    with pytest.raises(ProtectiveStopError, match="force"):
        robot.move_linear(robot.probe_pose_on_skin(0.0, 0.0, -0.05), 0.02)
    assert robot.is_protective_stopped()
    robot.step(250)
    held = robot.joint_positions()
    robot.step(100)
    assert np.abs(robot.joint_positions() - held).max() < 1e-4
    assert np.linalg.norm(robot.tcp_wrench()[:3]) < robot.force_limit
    with pytest.raises(ProtectiveStopError, match="unlock"):
        robot.move_linear(robot.probe_pose_on_skin(0.0, 0.0, 0.02))
    robot.unlock_protective_stop()
    robot.move_linear(robot.probe_pose_on_skin(0.0, 0.0, 0.02))
    assert not robot.is_protective_stopped()


def test_torque_beyond_a_joint_limit_is_a_protective_stop(robot) -> None:
    robot.force_limit = 1000.0
    robot.move_linear(robot.probe_pose_on_skin(0.0, 0.0, 0.01))
    with pytest.raises(ProtectiveStopError, match="N m"):
        robot.move_linear(robot.probe_pose_on_skin(0.0, 0.0, -0.08), 0.05)
    assert "beyond its limit" in robot.protective_stop_reason
