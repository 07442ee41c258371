"""VolumeGrid geometry and the PLUS-style axis-aligned grid."""

import numpy as np
import pytest

from resus.errors import ResusError
from resus.reconstruction.grid import VolumeGrid, aabb_grid, ensure_memory


def skewed_grid() -> VolumeGrid:
    axes = np.array([[0.5e-3, 0.0, 0.0], [0.1e-3, 0.4e-3, 0.0], [0.05e-3, 0.1e-3, 0.3e-3]])
    return VolumeGrid(origin=(0.01, -0.02, 0.03), axes=axes, shape=(5, 6, 7))


def test_world_and_voxel_mappings_invert_each_other() -> None:
    grid = skewed_grid()
    indices = np.random.default_rng(1).uniform(-2, 8, size=(50, 3))
    np.testing.assert_allclose(grid.to_voxel(grid.to_world(indices)), indices, atol=1e-9)
    homogeneous = np.c_[indices, np.ones(50)]
    np.testing.assert_allclose(
        (grid.voxel_to_world @ homogeneous.T).T[:, :3], grid.to_world(indices)
    )
    np.testing.assert_allclose(grid.world_to_voxel @ grid.voxel_to_world, np.eye(4), atol=1e-9)
    np.testing.assert_allclose(
        grid.spacing, [0.5e-3, np.hypot(0.1e-3, 0.4e-3), np.linalg.norm([0.05e-3, 0.1e-3, 0.3e-3])]
    )


def test_corners_are_the_corner_voxel_centres() -> None:
    grid = skewed_grid()
    corners = grid.corners()
    assert corners.shape == (8, 3)
    assert any(np.allclose(c, grid.origin) for c in corners)
    assert any(np.allclose(c, grid.to_world([4, 5, 6])) for c in corners)


def test_reach_bounds_a_ball_in_index_space() -> None:
    grid = skewed_grid()
    radius = 1e-3
    directions = np.random.default_rng(2).normal(size=(20000, 3))
    ball = radius * directions / np.linalg.norm(directions, axis=1, keepdims=True)
    extent = np.abs(grid.to_voxel(grid.origin + ball)).max(axis=0)
    np.testing.assert_allclose(extent, grid.reach(radius), rtol=2e-3)
    assert np.all(extent <= grid.reach(radius) + 1e-12)


def test_aabb_grid_from_bounds_uses_plus_counts() -> None:
    grid = aabb_grid(0.5e-3, bounds=((0.0, 0.0, 0.0), (0.0101, 0.0049, 0.00124)))
    assert grid.shape == (21, 11, 3)  # round(range / spacing) + 1
    np.testing.assert_allclose(grid.axes, np.eye(3) * 0.5e-3)
    assert grid.bytes_needed(4) == 21 * 11 * 3 * 4


@pytest.mark.parametrize(
    ("kwargs", "message"),
    [
        ({"spacing": 0.0, "bounds": ((0, 0, 0), (1, 1, 1))}, "spacing"),
        ({"spacing": 1e-3, "bounds": ((0, 0, 0), (-1, 1, 1))}, "max < min"),
        ({"spacing": 1e-3}, "bounds or poses"),
    ],
)
def test_aabb_grid_rejects_bad_input(kwargs: dict, message: str) -> None:
    with pytest.raises(ResusError, match=message):
        aabb_grid(**kwargs)


def test_grid_rejects_degenerate_axes_and_shapes() -> None:
    with pytest.raises(ResusError, match="degenerate"):
        VolumeGrid(origin=np.zeros(3), axes=[[1, 0, 0], [0, 1, 0], [1, 1, 0]], shape=(2, 2, 2))
    with pytest.raises(ResusError, match="shape"):
        VolumeGrid(origin=np.zeros(3), axes=np.eye(3), shape=(2, 0, 2))


def test_a_grid_bigger_than_memory_is_refused_up_front() -> None:
    huge = VolumeGrid(origin=np.zeros(3), axes=np.eye(3) * 1e-4, shape=(100_000, 100_000, 100_000))
    with pytest.raises(ResusError, match=r"needs .* GiB .* available"):
        ensure_memory(huge, 8)
