"""RTDERobot (the hardware path) against the emulator: motion, faults, force on the phantom."""

from __future__ import annotations

import logging
import os
import signal
import time
from dataclasses import dataclass

import numpy as np
import pytest
from cli_runner import resus
from scan_session import write_linear_plan

from resus.acquisition.backends.rtde import RTDERobot, RTDERobotConfig
from resus.acquisition.robot import RobotFault
from resus.errors import ResusError
from sim.robot.scene_config import load_scene_config
from sim.rtde.launch import free_host, launch
from sim.transforms import make_pose

pytestmark = [pytest.mark.slow, pytest.mark.hang_guard]


FAULT_AFTER = 0.5
"""Seconds after the first servoL at which faults are injected (`motion+T`): the robot has
connected by then however long that took on a loaded machine."""
DROP_FOR = 0.5
"""How long the dropped link refuses connections (s)."""
DETECTION_LIMIT = 0.25
"""Wall-clock seconds within which RobotFault must follow a fault. The fault path itself
takes a control cycle or two (the robot reads the safety state every cycle, and a dropped
link shows on its sockets at once); the rest of the limit is what the emulator, ur_rtde's
receive thread and this loop may each wait for a core on a loaded 2-core machine."""
CONTACT_TIME = 2.0
"""Robot-clock seconds of force mode on the phantom: the admittance closes the force error
with a time constant of about 0.3 s, so over the last 0.5 s it is within 0.2 N."""


@dataclass
class Seen:
    """How a polling loop met a fault."""

    reason: str
    at: float
    """time.monotonic() when RobotFault was raised."""
    last_packet: float
    """Robot time of the state packet the last cycle completed without a fault began with."""


def _wait_for_fault(robot: RTDERobot, timeout: float = 10.0) -> Seen:
    """Poll like a scanner does each cycle until RobotFault."""
    deadline = time.monotonic() + timeout
    last_packet = -np.inf
    while time.monotonic() < deadline:
        try:
            packet = robot.time()
            robot.servo_linear(robot.tcp_pose())
            robot.wait_period()
        except RobotFault as fault:
            return Seen(str(fault), time.monotonic(), last_packet)
        last_packet = packet
    raise AssertionError("no RobotFault")


def _pose_at_rest(robot: RTDERobot, timeout: float = 2.0) -> np.ndarray:
    """The TCP pose once two state packets agree on it. A blocking move returns when the
    control stream reports it done; the receive stream may be a packet or two behind."""
    deadline = time.monotonic() + timeout
    stamp, pose = robot.time(), robot.tcp_pose()
    while time.monotonic() < deadline:
        time.sleep(robot.control_period)
        previous, pose = (stamp, pose), (robot.time(), robot.tcp_pose())
        stamp, pose = pose
        if stamp > previous[0] and np.array_equal(pose, previous[1]):
            return pose
    raise AssertionError("the TCP did not come to rest")


def test_config_rejects_bad_values_naming_the_setting():
    with pytest.raises(ResusError, match=r"RTDERobotConfig\.tcp_offset must be a rigid 4x4"):
        RTDERobotConfig(tcp_offset=np.eye(3))
    with pytest.raises(ResusError, match=r"RTDERobotConfig\.servo_gain .*, got 5\.0$"):
        RTDERobotConfig(servo_gain=5.0)
    with pytest.raises(ResusError, match=r"RTDERobotConfig\.frequency .*, got 600"):
        RTDERobotConfig(frequency=600)


def test_moves_streams_and_applies_the_tcp_offset():
    offset = make_pose(np.eye(3), np.array([0.0, 0.0, 0.05]))
    with launch() as emulator:
        with RTDERobot(RTDERobotConfig(emulator.host, tcp_offset=offset)) as robot:
            assert robot.fault() is None
            pose = robot.tcp_pose()
            goal = pose.copy()
            goal[:3, 3] += [0.02, 0.0, -0.03]
            robot.move_linear(goal, 0.1, 0.5)
            np.testing.assert_allclose(_pose_at_rest(robot), goal, atol=1e-6)
            began = time.monotonic()
            for i in range(250):
                target = goal.copy()
                target[1, 3] += 0.01 * i / 250
                robot.servo_linear(target)
                robot.wait_period()
            # wait_period paces the stream on the wall clock: 250 periods take 0.5 s or more
            # (the emulator's own clock may fall behind on a loaded machine)
            assert time.monotonic() - began > 250 * robot.control_period - 0.01
            robot.stop()
            # The servo lags the stream by its lookahead time (0.1 s at 20 mm/s), and servoStop
            # brakes from there: it ends a few millimetres short of the last target.
            np.testing.assert_allclose(robot.tcp_pose()[:3, 3], target[:3, 3], atol=5e-3)
            assert robot.joint_positions().shape == (6,) and robot.tcp_wrench().shape == (6,)
        assert "program stopped: stopScript" in emulator.log()  # close() ended the script


