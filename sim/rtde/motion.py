"""Setpoint generators for UR motion commands: one target per control period.

UR's controller turns each command into a stream of setpoints. moveJ and moveL follow a
trapezoidal profile (`sim.robot.motions`' JointPath and LinearPath, shared with the simulated
robot); speedJ/speedL ramp to a velocity and hold it and stopJ/stopL/servoStop brake to rest
(`VelocityMove`, in either space, starting from the arm's actual velocity so that a stop
continues whatever motion ran before); servoJ/servoL follow the client's latest target as UR's
servo does, over the command's servo time and smoothed by its lookahead time (`ServoTarget`,
the simulated robot's own servo model).
`advance(dt)` gives the next target: joints (6,) or a TCP pose (4x4).
"""

from __future__ import annotations

from abc import ABC, abstractmethod

import numpy as np
from scipy.spatial.transform import Rotation

from sim.robot.motions import JOINT, JointPath, LinearPath, Servo, rotation_vector


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


class ServoTarget(Servo, Motion):
    """servoJ / servoL: the client's latest target, followed by the simulated robot's own
    servo model (`sim.robot.motions.Servo`: linear over the servo time, smoothed to second
    order over the lookahead time). So a target that arrives late and lands many periods
    ahead (a client on a loaded machine skips targets to keep to the plan's clock) moves the
    arm smoothly instead of by a step within one period: in contact with the phantom such a
    step spikes the force, and an arm still settling from it goes on moving for tens of
    milliseconds after a stop."""
