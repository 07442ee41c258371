"""Rigid transforms as 4x4 homogeneous matrices (float64, metres, radians).

Everything in the project passes poses as 4x4 matrices; this module holds the few operations
on them that several parts need, including the one conversion to and from Universal Robots'
`[x, y, z, rx, ry, rz]` (rotation vector) pose used at the ur_rtde boundary.
"""

from __future__ import annotations

import numpy as np
from scipy.spatial.transform import Rotation

RIGID_TOLERANCE = 1e-6


def make_pose(rotation: np.ndarray, translation: np.ndarray) -> np.ndarray:
    """Build a 4x4 pose from a 3x3 rotation matrix and a translation (metres)."""
    pose = np.eye(4)
    pose[:3, :3] = rotation
    pose[:3, 3] = translation
    return pose


def invert_pose(pose: np.ndarray) -> np.ndarray:
    """Inverse of a rigid transform (or a stack of them), without a general matrix inverse."""
    pose = np.asarray(pose, dtype=np.float64)
    rotation_t = np.swapaxes(pose[..., :3, :3], -1, -2)
    inverse = np.zeros_like(pose)
    inverse[..., :3, :3] = rotation_t
    inverse[..., :3, 3] = -np.einsum("...ij,...j->...i", rotation_t, pose[..., :3, 3])
    inverse[..., 3, 3] = 1.0
    return inverse


def rigidity_error(pose: np.ndarray) -> np.ndarray:
    """How far each pose is from a rigid transform: max |R^T R - I|, |det R - 1|, bottom row."""
    pose = np.asarray(pose, dtype=np.float64)
    rotation = pose[..., :3, :3]
    gram = np.einsum("...ji,...jk->...ik", rotation, rotation) - np.eye(3)
    orthogonality = np.abs(gram).max(axis=(-1, -2))
    determinant = np.abs(np.linalg.det(rotation) - 1.0)
    bottom = np.abs(pose[..., 3, :] - np.array([0.0, 0.0, 0.0, 1.0])).max(axis=-1)
    return np.maximum(np.maximum(orthogonality, determinant), bottom)


def is_rigid(pose: np.ndarray, tolerance: float = RIGID_TOLERANCE) -> np.ndarray:
    """True where a pose (or each pose of a stack) is a proper rigid transform and finite."""
    pose = np.asarray(pose, dtype=np.float64)
    finite = np.isfinite(pose).all(axis=(-1, -2))
    with np.errstate(invalid="ignore"):
        return finite & (rigidity_error(np.nan_to_num(pose)) <= tolerance)


def pose_from_ur(ur_pose: np.ndarray) -> np.ndarray:
    """UR `[x, y, z, rx, ry, rz]` (metres, rotation vector in radians) to a 4x4 pose."""
    ur_pose = np.asarray(ur_pose, dtype=np.float64)
    if ur_pose.shape[-1] != 6:
        raise ValueError(f"a UR pose has 6 numbers, got shape {ur_pose.shape}")
    pose = np.zeros((*ur_pose.shape[:-1], 4, 4))
    pose[..., :3, :3] = (
        Rotation.from_rotvec(ur_pose[..., 3:].reshape(-1, 3))
        .as_matrix()
        .reshape((*ur_pose.shape[:-1], 3, 3))
    )
    pose[..., :3, 3] = ur_pose[..., :3]
    pose[..., 3, 3] = 1.0
    return pose


def pose_to_ur(pose: np.ndarray) -> np.ndarray:
    """4x4 pose to UR `[x, y, z, rx, ry, rz]`; the rotation vector has angle in [0, pi]."""
    pose = np.asarray(pose, dtype=np.float64)
    rotvec = Rotation.from_matrix(pose[..., :3, :3].reshape(-1, 3, 3)).as_rotvec()
    return np.concatenate([pose[..., :3, 3], rotvec.reshape((*pose.shape[:-2], 3))], axis=-1)


