"""A UR robot through ur_rtde: the real UR3e, or the RTDE emulator on 127.0.0.1.

`RTDERobot` drives the controller with `rtde_control.RTDEControlInterface` and reads it
with `rtde_receive.RTDEReceiveInterface`. Poses are converted to UR's `[x, y, z, rx, ry, rz]`
here and nowhere else. Streaming follows ur_rtde's fixed-rate pattern: `servo_linear` opens
a control period with `initPeriod()`, `wait_period` closes it with `waitPeriod()`.

Readings: ur_rtde's receive thread replaces its state packet between any two getter calls, so
the timestamp, pose, wrench and joints are read from one packet together (read again when a
newer packet arrived in between), and every reading returns that packet's values until the
next period (`wait_period`), command or READING_HOLD: a cycle's readings describe one instant,
as the simulated robot's do between two periods, and a pose recorded against a timestamp is
the pose at it, however late the calling thread runs on a loaded machine.

Faults: every command checks the link and the safety state first, and a command the
controller refuses raises `RobotFault` with the controller's reason. The interfaces run in a
process of their own (`rtde_link`): a link the controller closed is seen on its sockets at
once, and ur_rtde crashing in its own reconnection is a lost link, not a lost scan. Ctrl-C
during a blocking call (moveL) reaches this process at once; `close()` (also on leaving the
`with` block, whatever the exit) lets the call finish, then stops the servo, stops the
control script and disconnects. What ur_rtde prints from C++ is logged at DEBUG on
`resus.acquisition.backends.rtde_link`'s logger, so the user sees the one `RobotFault` line.
"""

from __future__ import annotations

import contextlib
import time
from dataclasses import dataclass

import numpy as np

from resus.acquisition.backends.rtde_link import LINK_LOST, RUNTIME_PLAYING, Packet, RTDELink
from resus.acquisition.robot import Robot, RobotFault
from resus.errors import ResusError
from sim.transforms import is_rigid, pose_from_ur, pose_to_ur

SCRIPT_START_TIMEOUT = 2.0
"""Seconds the receive stream gets after connecting to show the control script running:
ur_rtde waited for it on the control interface's own stream, which may be ahead."""
REFUSAL_WAIT = 0.25
"""Seconds to wait for the reason of a refused command to show on the receive stream, which
may lag the control stream that saw the refusal."""
READING_HOLD = 0.1
"""Longest time (s) for which readings return the packet they last read when no period ends
and no command is sent: long enough that a preempted caller still pairs a cycle's readings,
short enough that a caller polling without `wait_period` sees the robot move."""


@dataclass(frozen=True)
class _Readings:
    """One RTDE state packet's timestamp, TCP pose (4x4), TCP wrench and joints."""

    time: float
    pose: np.ndarray
    wrench: np.ndarray
    joints: np.ndarray
    taken_at: float
    """`time.monotonic()` when it was read."""


@dataclass(frozen=True)
class RTDERobotConfig:
    """How to reach and drive a UR controller over RTDE."""

    host: str = "127.0.0.1"
    """Controller address (the emulator listens on 127.0.0.1 by default)."""
    frequency: float = 500.0
    """RTDE rate (Hz): 500 for e-Series, 125 for CB3."""
    tcp_offset: np.ndarray | None = None
    """TCP pose in the flange frame (4x4, m): the probe face centre, z into the tissue.
    None keeps the TCP configured on the controller (PolyScope installation, or the
    simulated probe's in the emulator)."""
    servo_lookahead: float = 0.1
    """servoL lookahead time (s, UR range 0.03-0.2): smooths the streamed path."""
    servo_gain: float = 300.0
    """servoL proportional gain (UR range 100-2000)."""
    force_speed_limit: float = 0.05
    """Highest TCP speed along the compliant axis in force mode (m/s)."""
    stop_deceleration: float = 2.0
    """Deceleration of `stop()` (m/s^2)."""

    def __post_init__(self) -> None:
        where = "RTDERobotConfig"
        if self.tcp_offset is not None:
            offset = np.asarray(self.tcp_offset, dtype=np.float64)
            if offset.shape != (4, 4) or not is_rigid(offset):
                raise ResusError(
                    f"{where}.tcp_offset must be a rigid 4x4 pose of the TCP in the flange frame"
                )
            object.__setattr__(self, "tcp_offset", offset)
        if not 0 < self.frequency <= 500:
            raise ResusError(f"{where}.frequency must be in (0, 500] Hz, got {self.frequency}")
        if not 0.03 <= self.servo_lookahead <= 0.2:
            raise ResusError(
                f"{where}.servo_lookahead must be in [0.03, 0.2] s, got {self.servo_lookahead}"
            )
        if not 100 <= self.servo_gain <= 2000:
            raise ResusError(f"{where}.servo_gain must be in [100, 2000], got {self.servo_gain}")


