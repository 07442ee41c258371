"""GridSettings: the one place that turns a grid's name into the grid around a sweep."""

from __future__ import annotations

import numpy as np
import pytest

from resus.errors import ResusError
from resus.reconstruction.grid import aabb_grid
from resus.reconstruction.grid_settings import GridSettings
from resus.reconstruction.parallelepiped import ransac_grid
from sim.transforms import make_pose
from sim.ultrasound.probe import LinearProbe

DOWN = np.diag([1.0, -1.0, -1.0])
POSES = np.stack([make_pose(DOWN, (0.0, 1e-3 * k, 0.1)) for k in range(12)])
"""A 11 mm linear sweep along y, the beam down."""
FRAMES = (POSES, LinearProbe(cols=32, rows=24).image_to_probe(), (24, 32))


def test_each_kind_is_the_grid_its_function_makes() -> None:
    poses, image_to_probe, shape = FRAMES
    box = GridSettings("aabb", spacing=1e-3).around(*FRAMES)
    expected = aabb_grid(1e-3, poses=poses, image_to_probe=image_to_probe, frame_shape=shape)
    assert box.places_like(expected) and box.shape == expected.shape
    fitted = GridSettings(spacing=1e-3, seed=3).around(*FRAMES)
    expected = ransac_grid(poses, image_to_probe, shape, spacing=1e-3, seed=3)
    assert fitted.places_like(expected) and fitted.shape == expected.shape
    counted = GridSettings(voxels=(9, 7, 5)).around(*FRAMES)
    assert counted.shape == (9, 7, 5)
    np.testing.assert_allclose(counted.corners(), fitted.corners(), atol=1e-12)  # same box


@pytest.mark.parametrize(
    ("changes", "message"),
    [
        ({"kind": "sphere"}, r"GridSettings\.kind must be one of ransac, aabb, got 'sphere'"),
        ({"spacing": 0.0}, r"GridSettings\.spacing must be positive, got 0\.0"),
        (
            {"kind": "aabb", "voxels": (8, 8, 8)},
            r"GridSettings\.voxels sets the ransac grid's voxel counts; GridSettings\.kind 'aabb'",
        ),
    ],
)
def test_refused_settings_are_named(changes: dict, message: str) -> None:
    with pytest.raises(ResusError, match=rf"^{message}"):
        GridSettings(**changes)
