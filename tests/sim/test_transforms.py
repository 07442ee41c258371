"""Rigid-transform helpers against independent computations."""

import numpy as np
import pytest
from scipy.spatial.transform import Rotation

from sim.transforms import (
    interpolate_poses,
    invert_pose,
    is_rigid,
    make_pose,
    pose_from_ur,
    pose_to_ur,
)

RNG = np.random.default_rng(7)


def random_poses(n: int) -> np.ndarray:
    rotations = Rotation.random(n, random_state=3).as_matrix()
    return np.stack(
        [make_pose(r, t) for r, t in zip(rotations, RNG.normal(size=(n, 3)), strict=True)]
    )


def test_invert_matches_general_inverse() -> None:
    poses = random_poses(20)
    np.testing.assert_allclose(invert_pose(poses), np.linalg.inv(poses), atol=1e-12)


def test_ur_pose_round_trip_and_known_value() -> None:
    # A quarter turn about z at (0.1, 0.2, 0.3): rotation vector (0, 0, pi/2).
    pose = pose_from_ur([0.1, 0.2, 0.3, 0.0, 0.0, np.pi / 2])
    np.testing.assert_allclose(pose[:3, :3] @ [1, 0, 0], [0, 1, 0], atol=1e-12)
    np.testing.assert_allclose(pose[:3, 3], [0.1, 0.2, 0.3])
    poses = random_poses(50)
    np.testing.assert_allclose(pose_from_ur(pose_to_ur(poses)), poses, atol=1e-10)
    assert np.all(np.linalg.norm(pose_to_ur(poses)[:, 3:], axis=1) <= np.pi + 1e-12)


def test_ur_pose_rejects_wrong_length() -> None:
    with pytest.raises(ValueError, match="6 numbers"):
        pose_from_ur([0.0, 1.0, 2.0])


def test_is_rigid_flags_scaling_shear_and_nan() -> None:
    pose = random_poses(1)[0]
    assert is_rigid(pose)
    scaled = pose.copy()
    scaled[:3, :3] *= 1.01
    reflected = pose @ np.diag([1.0, 1.0, -1.0, 1.0])
    nan_pose = pose.copy()
    nan_pose[0, 3] = np.nan
    assert not is_rigid(scaled)
    assert not is_rigid(reflected)
    assert not is_rigid(nan_pose)


def test_interpolation_hits_midpoint_rotation_and_clamps() -> None:
    start = make_pose(np.eye(3), [0.0, 0.0, 0.0])
    end = make_pose(Rotation.from_euler("x", 90, degrees=True).as_matrix(), [1.0, 2.0, 0.0])
    poses = np.stack([start, end])
    mid, before, after = interpolate_poses([0.0, 2.0], poses, [1.0, -5.0, 9.0])
    np.testing.assert_allclose(mid[:3, 3], [0.5, 1.0, 0.0])
    angle = Rotation.from_matrix(mid[:3, :3]).magnitude()
    assert angle == pytest.approx(np.pi / 4)
    np.testing.assert_allclose(before, start)
    np.testing.assert_allclose(after, end, atol=1e-12)
