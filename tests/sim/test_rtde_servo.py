"""The servo that follows a streamed servoL: the RTDE emulator's and the simulated robot's are
one model, and a stream that stalls does not jerk the arm into the phantom.

A client on a busy host stalls now and then, and then sends the target for the time it has
reached, many periods ahead. With the servo's first-order lookahead filter that jump was a step
of the reference velocity: 0.4 s of stall 50 ms into the default fan (the probe rocking about
its face) read 24.7 N on the wrist sensor, against the 4 N held, on both paths, and `resus scan`
stopped at its 20 N limit on the emulator. The servo is now second order (7.3 N).
"""

from __future__ import annotations

import numpy as np

from resus.acquisition.patterns import fan_sweep
from sim.robot import kinematics
from sim.robot.motions import LINEAR, Servo
from sim.robot.ur3e import CONTROL_PERIOD, HOME_JOINTS, SimulatedUR3e
from sim.rtde.motion import ServoTarget
from sim.rtde.mujoco_arm import MujocoArm
from sim.transforms import invert_pose

LOOKAHEAD = 0.1
"""servoL lookahead time (s): `RTDERobotConfig`'s default, and the simulated robot's."""
FORCE = 4.0


def stalled_fan_forces(robot: SimulatedUR3e, through_emulator: bool) -> np.ndarray:
    """|F| each period of the default fan, streamed at 500 Hz into force mode on the skin,
    with the stream stalled for 0.4 s from 50 ms in: by servoL on the robot itself, or by the
    emulator's servo (`ServoTarget`) handing its setpoints to the arm (`MujocoArm`)."""
    fan = fan_sweep(robot.phantom, robot.phantom_to_base)
    start = fan.pose_at(0.0)
    joints = kinematics.inverse_kinematics(
        fan.approach_pose(start) @ invert_pose(robot.get_tcp()), HOME_JOINTS
    )
    robot.reset(joints)
    robot.force_mode(
        robot.tcp_pose(), np.array([0, 0, 1, 0, 0, 0]), np.array([0, 0, FORCE, 0, 0, 0]), 2,
        np.full(6, 0.05),
    )  # fmt: skip
    arm = MujocoArm(robot)
    servo = ServoTarget(LINEAR, robot.tcp_pose())

    def period(target: np.ndarray | None) -> float:
        if through_emulator:
            if target is not None:
                servo.command(target, CONTROL_PERIOD, LOOKAHEAD)
            arm.servo_linear(servo.advance(CONTROL_PERIOD))
        elif target is not None:
            robot.servo_linear(target, CONTROL_PERIOD, LOOKAHEAD)
        robot.step()
        return float(np.linalg.norm(robot.tcp_wrench()[:3]))

    for _ in range(1500):  # 3 s: pressed on and settled at 4 N
        period(start)
    forces = []
    for k in range(400):  # 0.8 s of the fan: 25 periods, a 0.4 s stall, the rest
        forces.append(period(None if 25 <= k < 225 else fan.pose_at(k * CONTROL_PERIOD)))
    assert not robot.is_protective_stopped()
    return np.array(forces)


def test_a_stalled_stream_does_not_jerk_the_probe_into_the_phantom(shared_robot) -> None:
    forces = stalled_fan_forces(shared_robot, through_emulator=False)
    assert abs(forces[:25].mean() - FORCE) < 0.5  # settled before the stall
    assert forces.max() < 10.0, forces.max()  # 24.7 N with a first-order servo


def test_the_emulator_and_the_simulated_robot_servo_alike(shared_robot) -> None:
    """The planner's force check runs the plan on the simulated robot: it predicts the
    emulator only because both follow a stream with the same servo and force controller."""
    direct = stalled_fan_forces(shared_robot, through_emulator=False)
    emulated = stalled_fan_forces(shared_robot, through_emulator=True)
    np.testing.assert_allclose(emulated, direct, atol=1e-6)


def test_a_late_target_starts_the_setpoint_moving_gently() -> None:
    """Second order: a target that jumps 10 mm moves the setpoint 15 um in the first period
    and its speed by at most 7.4 mm/s a period (a first-order filter moved it 0.2 mm: a step
    of 98 mm/s), without overshoot, and within 1 % after four lookahead times."""
    start = np.eye(4)
    target = start.copy()
    target[0, 3] = 0.01
    servo = Servo(LINEAR, start)
    servo.command(target, CONTROL_PERIOD, LOOKAHEAD)
    path = np.array([servo.advance(CONTROL_PERIOD)[0, 3] for _ in range(250)])
    speeds = np.diff(np.concatenate([[0.0], path])) / CONTROL_PERIOD
    assert path[0] < 2e-5
    assert np.abs(np.diff(np.concatenate([[0.0], speeds]))).max() < 0.0075
    assert np.all(np.diff(path) >= 0) and path.max() <= 0.01
    assert path[round(4 * LOOKAHEAD / CONTROL_PERIOD) - 1] > 0.99 * 0.01


def test_without_lookahead_the_target_is_followed_as_given() -> None:
    """The emulator hands its arm setpoints already smoothed: servo time one period, no
    lookahead, so the arm's servo passes them on unchanged."""
    servo = Servo(LINEAR, np.eye(4))
    target = np.eye(4)
    target[1, 3] = 0.002
    servo.command(target, CONTROL_PERIOD, 0.0)
    np.testing.assert_allclose(servo.advance(CONTROL_PERIOD), target, atol=1e-15)
