"""A UR robot through ur_rtde: the real UR3e, or the RTDE emulator on 127.0.0.1.

`RTDERobot` drives the controller with `rtde_control.RTDEControlInterface` and reads it
with `rtde_receive.RTDEReceiveInterface`. Poses are converted to UR's `[x, y, z, rx, ry, rz]`
here and nowhere else. Streaming follows ur_rtde's fixed-rate pattern: `servo_linear` opens
a control period with `initPeriod()`, `wait_period` closes it with `waitPeriod()`.

Faults: every command checks the link and the safety state first, and a command the
controller refuses raises `RobotFault` with the controller's reason. ur_rtde holds Python's
GIL while it blocks (moveL), so Ctrl-C is handled when the call returns; `close()` (also on
leaving the `with` block, whatever the exit) then stops the servo, stops the control script
and disconnects.
"""

from __future__ import annotations

import contextlib
import time
from dataclasses import dataclass

import numpy as np

from resus.acquisition.robot import Robot, RobotFault
from sim.transforms import is_rigid, pose_from_ur, pose_to_ur

RUNTIME_PLAYING = 2
"""`runtime_state` of a running program."""
REFUSAL_WAIT_PERIODS = 10
LINK_SETTLE = 2.0
"""Seconds `close` waits after a lost link before disconnecting: ur_rtde 1.6.5 reconnects on
its own after a dropped link, and disconnecting while that reconnection runs crashes the
process (segfault), so it is given time to finish or give up."""
"""Control periods to wait for the reason of a refused command to show on the receive side."""


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
        if self.tcp_offset is not None:
            offset = np.asarray(self.tcp_offset, dtype=np.float64)
            if offset.shape != (4, 4) or not is_rigid(offset):
                raise ValueError(
                    "tcp_offset must be a rigid 4x4 pose of the TCP in the flange frame"
                )
            object.__setattr__(self, "tcp_offset", offset)
        if not 0 < self.frequency <= 500:
            raise ValueError(f"frequency must be in (0, 500] Hz, got {self.frequency}")
        if not 0.03 <= self.servo_lookahead <= 0.2:
            raise ValueError(
                f"servo_lookahead must be in [0.03, 0.2] s, got {self.servo_lookahead}"
            )
        if not 100 <= self.servo_gain <= 2000:
            raise ValueError(f"servo_gain must be in [100, 2000], got {self.servo_gain}")


