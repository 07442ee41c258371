"""A vessel's course from its voxel mask: cross-sections slice by slice along the leg.

The femoral vessels run along the leg, so the mask is cut into slices across the grid axis
closest to the proximal-distal direction. Each slice's 2D blobs are cross-sections; a blob's
centroid lies on the vessel's axis (the centroid of any planar cut of a straight tube does).
A slice is "branching" where a branch leaves: a blob elongated beyond `MAX_ELONGATION` (two
branches still merged, as just distal to the femoral bifurcation) or a change in the number
of blobs from a neighbouring slice. Slices with exactly one round blob are stations of the
trunk; their centroids, smoothed along the leg, give its tangent and curvature.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np
from scipy import ndimage

from resus.reconstruction.grid import VolumeGrid

MAX_ELONGATION = 1.15
"""Largest ratio of a round cross-section's principal axes: a tube cut up to 29 degrees off
its axis (mapped tubes measure 1.00-1.05; a branch leaving its trunk passes 1.15 about 1 mm
out of it, and two touching equal branches give 2)."""
MIN_SECTION_AREA = 2.0e-6
"""Blobs smaller than this (m^2, a disc of 0.8 mm radius) are fragments, not cross-sections."""
MIN_STATIONS = 3
"""Fewer trunk stations than this give no course (no tangent or curvature to speak of)."""
SMOOTHING_LENGTH = 3.0e-3
"""Standard deviation (m) of the Gaussian that smooths station centroids along the leg."""


@dataclass
class CrossSection:
    """One blob of one slice."""

    slice_index: int
    centroid: np.ndarray
    """World position (m)."""
    area: float
    """m^2, in the slice plane."""
    elongation: float
    """Ratio of the blob's principal axes (1 for a circle)."""


@dataclass
class VesselTrack:
    """A vessel's cross-sections and its trunk's stations, proximal to distal."""

    axis: np.ndarray
    """World unit vector across which slices are cut, pointing proximally."""
    sections: list[CrossSection]
    """Every round cross-section (elongation <= MAX_ELONGATION), branches included."""
    positions: np.ndarray
    """(M, 3) trunk station centres (smoothed centroids, m)."""
    tangents: np.ndarray
    """(M, 3) unit directions of the trunk, pointing proximally."""
    radii: np.ndarray
    """(M,) equivalent radius of each station's cross-section (m)."""
    curvature: np.ndarray
    """(M,) curvature of the smoothed trunk (1/m)."""
    branch_distance: np.ndarray
    """(M,) distance along the leg to the nearest branching slice (m; inf if none)."""
    end_distance: np.ndarray
    """(M,) distance along the leg to the nearer end of the mapped stretch (m)."""


def slicing_axis(grid: VolumeGrid, proximal: np.ndarray) -> int:
    """The grid axis closest to the proximal-distal direction."""
    return int(np.argmax(np.abs(grid.directions @ proximal)))


def cross_sections(
    mask: np.ndarray, grid: VolumeGrid, axis: int
) -> tuple[list[CrossSection], list[CrossSection]]:
    """All blobs of every slice across `axis` (round ones, and elongated ones)."""
    in_plane = [a for a in range(3) if a != axis]
    pixel_area = float(np.linalg.norm(np.cross(grid.axes[in_plane[0]], grid.axes[in_plane[1]])))
    round_sections: list[CrossSection] = []
    elongated: list[CrossSection] = []
    for k in range(grid.shape[axis]):
        blobs, count = ndimage.label(np.take(mask, k, axis=axis))
        for blob in range(1, count + 1):
            pixels = np.argwhere(blobs == blob)
            if len(pixels) * pixel_area < MIN_SECTION_AREA:
                continue
            index = np.insert(pixels.astype(np.float64), axis, k, axis=1)
            points = grid.to_world(index)
            spread = np.linalg.eigvalsh(np.cov(points.T) + 1e-18 * np.eye(3))[1:]
            section = CrossSection(
                k,
                points.mean(axis=0),
                len(pixels) * pixel_area,
                float(np.sqrt(spread[1] / spread[0])),
            )
            (round_sections if section.elongation <= MAX_ELONGATION else elongated).append(section)
    return round_sections, elongated


def vessel_track(mask: np.ndarray, grid: VolumeGrid, proximal: np.ndarray) -> VesselTrack:
    """The track of one class's voxel mask; `proximal` is the world proximal direction."""
    axis = slicing_axis(grid, proximal)
    direction = grid.directions[axis] * np.sign(grid.directions[axis] @ proximal)
    round_sections, elongated = cross_sections(mask, grid, axis)
    per_slice: dict[int, list[CrossSection]] = {}
    for section in round_sections + elongated:
        per_slice.setdefault(section.slice_index, []).append(section)
    branching = branching_slices(per_slice)
    stations = sorted(
        (found[0] for k, found in per_slice.items() if len(found) == 1 and k not in branching),
        key=lambda s: -float(s.centroid @ direction),
    )
    step = float(grid.spacing[axis])
    if len(stations) < MIN_STATIONS:
        empty = np.zeros((0, 3))
        return VesselTrack(direction, round_sections, empty, empty, *(np.zeros(0),) * 4)
    along = np.array([s.centroid @ direction for s in stations])
    centroids = np.array([s.centroid for s in stations])
    positions, tangents, curvature = smooth_course(centroids, along)
    slice_along = {k: per_slice[k][0].centroid @ direction for k in per_slice}
    branch_along = np.array([slice_along[k] for k in sorted(branching)])
    branch_distance = (
        np.abs(along[:, None] - branch_along[None]).min(axis=1)
        if len(branch_along)
        else np.full(len(along), np.inf)
    )
    extent = np.array(list(slice_along.values()))
    end_distance = np.minimum(along - extent.min(), extent.max() - along) + 0.5 * step
    radii = np.sqrt(np.array([s.area for s in stations]) / np.pi)
    return VesselTrack(
        direction,
        round_sections,
        positions,
        tangents,
        radii,
        curvature,
        branch_distance,
        end_distance,
    )


def branching_slices(per_slice: dict[int, list[CrossSection]]) -> set[int]:
    """Slices with an elongated blob, or whose blob count differs from a neighbour's (both
    holding blobs: a vessel running out of the mapped stretch is an end, not a branch)."""
    count = {k: len(found) for k, found in per_slice.items()}
    return {
        k
        for k, found in per_slice.items()
        if any(section.elongation > MAX_ELONGATION for section in found)
        or any(count.get(k + d, count[k]) != count[k] for d in (-1, 1))
    }


def smooth_course(
    centroids: np.ndarray, along: np.ndarray
) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """Smoothed positions, unit tangents (towards larger `along`) and curvature (1/m) of
    three or more centroids, given with their coordinates `along` the leg (m)."""
    order = np.argsort(along)
    s = along[order]
    step = float(np.median(np.diff(s))) if len(s) > 1 else 1.0
    sigma = SMOOTHING_LENGTH / step if step > 0 else 0.0
    smoothed = ndimage.gaussian_filter1d(centroids[order], sigma, axis=0, mode="nearest")
    first = np.gradient(smoothed, s, axis=0)
    second = np.gradient(first, s, axis=0)
    speed = np.linalg.norm(first, axis=1)
    tangent = first / speed[:, None]
    curvature = np.linalg.norm(np.cross(first, second), axis=1) / speed**3
    undo = np.argsort(order)
    return smoothed[undo], tangent[undo], curvature[undo]
