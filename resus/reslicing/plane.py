"""Arbitrary reslice planes in world coordinates, e.g. a longitudinal view along a vessel.

A plane is a centre point, two in-plane directions (columns and rows), a size and a pixel
spacing, all in world metres. It is sampled from a `SampledVolume` (cubic B-spline grey
levels, nearest-neighbour labels) and comes back with its `plane_to_world` pose, the same
kind of 4x4 the paper's reslices and the probe's `image_to_probe` carry.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from resus.errors import ResusError
from resus.reconstruction.grid import VolumeGrid
from resus.reconstruction.io import intensity_to_uint8
from resus.reslicing.geometry import plane_pose
from resus.reslicing.sampling import SampledVolume


def _unit(vector: np.ndarray, name: str) -> np.ndarray:
    vector = np.asarray(vector, dtype=np.float64).reshape(3)
    length = np.linalg.norm(vector)
    if not (np.isfinite(length) and length > 1e-12):
        raise ResusError(f"plane {name} must be a finite non-zero 3-vector, got {vector}")
    return vector / length


@dataclass(frozen=True)
class ObliquePlane:
    """A rectangle of pixels in the world: centre, column and row directions, size, spacing.

    The row direction is made orthogonal to the column direction (Gram-Schmidt), so only its
    side of the column direction matters. Pixel `(col, row)` lies at
    `centre + (col - (cols - 1) / 2) * spacing * u + (row - (rows - 1) / 2) * spacing * v`.
    """

    centre: np.ndarray
    """World point at the image centre (m)."""
    col_direction: np.ndarray
    """Direction of increasing column (image x)."""
    row_direction: np.ndarray
    """Direction of increasing row (image y, e.g. depth)."""
    width: float
    """Extent along the columns (m)."""
    height: float
    """Extent along the rows (m)."""
    spacing: float
    """Pixel size (m), the same along rows and columns."""

    def __post_init__(self) -> None:
        centre = np.asarray(self.centre, dtype=np.float64).reshape(3)
        if not np.isfinite(centre).all():
            raise ResusError(f"plane centre must be finite, got {centre}")
        u = _unit(self.col_direction, "col_direction")
        v = _unit(self.row_direction, "row_direction")
        v = v - (v @ u) * u
        if np.linalg.norm(v) < 1e-6:
            raise ResusError("plane row_direction is parallel to col_direction")
        for name in ("width", "height", "spacing"):
            if not (np.isfinite(getattr(self, name)) and getattr(self, name) > 0):
                raise ResusError(f"plane {name} must be positive metres, got {getattr(self, name)}")
        object.__setattr__(self, "centre", centre)
        object.__setattr__(self, "col_direction", u)
        object.__setattr__(self, "row_direction", v / np.linalg.norm(v))

    @classmethod
    def along_segment(
        cls,
        start: np.ndarray,
        end: np.ndarray,
        depth_direction: np.ndarray,
        height: float,
        spacing: float,
        margin: float = 0.0,
    ) -> ObliquePlane:
        """Longitudinal view: columns run from `start` to `end` (e.g. along a vessel's axis,
        `margin` metres beyond each end), rows along `depth_direction`, centred on the segment."""
        start = np.asarray(start, dtype=np.float64).reshape(3)
        end = np.asarray(end, dtype=np.float64).reshape(3)
        return cls(
            centre=(start + end) / 2,
            col_direction=end - start,
            row_direction=depth_direction,
            width=float(np.linalg.norm(end - start)) + 2 * margin,
            height=height,
            spacing=spacing,
        )

    @property
    def shape(self) -> tuple[int, int]:
        """(rows, cols) of the image."""
        return max(round(self.height / self.spacing), 1), max(round(self.width / self.spacing), 1)

    def plane_to_world(self) -> np.ndarray:
        """4x4 pose mapping pixel `(col, row, 0, 1)` to world metres."""
        rows, cols = self.shape
        col_step, row_step = self.spacing * self.col_direction, self.spacing * self.row_direction
        origin = self.centre - (cols - 1) / 2 * col_step - (rows - 1) / 2 * row_step
        return plane_pose(origin, col_step, row_step)


def reslice_plane(
    sampled: SampledVolume, grid: VolumeGrid, plane: ObliquePlane
) -> tuple[np.ndarray, np.ndarray | None, np.ndarray]:
    """`(image, labels, plane_to_world)` of `plane` through a volume on `grid`: uint8 grey
    levels, uint8 classes (None without a label volume), zero outside the volume."""
    if sampled.shape != grid.shape:
        raise ResusError(f"volume shape {sampled.shape} does not match its grid {grid.shape}")
    plane_to_world = plane.plane_to_world()
    plane_to_voxel = grid.world_to_voxel @ plane_to_world
    rows, cols = plane.shape
    image, labels = sampled.sample(
        plane_to_voxel[:3, 3], plane_to_voxel[:3, 0], plane_to_voxel[:3, 1], rows, cols
    )
    return intensity_to_uint8(image), labels, plane_to_world
