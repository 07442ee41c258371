"""The trajectory sampled for checking: densely in time for the robot, at the frame rate for
the images."""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np
from scipy.spatial.transform import Rotation

from resus.acquisition.trajectory import Trajectory

MAX_STEP_TIME = 0.01
"""Longest time between robot samples (s)."""
MAX_STEP_ARC = 0.5e-3
"""Longest path length between robot samples (m, rotation counted at the rotation radius)."""


@dataclass(frozen=True)
class PathSamples:
    """Uniform-time samples of the TCP path."""

    times: np.ndarray
    poses: np.ndarray
    """(T, 4, 4) TCP poses in the base frame."""

    @classmethod
    def of(cls, trajectory: Trajectory) -> PathSamples:
        step = min(MAX_STEP_TIME, MAX_STEP_ARC / trajectory.speed)
        count = int(np.ceil(trajectory.duration / step)) + 1
        times = np.linspace(0.0, trajectory.duration, count)
        return cls(times, trajectory.poses_at(times))

    def nearest(self, poses: np.ndarray, rotation_radius: float) -> np.ndarray:
        """(N,) index of the sample nearest each of `poses` (N, 4, 4): the position offset
        plus the rotation between them counted as arc at `rotation_radius`."""
        offsets = np.linalg.norm(poses[:, None, :3, 3] - self.poses[None, :, :3, 3], axis=2)
        relative = np.einsum("nji,tjk->ntik", poses[:, :3, :3], self.poses[:, :3, :3])
        turns = Rotation.from_matrix(relative.reshape(-1, 3, 3)).magnitude()
        return np.argmin(offsets + rotation_radius * turns.reshape(offsets.shape), axis=1)


@dataclass(frozen=True)
class FrameSamples:
    """The frames a probe at the trajectory's frame rate would take, and which count."""

    times: np.ndarray
    poses: np.ndarray
    """(N, 4, 4) probe poses in the base frame."""
    segment: np.ndarray
    """(N,) imaging segment of each frame, -1 for frames in transit (turnarounds)."""

    @classmethod
    def of(cls, trajectory: Trajectory) -> FrameSamples:
        times = np.arange(0.0, trajectory.duration + 1e-9, 1.0 / trajectory.frame_rate)
        return cls(times, trajectory.poses_at(times), trajectory.imaging_segment_at(times))

    @property
    def imaging(self) -> np.ndarray:
        return self.segment >= 0
