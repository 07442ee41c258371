"""RTDERobot (the hardware path) against the emulator: motion, faults, force on the phantom."""

from __future__ import annotations

import time

import numpy as np
import pytest

from resus.acquisition.backends.rtde import RTDERobot, RTDERobotConfig
from resus.acquisition.robot import RobotFault
from sim.robot.scene_config import load_scene_config
from sim.rtde.launch import launch
from sim.transforms import make_pose

pytestmark = [pytest.mark.slow, pytest.mark.hang_guard]


FAULT_TIME = 2.0
"""Emulator time of injected faults: after the robot has connected (about 0.5 s)."""
DETECTION_LIMIT = 0.05
"""RobotFault must follow a protective stop within this many seconds."""
DROP_DETECTION_LIMIT = 0.25
"""... and a dropped link within this many: usually a few ms, but a command that hits the dead
socket first blocks in ur_rtde's own reconnect attempt for about 0.13 s."""


def _wait_for_fault(robot: RTDERobot, timeout: float = 5.0) -> tuple[str, float]:
    """Poll like a scanner does each cycle; the fault and the monotonic time it was seen."""
    deadline = time.monotonic() + timeout
    while time.monotonic() < deadline:
        try:
            robot.tcp_pose()
            robot.servo_linear(robot.tcp_pose())
            robot.wait_period()
        except RobotFault as fault:
            return str(fault), time.monotonic()
    raise AssertionError("no RobotFault")


def test_config_rejects_bad_values():
    with pytest.raises(ValueError, match="tcp_offset"):
        RTDERobotConfig(tcp_offset=np.eye(3))
    with pytest.raises(ValueError, match="servo_gain"):
        RTDERobotConfig(servo_gain=5.0)


def test_moves_streams_and_applies_the_tcp_offset():
    offset = make_pose(np.eye(3), np.array([0.0, 0.0, 0.05]))
    with launch() as emulator:
        with RTDERobot(RTDERobotConfig(emulator.host, tcp_offset=offset)) as robot:
            assert robot.fault() is None
            pose = robot.tcp_pose()
            goal = pose.copy()
            goal[:3, 3] += [0.02, 0.0, -0.03]
            robot.move_linear(goal, 0.1, 0.5)
            np.testing.assert_allclose(robot.tcp_pose(), goal, atol=1e-6)
            began = robot.time()
            for i in range(250):
                target = goal.copy()
                target[1, 3] += 0.01 * i / 250
                robot.servo_linear(target)
                robot.wait_period()
            assert robot.time() - began > 0.45  # 250 periods (slower when the machine is loaded)
            robot.stop()
            # servoStop brakes from the measured speed: it ends millimetres past the last target
            np.testing.assert_allclose(robot.tcp_pose()[:3, 3], target[:3, 3], atol=5e-3)
            assert robot.joint_positions().shape == (6,) and robot.tcp_wrench().shape == (6,)
        assert "program stopped: stopScript" in emulator.log()  # close() ended the script


def test_protective_stop_becomes_robot_fault_within_a_few_cycles():
    faults = (f"protective-stop@{FAULT_TIME}",)
    with launch(faults=faults) as emulator, RTDERobot(RTDERobotConfig(emulator.host)) as robot:
        reason, seen = _wait_for_fault(robot)
        assert "protective stop" in reason
        delay = seen - emulator.fault_time()
        assert 0.0 <= delay < DETECTION_LIMIT, f"protective stop seen after {delay:.3f} s"
        assert 0.0 <= robot.time() - FAULT_TIME < DETECTION_LIMIT


def test_dropped_connection_becomes_robot_fault_and_reconnect_recovers():
    faults = (f"drop@{FAULT_TIME}+0.5",)
    with launch(faults=faults) as emulator, RTDERobot(RTDERobotConfig(emulator.host)) as robot:
        reason, seen = _wait_for_fault(robot)
        assert "lost" in reason
        delay = seen - emulator.fault_time()
        assert 0.0 <= delay < DROP_DETECTION_LIMIT, f"dropped link seen after {delay:.3f} s"
        assert robot.fault() is not None
        time.sleep(max(0.0, emulator.fault_time() + 0.6 - time.monotonic()))
        robot.reconnect()
        assert robot.fault() is None
        assert robot.time() > FAULT_TIME + 0.5


def test_force_mode_holds_the_contact_force_on_the_phantom():
    surface = load_scene_config().phantom_to_base[2, 3]  # the default scene's phantom top
    with (
        launch(arm="mujoco", scene="default") as emulator,
        RTDERobot(RTDERobotConfig(emulator.host)) as robot,
    ):
        start = robot.tcp_pose()
        assert start[2, 2] < -0.99  # probe pointing down at the phantom below
        above = start.copy()
        above[2, 3] = surface + 0.005
        robot.move_linear(above, 0.1, 0.5)
        robot.force_mode(5.0)
        forces = []
        for _ in range(750):
            robot.servo_linear(above)
            robot.wait_period()
            forces.append(robot.tcp_wrench()[:3] @ robot.tcp_pose()[:3, 2])
        robot.force_mode_stop()
        settled = np.array(forces[-250:])
        assert abs(settled.mean() - 5.0) < 0.5, f"mean force {settled.mean():.2f} N"
        assert settled.std() < 0.5
        assert robot.tcp_pose()[2, 3] < surface  # the probe indents the gel
