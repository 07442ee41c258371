"""The arm an RTDE emulator drives, and its pure-kinematic implementation.

The emulator's controller plans every motion itself (moveL, speedL, stopL...) and hands the
arm one target per 2 ms control period, as UR's controller hands its joint servos one
setpoint per cycle. So an arm needs only streaming targets, force mode, readings and
`step()`. Two implementations: `KinematicArm` here (exact kinematics, no dynamics or contact:
fast, deterministic, for protocol tests and trajectory checks) and `MujocoArm` (physics and
contact with the phantom, in `sim.rtde.mujoco_arm`).
"""

from __future__ import annotations

from dataclasses import dataclass
from typing import Protocol

import numpy as np

from sim.robot.kinematics import (
    JOINT_SPEED_LIMITS,
    forward_kinematics,
    inverse_kinematics,
)
from sim.robot.ur3e import HOME_JOINTS
from sim.transforms import invert_pose


class UnreachableTarget(ValueError):
    """A Cartesian target has no inverse-kinematics solution within the joint limits."""


@dataclass(frozen=True)
class ForceModeCommand:
    """One forceMode call, as the controller decodes it from the input registers (base frame):
    one value for the arm, so the emulator's arms share one signature for it."""

    task_frame: np.ndarray
    """Pose (4x4) whose axes the selection, wrench and limits refer to."""
    selection: np.ndarray
    """Six 0/1 flags: the task-frame axes that comply."""
    wrench: np.ndarray
    """Force (N) and torque (Nm) to exert on the environment along the compliant axes (6,)."""
    force_type: int
    """UR's force-mode type: 1, 2 or 3."""
    limits: np.ndarray
    """Largest TCP speeds along the compliant axes (m/s, rad/s) (6,)."""


class EmulatedArm(Protocol):
    """What the emulator's controller needs from a simulated UR arm (4x4 poses, base frame)."""

    control_period: float

    def time(self) -> float:
        """Simulated seconds since start."""

    def joint_positions(self) -> np.ndarray:
        """Actual joints (6,), rad."""

    def tcp_pose(self) -> np.ndarray:
        """Actual TCP pose (4x4), the TCP offset applied."""

    def tcp_wrench(self) -> np.ndarray:
        """Force (N) and torque (Nm) the TCP exerts on the environment, base frame (6,)."""

    def set_tcp(self, flange_to_tcp: np.ndarray) -> None:
        """Set the TCP offset (4x4, flange frame)."""

    def servo_joint(self, q: np.ndarray) -> None:
        """Joint target for the next period (raises ValueError when out of limits)."""

    def servo_linear(self, pose: np.ndarray) -> None:
        """TCP target for the next period (raises UnreachableTarget when out of reach)."""

    def force_mode(self, command: ForceModeCommand) -> None:
        """Comply along the selected task-frame axes to apply the wrench; limits are speeds."""

    def force_mode_stop(self) -> None:
        """Leave force mode: every axis position-controlled again."""

    def zero_ft_sensor(self) -> None:
        """Take the current force/torque reading as zero."""

    def step(self) -> None:
        """Advance one control period."""

    def protective_stop_reason(self) -> str | None:
        """Why the arm stopped itself (force or torque over a limit), or None."""

    def unlock_protective_stop(self) -> None:
        """Leave the arm's own protective stop."""


class KinematicArm:
    """An ideal UR3e: joints reach each target within their speed limits, no dynamics.

    It has no contact model: its wrench is always zero and force mode acts as on a real UR
    in free space, moving the compliant axes at their speed limit towards the commanded force.
    """

    control_period = 0.002

    def __init__(self, initial_joints: np.ndarray = HOME_JOINTS) -> None:
        self._q = np.array(initial_joints, dtype=np.float64)
        self._target = self._q.copy()
        self._steps = 0
        self._flange_to_tcp = np.eye(4)
        self._force: ForceModeCommand | None = None

    def time(self) -> float:
        return self._steps * self.control_period

    def joint_positions(self) -> np.ndarray:
        return self._q.copy()

    def tcp_pose(self) -> np.ndarray:
        return forward_kinematics(self._q) @ self._flange_to_tcp

    def tcp_wrench(self) -> np.ndarray:
        return np.zeros(6)

    def set_tcp(self, flange_to_tcp: np.ndarray) -> None:
        self._flange_to_tcp = np.array(flange_to_tcp, dtype=np.float64)

    def servo_joint(self, q: np.ndarray) -> None:
        self._target = np.array(q, dtype=np.float64)

    def servo_linear(self, pose: np.ndarray) -> None:
        pose = np.asarray(pose, dtype=np.float64)
        if self._force is not None:
            pose = self._comply(pose)
        q = inverse_kinematics(pose @ invert_pose(self._flange_to_tcp), self._target)
        if q is None:
            raise UnreachableTarget(f"no joint solution reaches TCP position {pose[:3, 3]}")
        self._target = q

    def _comply(self, pose: np.ndarray) -> np.ndarray:
        """Replace the target along compliant axes: free-space motion at the speed limit."""
        assert self._force is not None  # called only while force mode is on
        selection, wrench = self._force.selection, self._force.wrench
        current = self.tcp_pose()
        rotation = self._force.task_frame[:3, :3]
        offset = rotation.T @ (pose[:3, 3] - current[:3, 3])
        step = np.sign(wrench[:3]) * self._speed_limits[:3] * self.control_period
        offset = np.where(selection[:3] > 0, step, offset)
        result = pose.copy()
        result[:3, 3] = current[:3, 3] + rotation @ offset
        return result

    def force_mode(self, command: ForceModeCommand) -> None:
        if command.force_type not in (1, 2, 3):
            raise ValueError(f"force mode type must be 1, 2 or 3, got {command.force_type}")
        self._force = command
        self._speed_limits = np.abs(np.asarray(command.limits, dtype=np.float64))

    def force_mode_stop(self) -> None:
        self._force = None

    def zero_ft_sensor(self) -> None:
        """Nothing to zero: the kinematic arm feels no force."""

    def protective_stop_reason(self) -> str | None:
        """Never: without contact or dynamics nothing can trip a limit."""
        return None

    def unlock_protective_stop(self) -> None:
        """Nothing to unlock (see `protective_stop_reason`)."""

    def step(self) -> None:
        limit = JOINT_SPEED_LIMITS * self.control_period
        self._q = self._q + np.clip(self._target - self._q, -limit, limit)
        self._steps += 1