class RTDERobot(Robot):
    """A UR arm behind ur_rtde's control and receive interfaces (in their own process)."""

    def __init__(self, config: RTDERobotConfig = RTDERobotConfig()) -> None:
        self.config = config
        self.control_period = 1.0 / config.frequency
        self._link: RTDELink | None = None
        """None while closed."""
        self._period_open = False
        self._readings: _Readings | None = None
        self._connect()

    # -- connection --------------------------------------------------------------------

    def _connect(self) -> None:
        self._link = RTDELink(self.config.host, self.config.frequency)
        self._await_script()
        offset = self.config.tcp_offset
        if offset is not None and not self._connected().call(
            "command", "setTcp", pose_to_ur(offset).tolist()
        ):
            self.close()
            raise RobotFault(f"the UR controller at {self.config.host} refused the TCP offset")

    def _await_script(self) -> None:
        """Give the receive stream time to show the control script running: right after
        connecting it may still hold a packet from before the script started, which `fault()`
        would take for a stopped script."""
        link = self._connected()
        deadline = time.monotonic() + SCRIPT_START_TIMEOUT
        while link.call("runtime_state") != RUNTIME_PLAYING and time.monotonic() < deadline:
            time.sleep(self.control_period)

    @property
    def link(self) -> RTDELink | None:
        """The process that holds ur_rtde's interfaces; None while closed."""
        return self._link

    def _connected(self) -> RTDELink:
        if self._link is None:
            raise RobotFault(LINK_LOST)
        return self._link

    def reconnect(self) -> None:
        """Drop the link and connect again (after a lost link or a stopped script)."""
        self._disconnect()
        self._connect()

    def _disconnect(self) -> None:
        if self._link is not None:
            self._link.close()
        self._link = None
        self._readings = None
        self._period_open = False

    def close(self) -> None:
        """Stop servoing, stop the control script, disconnect; safe to call twice. After a
        lost link the link's process is ended at once (see `rtde_link`)."""
        if self._link is not None and self.fault() is None:
            with contextlib.suppress(RuntimeError, RobotFault):
                self._link.call("command", "servoStop", self.config.stop_deceleration)
                self._link.call("command", "stopScript")
        self._disconnect()

    # -- readings ----------------------------------------------------------------------

    def _packet(self) -> _Readings:
        """The held state packet, or the latest one (see the module doc)."""
        readings = self._readings
        if readings is not None and time.monotonic() - readings.taken_at <= READING_HOLD:
            return readings
        reading = self._connected().call("packet")
        if reading is None:
            raise RobotFault(self.fault() or LINK_LOST)
        packet = Packet(*reading)
        self._readings = _Readings(
            float(packet.time),
            pose_from_ur(np.array(packet.pose)),
            np.array(packet.wrench),
            np.array(packet.joints),
            time.monotonic(),
        )
        return self._readings

    def tcp_pose(self) -> np.ndarray:
        return self._packet().pose.copy()

    def joint_positions(self) -> np.ndarray:
        return self._packet().joints.copy()

    def tcp_wrench(self) -> np.ndarray:
        return self._packet().wrench.copy()

    def time(self) -> float:
        return self._packet().time

    def fault(self) -> str | None:
        """Why the robot cannot move (one consistent reading of link, program and safety)."""
        if self._link is None:
            return LINK_LOST
        return self._link.state().fault()

    # -- commands ----------------------------------------------------------------------

    def _command(self, name: str, *arguments: object) -> None:
        """Send one command, checked against the controller's state in the same request;
        RobotFault when the state shows a fault, the command fails or the controller refuses it.

        ur_rtde returns False for a refused command (None for void ones).
        """
        accepted = self._request(name, "command", name, *arguments)
        if accepted is False:
            raise RobotFault(f"{name} refused: {self._refusal_reason()}")

    def _request(self, label: str, operation: str, *arguments: object) -> object:
        """`operation` in the link, checked against the controller's state; ur_rtde raising
        RuntimeError (the link broke under it) is a RobotFault naming `label`. Readings taken
        after it are of a newer packet."""
        try:
            return self._connected().checked(operation, *arguments)
        except RuntimeError as error:
            raise RobotFault(f"{label} failed: {self.fault() or error}") from None
        finally:
            self._readings = None

    def _refusal_reason(self) -> str:
        """Why the controller refused a command. The receive stream may lag the control
        stream that saw the refusal, so it gets REFUSAL_WAIT to catch up."""
        deadline = time.monotonic() + REFUSAL_WAIT
        while True:
            reason = self.fault()
            if reason is not None:
                return reason
            if time.monotonic() > deadline:
                return "the controller returned failure"
            time.sleep(self.control_period)

    def _period(self, operation: str) -> None:
        """`init_period` or `wait_period` in the link (checked like a command)."""
        self._request(operation, operation)
        self._period_open = True

    def move_linear(self, pose: np.ndarray, speed: float, acceleration: float) -> None:
        self._command("moveL", pose_to_ur(pose).tolist(), speed, acceleration, False)

    def servo_linear(self, pose: np.ndarray) -> None:
        if not self._period_open:
            self._period("init_period")
        config = self.config
        self._command(
            "servoL",
            pose_to_ur(pose).tolist(),
            0.5,  # speed and acceleration: ignored by UR's servoL, required by the API
            0.5,
            self.control_period,
            config.servo_lookahead,
            config.servo_gain,
        )

    def wait_period(self) -> None:
        self._period("wait_period")

    def force_mode(self, force: float) -> None:
        """forceMode type 2 in the current TCP frame: compliant along z only."""
        task_frame = pose_to_ur(self.tcp_pose()).tolist()
        limit = self.config.force_speed_limit
        wrench = [0.0, 0.0, float(force), 0.0, 0.0, 0.0]
        limits = [limit, limit, limit, 0.17, 0.17, 0.17]
        self._command("forceMode", task_frame, [0, 0, 1, 0, 0, 0], wrench, 2, limits)
        # Streamed commands share input_int_register_0: give the controller two full cycles
        # to read forceMode before the next servoL overwrites it.
        self._period("init_period")
        self._period("wait_period")
        self._period("wait_period")

    def force_mode_stop(self) -> None:
        self._command("forceModeStop")

    def stop(self) -> None:
        """End servoing and speed commands and brake any move (servoStop, speedStop, stopL)."""
        deceleration = self.config.stop_deceleration
        self._command("servoStop", deceleration)
        self._command("speedStop", deceleration)
        self._command("stopL", deceleration, False)
        self._period_open = False
