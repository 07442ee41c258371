"""Small known volumes for the reslicing tests (not a test module)."""

from __future__ import annotations

import numpy as np
from scipy import ndimage
from scipy.spatial.transform import Rotation

from resus.reconstruction.grid import VolumeGrid


def grid_for(
    shape: tuple[int, int, int], spacing: float = 0.5e-3, turned: bool = True
) -> VolumeGrid:
    """An isotropic grid, turned and moved away from the world axes when `turned`."""
    rotation = (
        Rotation.from_euler("zyx", [25, -15, 10], degrees=True).as_matrix() if turned else np.eye(3)
    )
    return VolumeGrid(origin=np.array([0.12, -0.05, 0.03]), axes=spacing * rotation.T, shape=shape)


def index_points(shape: tuple[int, int, int]) -> np.ndarray:
    """Voxel indices (nx, ny, nz, 3) as floats."""
    return np.stack(
        np.meshgrid(*[np.arange(n, dtype=float) for n in shape], indexing="ij"), axis=-1
    )


def distance_to_line(points: np.ndarray, through: np.ndarray, direction: np.ndarray) -> np.ndarray:
    """Distance of each point (..., 3) to the line through `through` along unit `direction`."""
    offset = points - through
    return np.linalg.norm(offset - (offset @ direction)[..., None] * direction, axis=-1)


def cylinder_volume(
    shape: tuple[int, int, int], axis: np.ndarray, radius: float
) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """(volume, labels, unit axis): a cylinder of `radius` voxels through the centre along
    `axis` (index space), grey 200 and class 1 inside, grey 80 and class 0 outside."""
    axis = np.asarray(axis, dtype=float) / np.linalg.norm(axis)
    centre = (np.array(shape) - 1) / 2
    inside = distance_to_line(index_points(shape), centre, axis) <= radius
    return np.where(inside, 200.0, 80.0).astype(np.float32), inside.astype(np.uint8), axis


def vessel_volume(shape: tuple[int, int, int], seed: int = 0) -> tuple[np.ndarray, np.ndarray]:
    """(volume, labels): smooth textured tissue with an artery (1) and a vein (2) as tubes
    along z, lumens dark, in grey levels 0..255 and non-zero everywhere."""
    rng = np.random.default_rng(seed)
    tissue = ndimage.gaussian_filter(rng.standard_normal(shape).astype(np.float32), 2.0)
    volume = 120 + 40 * tissue / tissue.std()
    points = index_points(shape)
    labels = np.zeros(shape, dtype=np.uint8)
    nx, ny, _ = shape
    for label, (cx, cy, radius) in (
        (1, (0.35 * nx, 0.45 * ny, 0.12 * nx)),
        (2, (0.65 * nx, 0.5 * ny, 0.15 * nx)),
    ):
        inside = (
            distance_to_line(
                points,
                np.array([cx, cy, 0.0]),
                np.array([0.1, 0.05, 1.0]) / np.linalg.norm([0.1, 0.05, 1.0]),
            )
            <= radius
        )
        labels[inside] = label
    volume = np.where(labels > 0, 25.0, volume)
    volume = ndimage.gaussian_filter(volume, 0.7)
    return np.clip(volume, 1, 255).astype(np.float32), labels
