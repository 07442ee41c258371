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
from numba import njit
from scipy.spatial.transform import Rotation

from sim.robot.profiles import TrapezoidalProfile


class Motion(Protocol):
    """A running motion command."""

    def reference(self, t: float, dt: float) -> tuple[np.ndarray, bool]:
        """Nominal reference (6 joints or a 4x4 TCP pose) at `t + dt`, and whether it ends."""
        ...


@njit(cache=True)
def rotation_exp(rotvec: np.ndarray) -> np.ndarray:
    """Rotation matrix of a rotation vector (Rodrigues' formula)."""
    angle = math.sqrt(rotvec[0] ** 2 + rotvec[1] ** 2 + rotvec[2] ** 2)
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


@njit(cache=True)
def rotation_vector(rotation: np.ndarray) -> np.ndarray:
    """The rotation vector (axis times angle, rad) of a rotation matrix turned by under pi."""
    skew = np.array(
        [
            rotation[2, 1] - rotation[1, 2],
            rotation[0, 2] - rotation[2, 0],
            rotation[1, 0] - rotation[0, 1],
        ]
    )
    cosine = (rotation[0, 0] + rotation[1, 1] + rotation[2, 2] - 1.0) / 2.0
    angle = math.acos(min(max(cosine, -1.0), 1.0))
    return (0.5 if angle < 1e-9 else angle / (2.0 * math.sin(angle))) * skew


JOINT = "joint"
"""A motion in joint space: six joint angles (rad)."""
LINEAR = "linear"
"""A motion in tool space: 4x4 TCP poses in the base frame."""


def blend(space: str, start: np.ndarray, end: np.ndarray, weight: float) -> np.ndarray:
    """The point `weight` (0..1) of the way from `start` to `end`: linear for joints; for TCP
    poses linear in position and along the shortest rotation between the orientations."""
    if space == JOINT:
        return start + weight * (end - start)
    return _blend_poses(start, end, weight)


@njit(cache=True)
def _blend_poses(start: np.ndarray, end: np.ndarray, weight: float) -> np.ndarray:
    result = end.copy()
    result[:3, 3] = start[:3, 3] + weight * (end[:3, 3] - start[:3, 3])
    rotation = np.ascontiguousarray(start[:3, :3])
    turn = rotation_vector(rotation.T @ np.ascontiguousarray(end[:3, :3]))
    result[:3, :3] = rotation @ rotation_exp(weight * turn)
    return result


class Servo:
    """servoJ / servoL: follow the latest streamed target (joints, or TCP poses: linear in
    tool space), as UR's servo follows a stream. The simulated robot's own servo and the RTDE
    emulator's (`sim.rtde.motion.ServoTarget`) are this one model.

    Each new target is approached linearly over the command's servo `time`, and that path is
    smoothed over its `lookahead_time` by a critically damped second-order filter: two
    first-order stages of half the lookahead each, whose mean delay is the lookahead. It is
    second order because of streams that arrive late: a client that stalls (a busy host, the
    RTDE round trip) sends, when it resumes, the target for the time it has reached, many
    periods ahead. A single first-order stage turned that jump into a step of the reference
    velocity, which the joint servos' velocity feed-forward turned into a torque step: the
    arm jerked, and with the probe on the skin its wrist sensor read the jerk as contact
    force. A fan rocks the probe about its face, so the flange swings on the TCP's 135 mm
    lever: a 0.4 s stall 50 ms into the default fan read 24.7 N against the 4 N held (a
    linear sweep 4.4 N), and `resus scan` stopped at its 20 N limit on the emulator. With two
    stages the reference velocity stays continuous and the same stall reads 7.3 N.
    """

    def __init__(self, space: str, start: np.ndarray) -> None:
        """Start at rest at `start` (joints (6,) in JOINT space, a TCP pose in LINEAR)."""
        self.space = space
        self.setpoint = np.array(start, dtype=np.float64)
        self.stage = self.setpoint.copy()
        """The first smoothing stage's output, which the second (`setpoint`) follows."""
        self.previous = self.setpoint.copy()
        self.target = self.setpoint.copy()
        self.elapsed = self.duration = self.lookahead = 0.0

    def command(self, target: np.ndarray, duration: float, lookahead: float) -> None:
        """A streamed target, reached over `duration` and smoothed over `lookahead` (s). A
        repeat of the current command changes nothing (the emulator reads its registers
        every cycle)."""
        target = np.asarray(target, dtype=np.float64)
        if (
            np.array_equal(target, self.target)
            and duration == self.duration
            and lookahead == self.lookahead
        ):
            return
        self.previous = self._interpolated()
        self.target = target.copy()
        self.elapsed, self.duration, self.lookahead = 0.0, max(duration, 0.0), max(lookahead, 0.0)

    def _interpolated(self) -> np.ndarray:
        if self.elapsed >= self.duration:
            return self.target
        return blend(self.space, self.previous, self.target, self.elapsed / self.duration)

    def advance(self, dt: float) -> np.ndarray:
        """The setpoint at the end of the coming period of `dt` seconds."""
        self.elapsed += dt
        weight = dt / (0.5 * self.lookahead + dt)
        self.stage = blend(self.space, self.stage, self._interpolated(), weight)
        self.setpoint = blend(self.space, self.setpoint, self.stage, weight)
        return self.setpoint.copy()

    def reference(self, t: float, dt: float) -> tuple[np.ndarray, bool]:
        """`Motion.reference`: the next setpoint; a servo never ends by itself."""
        return self.advance(dt), False


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