class RTDERobot(Robot):
    """A UR arm behind ur_rtde's control and receive interfaces."""

    def __init__(self, config: RTDERobotConfig = RTDERobotConfig()) -> None:
        self.config = config
        self.control_period = 1.0 / config.frequency
        self._control = None
        self._receive = None
        self._cycle_start = None
        self._link_lost_at: float | None = None
        self._connect()

    # -- connection --------------------------------------------------------------------

    def _connect(self) -> None:
        import rtde_control
        import rtde_receive

        host = self.config.host
        try:
            self._receive = rtde_receive.RTDEReceiveInterface(host, self.config.frequency)
            self._control = rtde_control.RTDEControlInterface(host, self.config.frequency)
        except RuntimeError as error:
            self._disconnect()
            raise RobotFault(f"cannot connect to the UR controller at {host}: {error}") from None
        offset = self.config.tcp_offset
        if offset is not None and not self._control.setTcp(pose_to_ur(offset).tolist()):
            self.close()
            raise RobotFault(f"the UR controller at {host} refused the TCP offset")

    def reconnect(self) -> None:
        """Drop both interfaces and connect again (after a lost link or a stopped script)."""
        self._disconnect()
        self._connect()

    def _disconnect(self) -> None:
        for interface in (self._control, self._receive):
            if interface is not None:
                with contextlib.suppress(RuntimeError):
                    interface.disconnect()
        self._control = self._receive = None

    def close(self) -> None:
        """Stop servoing, stop the control script, disconnect; safe to call twice. After a
        lost link it first lets ur_rtde's own reconnection settle (see LINK_SETTLE)."""
        control = self._control
        if control is not None and self._receive is not None and self.fault() is None:
            control.servoStop(self.config.stop_deceleration)
            control.stopScript()
        if self._link_lost_at is not None and control is not None:
            time.sleep(max(0.0, self._link_lost_at + LINK_SETTLE - time.monotonic()))
        self._disconnect()

    # -- readings ----------------------------------------------------------------------

    def _reader(self):
        if self._receive is None or not self._receive.isConnected():
            raise RobotFault(self.fault() or "connection to the UR controller lost")
        return self._receive

    def tcp_pose(self) -> np.ndarray:
        return pose_from_ur(np.array(self._reader().getActualTCPPose()))

    def joint_positions(self) -> np.ndarray:
        return np.array(self._reader().getActualQ())

    def tcp_wrench(self) -> np.ndarray:
        return np.array(self._reader().getActualTCPForce())

    def time(self) -> float:
        return float(self._reader().getTimestamp())

    def fault(self) -> str | None:
        """Why the robot cannot move, from one RTDE stream so that safety and program state
        are read from the same packet (the control stream may be a cycle ahead)."""
        receive, control = self._receive, self._control
        if receive is None or control is None:
            return "connection to the UR controller lost"
        if not receive.isConnected():
            if self._link_lost_at is None:
                self._link_lost_at = time.monotonic()
            return "connection to the UR controller lost"
        if not control.isConnected():
            return "control connection to the UR controller lost"
        if receive.isEmergencyStopped():
            return "emergency stop"
        if receive.isProtectiveStopped():
            return "protective stop"
        if receive.getRuntimeState() != RUNTIME_PLAYING:
            return "the control script is not running on the controller"
        return None

    # -- commands ----------------------------------------------------------------------

    def _command(self, name: str, *arguments: object) -> None:
        """Send one command; RobotFault when it fails or the controller refuses it.

        ur_rtde returns False for a refused command (None for void ones) and raises
        RuntimeError when the link breaks under it.
        """
        control = self._controller()
        try:
            accepted = getattr(control, name)(*arguments)
        except RuntimeError as error:
            raise RobotFault(f"{name} failed: {self.fault() or error}") from None
        if accepted is False:
            raise RobotFault(f"{name} refused: {self._refusal_reason()}")

    def _refusal_reason(self) -> str:
        """Why the controller refused a command. The receive stream may be a cycle behind
        the control stream that saw the refusal, so it gets a few periods to catch up."""
        for _ in range(REFUSAL_WAIT_PERIODS):
            reason = self.fault()
            if reason is not None:
                return reason
            time.sleep(self.control_period)
        return "the controller returned failure"

    def _controller(self):
        reason = self.fault()
        if reason is not None:
            raise RobotFault(reason)
        return self._control

    def move_linear(self, pose: np.ndarray, speed: float, acceleration: float) -> None:
        self._command("moveL", pose_to_ur(pose).tolist(), speed, acceleration, False)

    def servo_linear(self, pose: np.ndarray) -> None:
        if self._cycle_start is None:
            self._cycle_start = self._controller().initPeriod()
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
        control = self._controller()
        if self._cycle_start is None:
            self._cycle_start = control.initPeriod()
        control.waitPeriod(self._cycle_start)
        self._cycle_start = control.initPeriod()

    def force_mode(self, force: float) -> None:
        """forceMode type 2 in the current TCP frame: compliant along z only."""
        task_frame = pose_to_ur(self.tcp_pose()).tolist()
        limit = self.config.force_speed_limit
        wrench = [0.0, 0.0, float(force), 0.0, 0.0, 0.0]
        limits = [limit, limit, limit, 0.17, 0.17, 0.17]
        self._command("forceMode", task_frame, [0, 0, 1, 0, 0, 0], wrench, 2, limits)
        # Streamed commands share input_int_register_0: give the controller two cycles to
        # read forceMode before the next servoL overwrites it.
        control = self._controller()
        for _ in range(2):
            control.waitPeriod(control.initPeriod())

    def force_mode_stop(self) -> None:
        self._command("forceModeStop")

    def stop(self) -> None:
        """End servoing and speed commands and brake any move (servoStop, speedStop, stopL)."""
        deceleration = self.config.stop_deceleration
        self._command("servoStop", deceleration)
        self._command("speedStop", deceleration)
        self._command("stopL", deceleration, False)
        self._cycle_start = None
