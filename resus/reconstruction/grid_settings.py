"""Which grid to put around a sweep: the paper's RANSAC parallelepiped or PLUS's axis-aligned
box, chosen by name, so `resus reconstruct` and the experiments' data make it one way."""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from resus.errors import ResusError, check_choice
from resus.reconstruction.grid import VolumeGrid, aabb_grid
from resus.reconstruction.parallelepiped import ransac_grid

GRIDS = ("ransac", "aabb")


@dataclass(frozen=True)
class GridSettings:
    """The kind of grid around a sweep and the size of its voxels."""

    kind: str = "ransac"
    """"ransac" (the paper's parallelepiped, `ransac_grid`) or "aabb" (PLUS's axis-aligned
    box of cubic voxels, `aabb_grid`)."""
    spacing: float = 0.5e-3
    """Voxel spacing (m); for "ransac" it sets the voxel counts unless `voxels` does."""
    voxels: tuple[int, int, int] | None = None
    """The "ransac" grid's voxel counts along its edges, instead of `spacing`."""
    seed: int = 0
    """Seed of the RANSAC plane fits."""

    def __post_init__(self) -> None:
        check_choice("GridSettings.kind", self.kind, GRIDS)
        if not self.spacing > 0:
            raise ResusError(f"GridSettings.spacing must be positive, got {self.spacing}")
        if self.voxels is not None and self.kind != "ransac":
            raise ResusError(
                f"GridSettings.voxels sets the ransac grid's voxel counts; GridSettings.kind "
                f"{self.kind!r} takes GridSettings.spacing alone"
            )

    def around(
        self, poses: np.ndarray, image_to_probe: np.ndarray, frame_shape: tuple[int, int]
    ) -> VolumeGrid:
        """The grid around every frame (of `frame_shape` pixels) at `poses` (base frame)."""
        if self.kind == "aabb":
            return aabb_grid(
                self.spacing, poses=poses, image_to_probe=image_to_probe, frame_shape=frame_shape
            )
        spacing = None if self.voxels is not None else self.spacing
        return ransac_grid(
            poses, image_to_probe, frame_shape, self.voxels, spacing=spacing, seed=self.seed
        )
