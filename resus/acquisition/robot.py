"""The abstract robot: what a scanner needs from an arm, in UR controller vocabulary."""

from __future__ import annotations

import time
from abc import ABC, abstractmethod

import numpy as np

from resus.errors import ResusError


class Robot(ABC):
    """An arm holding the probe. Poses are 4x4 TCP-in-base matrices (metres).

    The control loop is explicit: a streaming command (`servo_linear`) is followed by
    `wait_period()`, which on hardware waits out the control period and in simulation
    advances physics by it. Every call may raise `RobotFault` when the robot is stopped or
    the connection is lost.
    """

    control_period: float = 0.002
    """Seconds per control cycle (UR e-Series: 500 Hz)."""

    @abstractmethod
    def tcp_pose(self) -> np.ndarray:
        """Actual TCP pose in the base frame (4x4)."""

    @abstractmethod
    def joint_positions(self) -> np.ndarray:
        """Actual joint angles (6,), radians."""

    @abstractmethod
    def tcp_wrench(self) -> np.ndarray:
        """Force (N) and torque (Nm) the TCP exerts on the environment, base frame (6,)."""

    def probe_force(self) -> float:
        """The contact force along the probe axis (TCP z, into the tissue), in N: what force
        mode holds and what deforms the tissue in simulation."""
        return float(self.tcp_wrench()[:3] @ self.tcp_pose()[:3, 2])

    @abstractmethod
    def time(self) -> float:
        """The robot's clock (s): the timestamps poses are recorded against."""

    @abstractmethod
    def move_linear(self, pose: np.ndarray, speed: float, acceleration: float) -> None:
        """Blocking straight-line TCP move with a trapezoidal speed profile."""

    @abstractmethod
    def servo_linear(self, pose: np.ndarray) -> None:
        """Stream one TCP target for the current control period."""

    @abstractmethod
    def wait_period(self) -> None:
        """End the current control period (wait for it, or simulate it)."""

    @abstractmethod
    def force_mode(self, force: float) -> None:
        """Hold `force` newtons along the TCP z axis (into the tissue), stiff elsewhere."""

    @abstractmethod
    def force_mode_stop(self) -> None:
        """Leave force mode."""

    @abstractmethod
    def stop(self) -> None:
        """Stop moving now (decelerate at the robot's limit) and end any streaming."""

    @abstractmethod
    def fault(self) -> str | None:
        """Why the robot cannot move (protective stop, connection lost), or None."""

    def close(self) -> None:  # noqa: B027 - optional hook, nothing to release by default
        """Release the connection or simulation."""

    def __enter__(self) -> Robot:
        return self

    def __exit__(self, *exc_info: object) -> None:
        self.close()


def host_clock_offset(robot: Robot) -> float:
    """The robot's clock minus this host's monotonic clock (s), read back to back: what
    `ScannerSettings.time_offset` adds to the times of a probe that stamps its frames on the
    host (`VideoProbe`, `IgtlProbe`), before the latency temporal calibration finds."""
    before = time.monotonic()
    robot_time = robot.time()
    after = time.monotonic()
    return robot_time - 0.5 * (before + after)


class RobotFault(ResusError):
    """The robot stopped on its own or stopped answering (protective stop, lost link).

    A `ResusError`: the command line prints its one-line reason, without a traceback."""
