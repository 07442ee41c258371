"""Reference generators for UR motion commands, sampled once per control period.

Every motion answers `reference(t, dt)`: the nominal reference for the end of the control
period that starts at sim time `t`, and whether the motion ends with it. Joint motions give six
joint angles, Cartesian motions a 4x4 TCP pose that the controller turns into joints by
inverse kinematics.
"""

from __future__ import annotations

import math
from typing import Protocol

import numpy as np
from scipy.spatial.transform import Rotation

from sim.robot.profiles import TrapezoidalProfile


class Motion(Protocol):
    """A running motion command."""

    def reference(self, t: float, dt: float) -> tuple[np.ndarray, bool]:
        """Nominal reference (6 joints or a 4x4 TCP pose) at `t + dt`, and whether it ends."""
        ...


def rotation_exp(rotvec: np.ndarray) -> np.ndarray:
    """Rotation matrix of a rotation vector (Rodrigues' formula)."""
    angle = math.sqrt(float(rotvec @ rotvec))
    if angle < 1e-12:
        return np.eye(3)
    k = rotvec / angle
    cross = np.array([[0.0, -k[2], k[1]], [k[2], 0.0, -k[0]], [-k[1], k[0], 0.0]])
    return np.eye(3) + math.sin(angle) * cross + (1 - math.cos(angle)) * (cross @ cross)


class JointPath:
    """moveJ: all joints start and stop together; the leading joint follows the profile."""

    def __init__(
        self, start: np.ndarray, goal: np.ndarray, speed: float, acceleration: float, t0: float
    ) -> None:
        self.start, self.delta, self.t0 = start.copy(), goal - start, t0
        self.profile = TrapezoidalProfile(float(np.abs(self.delta).max()), speed, acceleration)

    def joints(self, t: float) -> np.ndarray:
        """Joint angles at sim time `t`."""
        if self.profile.distance == 0:
            return self.start + self.delta
        return self.start + self.delta * (
            self.profile.position(t - self.t0) / self.profile.distance
        )

    def finished(self, t: float) -> bool:
        """Whether the move has ended by sim time `t`."""
        return t - self.t0 >= self.profile.duration

    def reference(self, t: float, dt: float) -> tuple[np.ndarray, bool]:
        return self.joints(t + dt), self.finished(t + dt)


TOOL_ROTATION_SPEED = 1.0
"""Fastest tool orientation change of a moveL (rad/s)."""
TOOL_ROTATION_ACCELERATION = 4.0
"""Tool orientation acceleration of a moveL (rad/s^2)."""


class LinearPath:
    """moveL: the TCP moves on a straight line, its orientation turning about one fixed axis.

    The path fraction follows one trapezoidal profile, timed by whichever takes longer: the
    translation at (`speed`, `acceleration`) or the rotation at the tool rotation limits; so
    neither the TCP speed nor the rotation speed exceeds its limit.
    """

    def __init__(
        self, start: np.ndarray, goal: np.ndarray, speed: float, acceleration: float, t0: float
    ) -> None:
        self.start, self.t0 = start.copy(), t0
        self.translation = goal[:3, 3] - start[:3, 3]
        self.rotvec = Rotation.from_matrix(start[:3, :3].T @ goal[:3, :3]).as_rotvec()
        translation = TrapezoidalProfile(
            float(np.linalg.norm(self.translation)), speed, acceleration
        )
        rotation = TrapezoidalProfile(
            float(np.linalg.norm(self.rotvec)), TOOL_ROTATION_SPEED, TOOL_ROTATION_ACCELERATION
        )
        self.profile = max(translation, rotation, key=lambda profile: profile.duration)

    def fraction(self, t: float) -> float:
        if self.profile.distance == 0:
            return 1.0
        return self.profile.position(t - self.t0) / self.profile.distance

    def pose_at_fraction(self, u: float) -> np.ndarray:
        pose = np.eye(4)
        pose[:3, :3] = self.start[:3, :3] @ rotation_exp(u * self.rotvec)
        pose[:3, 3] = self.start[:3, 3] + u * self.translation
        return pose

    def pose(self, t: float) -> np.ndarray:
        """TCP pose at sim time `t`."""
        return self.pose_at_fraction(self.fraction(t))

    def finished(self, t: float) -> bool:
        """Whether the move has ended by sim time `t`."""
        return t - self.t0 >= self.profile.duration

    def reference(self, t: float, dt: float) -> tuple[np.ndarray, bool]:
        return self.pose(t + dt), self.finished(t + dt)


class JointServo:
    """servoJ/servoL: follow streamed joint targets.

    A new target is approached linearly over the command's `time`, then smoothed by a
    first-order filter with time constant `lookahead_time`, as UR's servo smooths a stream.
    """

    def __init__(self, current: np.ndarray, t0: float) -> None:
        self.previous = current.copy()
        self.target = current.copy()
        self.filtered = current.copy()
        self.t_command, self.duration, self.lookahead = t0, 0.0, 0.0

    def command(self, target: np.ndarray, t: float, duration: float, lookahead: float) -> None:
        self.previous = self._interpolated(t)
        self.target = target.copy()
        self.t_command, self.duration, self.lookahead = t, duration, lookahead

    def _interpolated(self, t: float) -> np.ndarray:
        if self.duration <= 0:
            return self.target.copy()
        alpha = min(max((t - self.t_command) / self.duration, 0.0), 1.0)
        return self.previous + alpha * (self.target - self.previous)

    def reference(self, t: float, dt: float) -> tuple[np.ndarray, bool]:
        blend = dt / (self.lookahead + dt)
        self.filtered += blend * (self._interpolated(t + dt) - self.filtered)
        return self.filtered.copy(), False


class CartesianVelocity:
    """speedL: the TCP velocity (linear m/s, angular rad/s, base frame) ramps to a target.

    The linear and the angular parts each change at most `acceleration` (m/s^2, rad/s^2).
    """

    def __init__(self, pose: np.ndarray) -> None:
        self.pose = pose.copy()
        self.velocity = np.zeros(6)
        self.target = np.zeros(6)
        self.acceleration = 1.0

    def command(self, velocity: np.ndarray, acceleration: float) -> None:
        self.target, self.acceleration = velocity.copy(), acceleration

    def reference(self, t: float, dt: float) -> tuple[np.ndarray, bool]:
        for part in (slice(0, 3), slice(3, 6)):
            change = self.target[part] - self.velocity[part]
            norm = float(np.linalg.norm(change))
            limit = self.acceleration * dt
            self.velocity[part] += change if norm <= limit else change * (limit / norm)
        self.pose[:3, 3] += self.velocity[:3] * dt
        self.pose[:3, :3] = rotation_exp(self.velocity[3:] * dt) @ self.pose[:3, :3]
        return self.pose.copy(), False


class JointDeceleration:
    """stop: each joint brakes from its reference velocity at `deceleration` (rad/s^2)."""

    def __init__(self, q: np.ndarray, qd: np.ndarray, deceleration: float) -> None:
        self.q, self.qd, self.deceleration = q.copy(), qd.copy(), deceleration

    def reference(self, t: float, dt: float) -> tuple[np.ndarray, bool]:
        speed = np.abs(self.qd)
        new_speed = np.maximum(speed - self.deceleration * dt, 0.0)
        self.q += np.sign(self.qd) * 0.5 * (speed + new_speed) * dt
        self.qd = np.sign(self.qd) * new_speed
        return self.q.copy(), not self.qd.any()