def quaternions_to_matrices(quaternions: np.ndarray) -> np.ndarray:
    """Unit quaternions (N, 4) as scalar-last (x, y, z, w) to rotation matrices (N, 3, 3)."""
    x, y, z, w = quaternions.T
    return np.stack(
        [
            np.stack([1 - 2 * (y * y + z * z), 2 * (x * y - z * w), 2 * (x * z + y * w)], -1),
            np.stack([2 * (x * y + z * w), 1 - 2 * (x * x + z * z), 2 * (y * z - x * w)], -1),
            np.stack([2 * (x * z - y * w), 2 * (y * z + x * w), 1 - 2 * (x * x + y * y)], -1),
        ],
        axis=1,
    )


def _slerp_quaternions(q0: np.ndarray, q1: np.ndarray, u: np.ndarray) -> np.ndarray:
    """Spherical-linear interpolation of unit quaternion pairs (N, 4) at fractions u (N,)."""
    dot = np.einsum("ni,ni->n", q0, q1)
    q1 = np.where(dot[:, None] < 0.0, -q1, q1)  # take the short way round
    angle = np.arccos(np.clip(np.abs(dot), 0.0, 1.0))
    sine = np.sin(angle)
    nearly_equal = sine < 1e-9
    safe = np.where(nearly_equal, 1.0, sine)
    w0 = np.where(nearly_equal, 1.0 - u, np.sin((1.0 - u) * angle) / safe)
    w1 = np.where(nearly_equal, u, np.sin(u * angle) / safe)
    q = w0[:, None] * q0 + w1[:, None] * q1
    return q / np.linalg.norm(q, axis=1, keepdims=True)


class PoseInterpolator:
    """Poses as a function of a strictly increasing parameter (seconds, arc length): linear in
    position, spherical-linear (slerp) in rotation; queries outside are clamped to the ends,
    because a tracker cannot report where the probe was before or after it looked.

    The rotations are turned into quaternions once, so each query is cheap (it runs on the
    500 Hz control path)."""

    def __init__(self, times: np.ndarray, poses: np.ndarray) -> None:
        self.times = np.asarray(times, dtype=np.float64)
        poses = np.asarray(poses, dtype=np.float64)
        if len(self.times) != len(poses) or len(poses) == 0:
            raise ValueError(f"need one time per pose, got {len(self.times)} and {len(poses)}")
        if np.any(np.diff(self.times) <= 0):
            raise ValueError("interpolation times must be strictly increasing")
        self.positions = poses[:, :3, 3].copy()
        self.quaternions = Rotation.from_matrix(poses[:, :3, :3]).as_quat()

    def __call__(self, query_times: np.ndarray | float) -> np.ndarray:
        """Poses (T, 4, 4) at the query times."""
        times = self.times
        query = np.clip(
            np.atleast_1d(np.asarray(query_times, dtype=np.float64)), times[0], times[-1]
        )
        if len(times) == 1:
            lower = upper = np.zeros(len(query), dtype=int)
            u = np.zeros(len(query))
        else:
            upper = np.clip(np.searchsorted(times, query, side="right"), 1, len(times) - 1)
            lower = upper - 1
            u = (query - times[lower]) / (times[upper] - times[lower])
        out = np.zeros((len(query), 4, 4))
        rotation = _slerp_quaternions(self.quaternions[lower], self.quaternions[upper], u)
        out[:, :3, :3] = quaternions_to_matrices(rotation)
        out[:, :3, 3] = (1.0 - u)[:, None] * self.positions[lower] + u[:, None] * self.positions[
            upper
        ]
        out[:, 3, 3] = 1.0
        return out


def interpolate_poses(times: np.ndarray, poses: np.ndarray, query_times: np.ndarray) -> np.ndarray:
    """Poses at `query_times` (see `PoseInterpolator`), for a one-off query."""
    return PoseInterpolator(times, poses)(query_times)
