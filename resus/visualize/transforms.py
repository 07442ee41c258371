"""4x4 poses as rerun transforms: one `Transform3D`, or columns of them for `send_columns`."""

from __future__ import annotations

import numpy as np
import rerun as rr
from scipy.spatial.transform import Rotation


def quaternions_xyzw(poses: np.ndarray) -> np.ndarray:
    """Rotation parts of (..., 4, 4) poses as (..., 4) unit quaternions, x y z w (rerun's order)."""
    poses = np.asarray(poses, dtype=np.float64)
    flat = Rotation.from_matrix(poses[..., :3, :3].reshape(-1, 3, 3)).as_quat()
    return flat.reshape((*poses.shape[:-2], 4))


def pose_transform(pose: np.ndarray) -> rr.Transform3D:
    """A `Transform3D` placing a child frame at `pose` (child to parent, rigid)."""
    return rr.Transform3D(
        translation=pose[:3, 3],
        quaternion=quaternions_xyzw(pose),  # type: ignore[arg-type]  # rerun takes xyzw arrays
    )


def pose_columns(poses: np.ndarray) -> rr.ComponentColumnList:
    """`Transform3D` columns for (N, 4, 4) rigid poses, one row per pose."""
    return rr.Transform3D.columns(translation=poses[:, :3, 3], quaternion=quaternions_xyzw(poses))
