"""The paper's RANSAC parallelepiped recovers a known sweep geometry, deterministically."""

import numpy as np
import pytest
from scipy.spatial.transform import Rotation

from resus.errors import ResusError
from resus.reconstruction.parallelepiped import ransac_grid, ransac_plane
from sim.transforms import make_pose
from sim.ultrasound.probe import LinearProbe

PROBE = LinearProbe(width=0.03, depth=0.04, cols=61, rows=81)
TILT = Rotation.from_euler("xyz", [12, -7, 20], degrees=True).as_matrix()
STEP = np.array([0.0004, 0.0009, 0.0001])  # advances along y, not along the frame normal
N_FRAMES = 40


def straight_sweep() -> np.ndarray:
    return np.array([make_pose(TILT, (0.1, 0.2, 0.05) + i * STEP) for i in range(N_FRAMES)])


def true_corners(poses: np.ndarray) -> np.ndarray:
    """Every frame's corner pixels lie on the parallelepiped; start and end frames are faces."""
    pixels = np.array(
        [[c, r, 0, 1] for c in (0, PROBE.cols - 1) for r in (0, PROBE.rows - 1)], float
    )
    return np.concatenate(
        [(poses[i] @ PROBE.image_to_probe() @ pixels.T).T[:, :3] for i in (0, -1)]
    )


def test_fitted_parallelepiped_is_the_true_one() -> None:
    poses = straight_sweep()
    grid = ransac_grid(poses, PROBE.image_to_probe(), (PROBE.rows, PROBE.cols), (20, 30, 40))
    fitted = grid.corners()
    expected = true_corners(poses)
    distances = np.linalg.norm(fitted[:, None] - expected[None], axis=2)
    assert distances.min(axis=1).max() < 1e-9
    assert distances.min(axis=0).max() < 1e-9
    top_left = (poses[0] @ PROBE.image_to_probe() @ [0, 0, 0, 1])[:3]
    end_top_left = (poses[-1] @ PROBE.image_to_probe() @ [0, 0, 0, 1])[:3]
    np.testing.assert_allclose(grid.origin, top_left, atol=1e-9)
    np.testing.assert_allclose(grid.to_world([0, 0, 39]), end_top_left, atol=1e-9)
    assert np.linalg.det(grid.axes) > 0  # right-handed
    assert grid.shape == (20, 30, 40)


def test_voxel_counts_can_come_from_a_spacing() -> None:
    poses = straight_sweep()
    grid = ransac_grid(poses, PROBE.image_to_probe(), (PROBE.rows, PROBE.cols), spacing=0.5e-3)
    edges = np.linalg.norm(grid.axes * (np.array(grid.shape) - 1)[:, None], axis=1)
    assert np.all(grid.spacing <= 0.5e-3 + 1e-12)
    np.testing.assert_array_equal(grid.shape, np.ceil(edges / 0.5e-3 - 1e-9).astype(int) + 1)


def test_same_seed_same_grid_and_robust_to_an_outlier_frame() -> None:
    rng = np.random.default_rng(5)
    poses = straight_sweep()
    poses[:, :3, 3] += rng.normal(scale=2e-5, size=(N_FRAMES, 3))
    outlier = Rotation.from_euler("x", 25, degrees=True).as_matrix()
    poses[17, :3, :3] = outlier @ poses[17, :3, :3]
    args = (poses, PROBE.image_to_probe(), (PROBE.rows, PROBE.cols), (10, 10, 10))
    first, again = ransac_grid(*args, seed=3), ransac_grid(*args, seed=3)
    np.testing.assert_array_equal(first.origin, again.origin)
    np.testing.assert_array_equal(first.axes, again.axes)
    # the outlier frame does not tilt the base planes: z stays along the true sweep's edge
    clean = ransac_grid(straight_sweep(), *args[1:])
    z_fitted, z_clean = first.axes[2], clean.axes[2]
    angle = np.degrees(
        np.arccos(z_fitted @ z_clean / np.linalg.norm(z_fitted) / np.linalg.norm(z_clean))
    )
    assert angle < 1.0


def test_ransac_plane_ignores_outliers() -> None:
    rng = np.random.default_rng(0)
    points = np.c_[rng.uniform(-1, 1, size=(200, 2)), np.zeros(200)]
    points[:40, 2] = rng.uniform(0.2, 1.0, size=40)
    normal, offset = ransac_plane(points, rng, iterations=100, inlier_threshold=1e-3)
    np.testing.assert_allclose(np.abs(normal), [0, 0, 1], atol=1e-9)
    assert abs(offset) < 1e-9


def test_degenerate_sweeps_are_refused() -> None:
    poses = straight_sweep()
    shape = (PROBE.rows, PROBE.cols)
    with pytest.raises(ResusError, match="at least two frames"):
        ransac_grid(poses[:1], PROBE.image_to_probe(), shape, (4, 4, 4))
    with pytest.raises(ResusError, match=r"collinear|advance|parallel"):
        ransac_grid(np.repeat(poses[:1], 5, axis=0), PROBE.image_to_probe(), shape, (4, 4, 4))
    with pytest.raises(ResusError, match="exactly one"):
        ransac_grid(poses, PROBE.image_to_probe(), shape, (4, 4, 4), spacing=1e-3)
