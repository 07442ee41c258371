"""The expected fraction of holes in the reconstruction, from the planned frames alone.

The grid is the one `resus reconstruct --grid aabb` would use: axis-aligned, cubic voxels of
the planned size, around every imaging frame's corners. Holes are counted only inside the
swept volume (voxels between the rectangles of neighbouring frames of one imaging segment), so
the empty corners of the box do not count. A voxel is observed when its centre lies within the
SDW kernel radius (1.5 voxels by default) of a frame's image rectangle: the planned planes are
rasterised, not the pixels (a pixel pitch far below the voxel size makes the two the same
up to a few per cent of a voxel at the plane's edges). The measured counterpart reconstructs
the simulated frames with the real SDW kernel and no hole filling, on the same grid definition.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from resus.acquisition.trajectory import Trajectory
from resus.planning import hole_kernels
from resus.planning.checks import CheckResult, place_at
from resus.planning.sampling import FrameSamples
from resus.reconstruction.compounding import ReconstructionSettings
from resus.reconstruction.grid import VolumeGrid, aabb_grid, frame_corner_pixels, frame_points_world
from sim.transforms import invert_pose
from sim.ultrasound.probe import LinearProbe

MAX_HOLE_FRACTION = 0.05
"""Largest acceptable fraction of holes in the swept volume before hole filling."""


@dataclass(frozen=True)
class HoleEstimate:
    """Holes of a set of frames on a grid."""

    grid: VolumeGrid
    swept: np.ndarray
    """(nx, ny, nz) bool: voxels between neighbouring frames."""
    observed: np.ndarray
    """(nx, ny, nz) bool: voxels a frame reaches."""
    pair_fraction: np.ndarray
    """(N - 1,) hole fraction between frame i and i + 1 (NaN across segments)."""

    @property
    def fraction(self) -> float:
        count = int(self.swept.sum())
        return float((self.swept & ~self.observed).sum() / count) if count else 1.0


def imaging_grid(poses: np.ndarray, probe: LinearProbe, voxel_size: float) -> VolumeGrid:
    """The axis-aligned grid of `voxel_size` around the frames at `poses`."""
    return aabb_grid(
        voxel_size,
        poses=poses,
        image_to_probe=probe.image_to_probe(),
        frame_shape=(probe.rows, probe.cols),
    )


def _rectangle(probe: LinearProbe) -> tuple[float, float, float]:
    """Half width, top and bottom (m, probe frame) of the pixel-centre rectangle."""
    corners = frame_corner_pixels(probe.rows, probe.cols) @ probe.image_to_probe().T
    return float(corners[:, 0].max()), float(corners[:, 2].min()), float(corners[:, 2].max())


def _pairs(segment: np.ndarray) -> np.ndarray:
    """Indices i where frames i and i + 1 belong to the same imaging segment."""
    return np.flatnonzero((segment[1:] == segment[:-1]) & (segment[:-1] >= 0))


def swept_volume(
    grid: VolumeGrid, poses: np.ndarray, segment: np.ndarray, probe: LinearProbe, observed
) -> tuple[np.ndarray, np.ndarray]:
    """Swept mask on `grid` and per-pair hole fraction given the `observed` mask."""
    half_width, top, bottom = _rectangle(probe)
    pairs = _pairs(segment)
    swept = np.zeros(grid.shape, dtype=np.uint8)
    holes = np.zeros(len(pairs), dtype=np.int64)
    voxels = np.zeros(len(pairs), dtype=np.int64)
    corners = frame_points_world(
        poses, probe.image_to_probe(), frame_corner_pixels(probe.rows, probe.cols)
    )
    hole_kernels.mark_swept(
        grid.origin, grid.axes, grid.world_to_voxel, invert_pose(poses), corners, pairs,
        half_width, top, bottom, observed.view(np.uint8), swept, holes, voxels,
    )  # fmt: skip
    fraction = np.full(max(len(poses) - 1, 0), np.nan)
    fraction[pairs] = holes / np.maximum(voxels, 1)
    return swept.view(bool), fraction


def estimate_holes(
    frames: FrameSamples, probe: LinearProbe, voxel_size: float, radius_voxels: float
) -> HoleEstimate:
    """Rasterise the planned imaging frames into the reconstruction grid."""
    imaging = frames.imaging
    grid = imaging_grid(frames.poses[imaging], probe, voxel_size)
    half_width, top, bottom = _rectangle(probe)
    radius = radius_voxels * voxel_size
    observed = np.zeros(grid.shape, dtype=np.uint8)
    corners = frame_points_world(
        frames.poses[imaging], probe.image_to_probe(), frame_corner_pixels(probe.rows, probe.cols)
    )
    hole_kernels.mark_observed(
        grid.origin, grid.axes, grid.world_to_voxel, invert_pose(frames.poses[imaging]), corners,
        half_width, top, bottom, radius, grid.reach(radius) + 1, observed,
    )  # fmt: skip
    swept, fraction = swept_volume(grid, frames.poses, frames.segment, probe, observed.view(bool))
    return HoleEstimate(grid, swept, observed.view(bool), fraction)


def check_holes(
    trajectory: Trajectory, frames: FrameSamples, estimate: HoleEstimate
) -> CheckResult:
    """The swept volume has at most MAX_HOLE_FRACTION holes before hole filling; a scan that
    images at stations only (a compression scan) sweeps no volume and passes."""
    stations = trajectory.station_segments
    if stations and len(stations) == len(trajectory.imaging_segments or ()):
        return CheckResult(
            "reconstruction holes", True, f"imaging at {len(stations)} stations: no volume swept"
        )
    fraction = estimate.fraction
    summary = (
        f"{fraction:.1%} of {int(estimate.swept.sum())} swept voxels unobserved "
        f"(limit {MAX_HOLE_FRACTION:.0%})"
    )
    if fraction <= MAX_HOLE_FRACTION:
        return CheckResult("reconstruction holes", True, summary)
    pair = estimate.pair_fraction
    over = np.flatnonzero(pair > MAX_HOLE_FRACTION)
    first, last = (int(over[0]), int(over[-1])) if len(over) else (0, len(pair) - 1)
    return CheckResult(
        "reconstruction holes",
        False,
        summary,
        place_at(trajectory, frames.times[first], frames.times[last + 1]),
        "frames are too far apart: see the frame spacing advice (slow down or raise the "
        "frame rate), or reconstruct with larger voxels",
    )


def default_radius_voxels() -> float:
    """The SDW kernel radius reconstruction uses by default (voxels)."""
    return ReconstructionSettings().radius
