"""Reconstructed volumes and reslices in rerun, in the world frame where they were made.

A volume shows as its three index-orthogonal centre slices (textured quads on the grid, any
grid, the RANSAC parallelepiped included), the outline of its voxels, and on request as a dense
`Volume3D` (rerun marks that archetype unstable; it needs an orthogonal, right-handed grid).
Reslices show one at a time on the "reslice" timeline: the plane in 3D and the image in 2D.
"""

from __future__ import annotations

from collections.abc import Sequence
from itertools import product

import numpy as np
import rerun as rr

from resus.errors import ResusError
from resus.indices import evenly_spaced
from resus.reconstruction.grid import VolumeGrid
from resus.reconstruction.io import intensity_to_uint8
from resus.reslicing.reslice import Reslice
from resus.visualize import entities as at
from resus.visualize.quads import textured_quad
from resus.visualize.transforms import quaternions_xyzw

AXIS_NAMES = "ijk"
ORTHOGONAL_TOLERANCE = 1e-6


def slice_to_world(grid: VolumeGrid, axis: int, index: int) -> np.ndarray:
    """4x4 taking pixel `(col, row, 0, 1)` of slice `index` across `axis` to world metres.

    Columns run along the lower remaining grid axis, rows along the higher one, so the slice
    image is `volume.take(index, axis).T`.
    """
    across, down = (a for a in range(3) if a != axis)
    pixel_to_voxel = np.zeros((4, 4))
    pixel_to_voxel[across, 0] = pixel_to_voxel[down, 1] = pixel_to_voxel[axis, 2] = 1.0
    pixel_to_voxel[axis, 3] = index
    pixel_to_voxel[3, 3] = 1.0
    return grid.voxel_to_world @ pixel_to_voxel


def outline_segments(grid: VolumeGrid) -> np.ndarray:
    """(12, 2, 3) world end points of the edges of the grid's voxel box (voxel faces, not
    centres)."""
    low, high = -0.5, np.array(grid.shape) - 0.5
    corners = {c: grid.to_world(np.where(c, high, low)) for c in product((0, 1), repeat=3)}
    return np.array(
        [
            [corners[c], corners[tuple(1 if a == axis else v for a, v in enumerate(c))]]
            for c in corners
            for axis in range(3)
            if c[axis] == 0
        ]
    )


def check_dense_grid(grid: VolumeGrid) -> None:
    """ResusError unless `Volume3D` can place the grid: orthogonal and right-handed axes."""
    directions = grid.directions
    if not np.allclose(directions @ directions.T, np.eye(3), atol=ORTHOGONAL_TOLERANCE) or (
        np.linalg.det(directions) < 0
    ):
        raise ResusError(
            "a dense rerun volume needs an orthogonal, right-handed voxel grid "
            "(an axis-aligned box grid)"
        )


def dense_volume(volume: np.ndarray, grid: VolumeGrid) -> rr.Volume3D:
    """The volume as a ray-marched `Volume3D` (float16 grey levels 0..255)."""
    check_dense_grid(grid)
    pose = np.eye(4)
    pose[:3, :3] = grid.directions.T
    return rr.Volume3D(
        np.ascontiguousarray(volume.transpose(2, 1, 0)).astype(np.float16),
        voxel_size=grid.spacing,
        translation=grid.origin - 0.5 * grid.axes.sum(axis=0),
        quaternion=quaternions_xyzw(pose),  # type: ignore[arg-type]  # rerun takes xyzw arrays
        value_range=(0.0, 255.0),
    )


def log_volume(
    stream: rr.RecordingStream,
    volume: np.ndarray,
    grid: VolumeGrid,
    labels: np.ndarray | None = None,
    *,
    dense: bool = False,
) -> None:
    """Log (static) a volume on its grid: centre slices tinted by `labels`, outline, dense."""
    if volume.shape != grid.shape or (labels is not None and labels.shape != grid.shape):
        raise ResusError(f"volume {volume.shape} and labels must match the grid {grid.shape}")
    dense_archetype = dense_volume(volume, grid) if dense else None  # refuse before logging
    grey = intensity_to_uint8(volume)
    for axis in range(3):
        index = grid.shape[axis] // 2
        label = None if labels is None else labels.take(index, axis).T
        stream.log(
            f"{at.VOLUME}/slices/{AXIS_NAMES[axis]}",
            textured_quad(slice_to_world(grid, axis, index), grey.take(index, axis).T, label),
            static=True,
        )
    stream.log(
        f"{at.VOLUME}/outline",
        rr.LineStrips3D(outline_segments(grid), colors=(240, 200, 40), radii=0.0003),
        static=True,
    )
    if dense_archetype is not None:
        stream.log(f"{at.VOLUME}/dense", dense_archetype, static=True)


def log_reslices(
    stream: rr.RecordingStream,
    reslices: Sequence[Reslice],
    label_names: Sequence[str],
    *,
    limit: int | None = None,
) -> int:
    """Log reslices (a list or a `ResliceDataset`) on the "reslice" timeline, at most `limit`
    of them evenly spread; returns how many were logged."""
    stream.log(at.RESLICE_2D, at.annotation_context(tuple(label_names)), static=True)
    chosen = range(len(reslices)) if limit is None else evenly_spaced(len(reslices), limit)
    for index in chosen:
        reslice = reslices[index]
        stream.set_time(at.RESLICE, sequence=index)
        stream.log(
            at.RESLICE_QUAD, textured_quad(reslice.plane_to_world, reslice.image, reslice.label)
        )
        stream.log(f"{at.RESLICE_2D}/image", rr.Image(reslice.image))
        stream.log(
            f"{at.RESLICE_2D}/labels", rr.SegmentationImage(reslice.label, opacity=at.LABEL_OPACITY)
        )
    stream.reset_time()
    return len(chosen)
