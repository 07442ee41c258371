"""A plain numpy squared-distance-weighted compounding, for checking and timing the kernel.

It computes the same formula as `reconstruct_kernels` in the most direct vectorised way (every
pixel against every voxel offset in its box, `np.add.at` to accumulate), with none of the
kernel's banding or incremental tricks, so tests can compare the two and the benchmark can
report the kernel's speed-up over it.
"""

from __future__ import annotations

from itertools import product

import numpy as np

from resus.reconstruction.grid import VolumeGrid


def sdw_accumulate_numpy(
    frame: np.ndarray,
    pose: np.ndarray,
    image_to_probe: np.ndarray,
    grid: VolumeGrid,
    radius: float,
    alpha: float,
    value: np.ndarray,
    weight: np.ndarray,
) -> None:
    """Add one frame's `W * I` to `value` and `W` to `weight`, W = 1/(d + alpha)^2, d <= radius
    (metres), over every pixel and every voxel centre."""
    height, width = frame.shape
    cols, rows = np.meshgrid(np.arange(width, dtype=float), np.arange(height, dtype=float))
    pixels = np.stack([cols.ravel(), rows.ravel(), np.zeros(cols.size), np.ones(cols.size)])
    u = (grid.world_to_voxel @ pose @ image_to_probe @ pixels)[:3].T
    intensity = frame.ravel().astype(np.float64)
    reach = np.ceil(grid.reach(radius)).astype(int)
    base = np.floor(u).astype(np.int64)
    shape = np.array(grid.shape)
    for offset in product(*(range(-r, r + 1) for r in reach)):
        index = base + np.array(offset)
        distance = np.linalg.norm((index - u) @ grid.axes, axis=1)
        inside = np.all((index >= 0) & (index < shape), axis=1) & (distance <= radius)
        w = 1.0 / (distance[inside] + alpha) ** 2
        flat = np.ravel_multi_index(index[inside].T, grid.shape)
        np.add.at(value.reshape(-1), flat, w * intensity[inside])
        np.add.at(weight.reshape(-1), flat, w)
