"""Setpoint generators for UR motion commands: one target per control period.

UR's controller turns each command into a stream of setpoints. moveJ and moveL follow a
trapezoidal profile (`sim.robot.motions`' JointPath and LinearPath, shared with the simulated
robot); speedJ/speedL ramp to a velocity and hold it and stopJ/stopL/servoStop brake to rest
(`VelocityMove`, in either space, starting from the arm's actual velocity so that a stop
continues whatever motion ran before); servoJ/servoL follow the client's latest target as UR's
servo does, over the command's servo time and smoothed by its lookahead time (`ServoTarget`).
`advance(dt)` gives the next target: joints (6,) or a TCP pose (4x4).
"""

from __future__ import annotations

from abc import ABC, abstractmethod

import numpy as np
from scipy.spatial.transform import Rotation

from sim.robot.motions import JointPath, LinearPath, rotation_exp

JOINT = "joint"
LINEAR = "linear"


def rotation_vector(rotation: np.ndarray) -> np.ndarray:
    """The rotation vector (axis times angle, rad) of a rotation matrix turned by under pi."""
    skew = np.array(
        [
            rotation[2, 1] - rotation[1, 2],
            rotation[0, 2] - rotation[2, 0],
            rotation[1, 0] - rotation[0, 1],
        ]
    )
    angle = np.arccos(np.clip((np.trace(rotation) - 1.0) / 2.0, -1.0, 1.0))
    return (0.5 if angle < 1e-9 else angle / (2.0 * np.sin(angle))) * skew


def twist_between(start: np.ndarray, end: np.ndarray, dt: float) -> np.ndarray:
    """TCP velocity (vx, vy, vz, wx, wy, wz; base frame) that moves `start` to `end` in dt.

    For the small rotations between control periods; exact below about 3 rad.
    """
    turn = rotation_vector(end[:3, :3] @ start[:3, :3].T)
    return np.concatenate([end[:3, 3] - start[:3, 3], turn]) / dt


def displace(pose: np.ndarray, twist: np.ndarray, dt: float) -> np.ndarray:
    """`pose` moved by base-frame velocity `twist` for dt."""
    result = pose.copy()
    result[:3, 3] += twist[:3] * dt
    result[:3, :3] = Rotation.from_rotvec(twist[3:] * dt).as_matrix() @ pose[:3, :3]
    return result


class Motion(ABC):
    """A command in progress: `advance(dt)` gives the next target in `space`."""

    space: str
    finished: bool = False

    @abstractmethod
    def advance(self, dt: float) -> np.ndarray:
        """The target for the coming period."""


class ProfiledMove(Motion):
    """moveJ / moveL: rest to rest along a trapezoidal profile."""

    def __init__(
        self, space: str, start: np.ndarray, goal: np.ndarray, speed: float, acceleration: float
    ) -> None:
        if not (speed > 0 and acceleration > 0):
            raise ValueError(
                f"speed and acceleration must be positive, got {speed}, {acceleration}"
            )
        path_type = JointPath if space == JOINT else LinearPath
        self.space = space
        self.path = path_type(np.array(start), np.array(goal), speed, acceleration, 0.0)
        self.elapsed = 0.0

    def advance(self, dt: float) -> np.ndarray:
        self.elapsed += dt
        self.finished = self.path.finished(self.elapsed)
        if isinstance(self.path, JointPath):  # the JOINT space's path
            return self.path.joints(self.elapsed)
        return self.path.pose(self.elapsed)


class VelocityMove(Motion):
    """speedJ / speedL (ramp to `velocity` and hold) and the stops (`velocity` zero).

    The velocity changes at most `acceleration` per second on its leading coordinate.
    """

    def __init__(
        self,
        space: str,
        start: np.ndarray,
        initial_velocity: np.ndarray,
        velocity: np.ndarray,
        acceleration: float,
    ) -> None:
        self.space, self.target = space, np.array(start)
        self.velocity = np.array(initial_velocity, dtype=np.float64)
        self.retarget(velocity, acceleration)

    def retarget(self, velocity: np.ndarray, acceleration: float) -> None:
        """A new goal velocity (the client streams speedL/speedJ)."""
        if not acceleration > 0:
            raise ValueError(f"acceleration must be positive, got {acceleration}")
        self.goal_velocity = np.array(velocity, dtype=np.float64)
        self.acceleration = acceleration
        self.finished = self._at_rest()

    def _at_rest(self) -> bool:
        return not self.goal_velocity.any() and not self.velocity.any()

    def advance(self, dt: float) -> np.ndarray:
        change = self.goal_velocity - self.velocity
        largest = float(np.max(np.abs(change)))
        step = self.acceleration * dt
        if largest <= step:
            self.velocity = self.goal_velocity.copy()
        else:
            self.velocity = self.velocity + change * (step / largest)
        if self.space == JOINT:
            self.target = self.target + self.velocity * dt
        else:
            self.target = displace(self.target, self.velocity, dt)
        self.finished = self._at_rest()
        return self.target.copy()


def blend(space: str, start: np.ndarray, end: np.ndarray, weight: float) -> np.ndarray:
    """The point `weight` (0..1) of the way from `start` to `end`: linear for joints; for TCP
    poses linear in position and along the shortest rotation between the orientations."""
    if space == JOINT:
        return start + weight * (end - start)
    result = end.copy()
    result[:3, 3] = start[:3, 3] + weight * (end[:3, 3] - start[:3, 3])
    turn = rotation_vector(start[:3, :3].T @ end[:3, :3])
    result[:3, :3] = start[:3, :3] @ rotation_exp(weight * turn)
    return result


class ServoTarget(Motion):
    """servoJ / servoL: the client's latest target, followed as UR's servo follows a stream.

    Each new target is approached linearly over the command's servo `time`, and that path is
    smoothed by a first-order filter with the command's `lookahead_time` as time constant,
    the model `sim.robot.motions.JointServo` uses for the simulated robot's own servo. So a
    target that arrives late and lands many periods ahead (a client on a loaded machine skips
    targets to keep to the plan's clock) moves the arm smoothly instead of by a step within
    one period: in contact with the phantom such a step spikes the force, and an arm still
    settling from it goes on moving for tens of milliseconds after a stop.
    """

    def __init__(self, space: str, start: np.ndarray) -> None:
        """Start at rest at `start` (the arm's actual joints or TCP pose)."""
        self.space = space
        self.setpoint = np.array(start, dtype=np.float64)
        self.previous = self.setpoint.copy()
        self.target = self.setpoint.copy()
        self.elapsed = self.duration = self.lookahead = 0.0

    def command(self, target: np.ndarray, duration: float, lookahead: float) -> None:
        """A streamed target, reached over `duration` and smoothed over `lookahead` (s). The
        controller reads the registers every cycle: a repeat of the current command changes
        nothing."""
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
        self.elapsed += dt
        self.setpoint = blend(
            self.space, self.setpoint, self._interpolated(), dt / (self.lookahead + dt)
        )
        return self.setpoint.copy()