def test_protective_stop_becomes_robot_fault_at_the_first_packet_that_shows_it():
    faults = (f"protective-stop@motion+{FAULT_AFTER}",)
    with launch(faults=faults) as emulator, RTDERobot(RTDERobotConfig(emulator.host)) as robot:
        seen = _wait_for_fault(robot)
        # "protective stop", or "servoL refused: protective stop" when the control stream
        # saw it first; never "script not running", however the two streams raced.
        assert seen.reason.endswith(": protective stop") or seen.reason == "protective stop"
        # Packets up to the stop's cycle show normal operation: a cycle that went through
        # without a fault began with one of those, never with a packet that shows the stop.
        assert seen.last_packet <= emulator.fault_emulator_time() + 1e-6
        delay = seen.at - emulator.fault_time()
        assert 0.0 <= delay < DETECTION_LIMIT, f"protective stop seen after {delay:.3f} s"


def test_dropped_connection_becomes_robot_fault_and_reconnect_recovers():
    faults = (f"drop@motion+{FAULT_AFTER}+{DROP_FOR}",)
    with launch(faults=faults) as emulator, RTDERobot(RTDERobotConfig(emulator.host)) as robot:
        seen = _wait_for_fault(robot)
        assert seen.reason == "connection to the UR controller lost"
        delay = seen.at - emulator.fault_time()
        assert 0.0 <= delay < DETECTION_LIMIT, f"dropped link seen after {delay:.3f} s"
        assert robot.fault() == "connection to the UR controller lost"
        time.sleep(max(0.0, emulator.fault_time() + DROP_FOR + 0.1 - time.monotonic()))
        robot.reconnect()  # a new link process, now that connections are accepted again
        assert robot.fault() is None
        assert robot.time() > emulator.fault_emulator_time() + DROP_FOR


def test_ur_rtde_crashing_is_a_lost_link_and_the_caller_lives_on(caplog):
    """ur_rtde 1.6.5 can crash in its own reconnection (SIGSEGV); its process really
    crashing must reach the caller as a RobotFault, like any lost link."""
    caplog.set_level(logging.DEBUG, logger="resus.acquisition.backends.rtde_link")
    with launch() as emulator:
        with RTDERobot(RTDERobotConfig(emulator.host)) as robot:
            robot.servo_linear(robot.tcp_pose())
            robot.wait_period()
            link = robot.link
            assert link is not None
            os.kill(link.pid, signal.SIGSEGV)
            seen = _wait_for_fault(robot)
            assert seen.reason == "connection to the UR controller lost"
            assert robot.fault() == "connection to the UR controller lost"
            began = time.monotonic()
        closing = time.monotonic() - began  # the robot's close alone, not the emulator's exit
    assert closing < 2.0  # closing kills nothing twice and waits for nothing
    assert "ur_rtde's process ended by SIGSEGV" in caplog.text
    assert "Fatal Python error: Segmentation fault" in caplog.text  # its log, at DEBUG


def test_a_controller_that_is_off_is_one_line_on_the_console(tmp_path):
    """ur_rtde prints `connect: Connection refused` from C++ on the process's stderr; the
    user sees only the command's one `error:` line."""
    host = free_host()
    plan = write_linear_plan(
        tmp_path / "plan.yaml", start=(0.0, 0.0), direction=(1.0, 0.0), length=0.02
    )
    done = resus(
        "scan", "--robot", host, "--probe", "sim:96x96", "--trajectory", plan,
        "--out", tmp_path / "sweep.h5", "--yes", timeout=120,
    )  # fmt: skip
    assert done.returncode == 2
    lines = done.stderr.splitlines()
    assert len(lines) == 1, done.stderr
    assert lines[0].startswith(
        f"error: robot {host}: cannot connect to the UR controller at {host}: "
    )
    assert not (tmp_path / "sweep.h5").exists()


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
        # Timed on the robot clock: a loaded machine runs the emulator, and so the contact,
        # slower than the wall clock that wait_period keeps.
        began, samples = robot.time(), []
        while not samples or samples[-1][0] < began + CONTACT_TIME:
            robot.servo_linear(above)
            robot.wait_period()
            samples.append((robot.time(), robot.tcp_wrench()[:3] @ robot.tcp_pose()[:3, 2]))
        robot.force_mode_stop()
        times, forces = np.array(samples).T
        settled = forces[times > began + CONTACT_TIME - 0.5]
        assert abs(settled.mean() - 5.0) < 0.5, f"mean force {settled.mean():.2f} N"
        assert settled.std() < 0.5
        assert robot.tcp_pose()[2, 3] < surface  # the probe indents the gel
