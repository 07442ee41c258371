"""A vessel's surface from its share volume: closed, where the share crosses one half, and
facing outwards whichever way the grid's axes turn (a grid of negative determinant, as a
RANSAC parallelepiped may be, mirrors the marching-cubes triangles)."""

from __future__ import annotations

import numpy as np
import pytest

from resus.reconstruction.grid import VolumeGrid
from resus.vessels.map import VesselMapSettings, surface_mesh

SPACING, RADIUS, SIZE = 0.5e-3, 4.0e-3, 24
"""A 4 mm ball on a 24-voxel grid of 0.5 mm."""


def ball_share(grid: VolumeGrid, centre: np.ndarray) -> np.ndarray:
    """1 inside the ball, 0 outside, smoothly across its surface (a voxel's width)."""
    indices = np.stack(np.meshgrid(*(np.arange(n) for n in grid.shape), indexing="ij"), -1)
    distance = np.linalg.norm(grid.to_world(indices) - centre, axis=-1)
    return np.clip(0.5 - (distance - RADIUS) / SPACING, 0.0, 1.0).astype(np.float32)


@pytest.mark.parametrize("handed", ["right", "left"])
def test_the_surface_is_closed_round_and_faces_outwards(handed: str) -> None:
    axes = np.diag([SPACING, SPACING, SPACING if handed == "right" else -SPACING])
    grid = VolumeGrid(origin=(0.01, -0.02, 0.03), axes=axes, shape=(SIZE,) * 3)
    centre = grid.to_world(np.full(3, (SIZE - 1) / 2))
    mesh = surface_mesh(ball_share(grid, centre), grid, VesselMapSettings(smoothing_iterations=0))
    assert mesh is not None and mesh.is_watertight
    assert mesh.volume > 0  # outward normals: a mirrored winding would make it negative
    np.testing.assert_allclose(mesh.volume, 4 / 3 * np.pi * RADIUS**3, rtol=0.03)
    radii = np.linalg.norm(mesh.vertices - centre, axis=1)
    np.testing.assert_allclose(radii, RADIUS, atol=0.1 * SPACING)


def test_no_share_over_one_half_has_no_surface() -> None:
    grid = VolumeGrid(origin=(0.0, 0.0, 0.0), axes=np.eye(3) * SPACING, shape=(4, 4, 4))
    assert surface_mesh(np.full(grid.shape, 0.5, np.float32), grid, VesselMapSettings()) is None
