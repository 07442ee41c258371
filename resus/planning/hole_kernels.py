"""Numba kernels that rasterise image rectangles into a voxel grid (see `holes`)."""

from __future__ import annotations

import math

import numpy as np
from numba import njit


@njit(cache=True)
def _local(pose_inverse: np.ndarray, point: np.ndarray) -> np.ndarray:
    out = np.empty(3)
    for a in range(3):
        out[a] = (
            pose_inverse[a, 0] * point[0]
            + pose_inverse[a, 1] * point[1]
            + pose_inverse[a, 2] * point[2]
            + pose_inverse[a, 3]
        )
    return out


@njit(cache=True)
def _box(corners: np.ndarray, to_voxel: np.ndarray, pad: np.ndarray, shape) -> np.ndarray:
    """Inclusive voxel index ranges (3, 2) that hold `corners` (K, 3) padded by `pad`."""
    box = np.empty((3, 2), dtype=np.int64)
    for a in range(3):
        low, high = np.inf, -np.inf
        for k in range(corners.shape[0]):
            value = (
                to_voxel[a, 0] * corners[k, 0]
                + to_voxel[a, 1] * corners[k, 1]
                + to_voxel[a, 2] * corners[k, 2]
                + to_voxel[a, 3]
            )
            low, high = min(low, value), max(high, value)
        box[a, 0] = max(0, math.floor(low - pad[a]))
        box[a, 1] = min(shape[a] - 1, math.ceil(high + pad[a]))
    return box


@njit(cache=True)
def mark_observed(
    origin, axes, to_voxel, pose_inverses, corners, half_width, top, bottom, radius, pad, observed
) -> None:
    """Set `observed` where a voxel centre lies within `radius` of a frame's rectangle
    (|x| <= half_width, top <= z <= bottom in the probe frame)."""
    shape = observed.shape
    point = np.empty(3)
    for n in range(pose_inverses.shape[0]):
        box = _box(corners[n], to_voxel, pad, shape)
        for i in range(box[0, 0], box[0, 1] + 1):
            for j in range(box[1, 0], box[1, 1] + 1):
                for k in range(box[2, 0], box[2, 1] + 1):
                    if observed[i, j, k]:
                        continue
                    for a in range(3):
                        point[a] = origin[a] + i * axes[0, a] + j * axes[1, a] + k * axes[2, a]
                    local = _local(pose_inverses[n], point)
                    dx = local[0] - min(max(local[0], -half_width), half_width)
                    dz = local[2] - min(max(local[2], top), bottom)
                    if dx * dx + local[1] * local[1] + dz * dz <= radius * radius:
                        observed[i, j, k] = 1


@njit(cache=True)
def mark_swept(
    origin, axes, to_voxel, pose_inverses, corners, pairs, half_width, top, bottom, observed,
    swept, pair_holes, pair_voxels,
) -> None:  # fmt: skip
    """Set `swept` on voxels between the rectangles of frames pairs[p] and pairs[p] + 1 (on
    opposite sides of the two planes, inside the rectangle interpolated between them), and
    count per pair those voxels and the unobserved ones among them."""
    shape = swept.shape
    point = np.empty(3)
    both = np.empty((8, 3))
    no_pad = np.zeros(3)
    for p in range(pairs.shape[0]):
        n = pairs[p]
        both[:4] = corners[n]
        both[4:] = corners[n + 1]
        box = _box(both, to_voxel, no_pad, shape)
        for i in range(box[0, 0], box[0, 1] + 1):
            for j in range(box[1, 0], box[1, 1] + 1):
                for k in range(box[2, 0], box[2, 1] + 1):
                    for a in range(3):
                        point[a] = origin[a] + i * axes[0, a] + j * axes[1, a] + k * axes[2, a]
                    first = _local(pose_inverses[n], point)
                    second = _local(pose_inverses[n + 1], point)
                    if first[1] * second[1] > 0:
                        continue
                    gap = first[1] - second[1]
                    t = 0.5 if gap == 0 else first[1] / gap
                    x = (1 - t) * first[0] + t * second[0]
                    z = (1 - t) * first[2] + t * second[2]
                    if abs(x) > half_width or z < top or z > bottom:
                        continue
                    swept[i, j, k] = 1
                    pair_voxels[p] += 1
                    if not observed[i, j, k]:
                        pair_holes[p] += 1
