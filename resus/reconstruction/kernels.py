"""Numba kernels that insert one frame into the accumulators, and that fill holes.

Pixel insertion scatters each pixel into the voxels it reaches. To run in parallel without
two threads writing one voxel, the frame's rows are cut into bands of `band_rows` rows, so tall
that two pixels two bands apart are farther apart than twice the kernel's reach: all even bands
run in parallel, then all odd bands. Every voxel therefore receives its contributions in one
fixed order, whatever the thread count, so results are deterministic and a frame added live
gives exactly what batch reconstruction gives.

Accumulators (float32, indexed [i, j, k]): `value` holds the weighted sum of intensities (MEAN)
or the maximum (MAXIMUM); `weight` the sum of weights (zero means a hole); `label_weight[c-1]`
the sum of weights of pixels labelled c (labels are always a weighted vote).
"""

from __future__ import annotations

import math

import numpy as np
from numba import njit, prange

SDW, NEAREST, LINEAR = 0, 1, 2
MEAN, MAXIMUM = 0, 1
LINEAR_MAXIMUM_MIN_WEIGHT = 0.125  # PLUS: MAXIMUM considers only corners with weight >= 1/8


@njit(inline="always")
def _accumulate(value, weight, label_weight, i, j, k, w, intensity, label, compounding):
    if compounding == MEAN:
        value[i, j, k] += w * intensity
    elif intensity > value[i, j, k]:
        value[i, j, k] = intensity
    weight[i, j, k] += w
    if label > 0:
        label_weight[label - 1, i, j, k] += w


@njit(inline="always")
def _splat_sdw(
    u0, u1, u2, intensity, label, gram, reach, radius2, alpha, compounding,
    value, weight, label_weight,
):  # fmt: skip
    """Weight 1/(d + alpha)^2 to every voxel centre within the radius (d in metres)."""
    nx, ny, nz = value.shape
    i_lo, i_hi = max(0, math.ceil(u0 - reach[0])), min(nx - 1, math.floor(u0 + reach[0]))
    j_lo, j_hi = max(0, math.ceil(u1 - reach[1])), min(ny - 1, math.floor(u1 + reach[1]))
    k_lo, k_hi = max(0, math.ceil(u2 - reach[2])), min(nz - 1, math.floor(u2 + reach[2]))
    g00, g01, g02 = gram[0, 0], gram[0, 1], gram[0, 2]
    g11, g12, g22 = gram[1, 1], gram[1, 2], gram[2, 2]
    for i in range(i_lo, i_hi + 1):
        di = i - u0
        for j in range(j_lo, j_hi + 1):
            dj = j - u1
            base = g00 * di * di + 2.0 * g01 * di * dj + g11 * dj * dj
            cross = 2.0 * (g02 * di + g12 * dj)
            for k in range(k_lo, k_hi + 1):
                dk = k - u2
                d2 = base + (cross + g22 * dk) * dk
                if d2 <= radius2:
                    root = math.sqrt(max(d2, 0.0)) + alpha
                    _accumulate(
                        value, weight, label_weight, i, j, k, 1.0 / (root * root),
                        intensity, label, compounding,
                    )  # fmt: skip


@njit(inline="always")
def _splat_nearest(u0, u1, u2, intensity, label, compounding, value, weight, label_weight):
    """PLUS nearest-neighbour insertion: the pixel goes to the voxel whose centre is nearest."""
    nx, ny, nz = value.shape
    i, j, k = math.floor(u0 + 0.5), math.floor(u1 + 0.5), math.floor(u2 + 0.5)
    if 0 <= i < nx and 0 <= j < ny and 0 <= k < nz:
        _accumulate(value, weight, label_weight, i, j, k, 1.0, intensity, label, compounding)


@njit(inline="always")
def _splat_linear(u0, u1, u2, intensity, label, compounding, value, weight, label_weight):
    """PLUS trilinear insertion: split over the 8 surrounding voxels by trilinear weights.

    As in PLUS, a pixel is dropped unless all its neighbours are inside the grid, and MAXIMUM
    compounding only updates corners whose weight is at least 1/8.
    """
    nx, ny, nz = value.shape
    i0, j0, k0 = math.floor(u0), math.floor(u1), math.floor(u2)
    fx, fy, fz = u0 - i0, u1 - j0, u2 - k0
    i1, j1, k1 = i0 + (fx != 0.0), j0 + (fy != 0.0), k0 + (fz != 0.0)
    if i0 < 0 or j0 < 0 or k0 < 0 or i1 >= nx or j1 >= ny or k1 >= nz:
        return
    for corner in range(8):
        wi = fx if corner & 4 else 1.0 - fx
        wj = fy if corner & 2 else 1.0 - fy
        wk = fz if corner & 1 else 1.0 - fz
        w = wi * wj * wk
        if w == 0.0 or (compounding == MAXIMUM and w < LINEAR_MAXIMUM_MIN_WEIGHT):
            continue
        i = i1 if corner & 4 else i0
        j = j1 if corner & 2 else j0
        k = k1 if corner & 1 else k0
        _accumulate(value, weight, label_weight, i, j, k, w, intensity, label, compounding)


@njit(parallel=True, cache=True)
def insert_frame(
    frame, labels, image_to_voxel, gram, reach, radius2, alpha, method, compounding,
    band_rows, value, weight, label_weight,
):  # fmt: skip
    """Insert one frame (H, W) with labels (H, W; shape (0, 0) for none) into the accumulators.

    `image_to_voxel` (3, 4) maps `(col, row, 0, 1)` to continuous voxel indices.
    """
    height, width = frame.shape
    has_labels = labels.shape[0] == height
    n_bands = (height + band_rows - 1) // band_rows
    for colour in range(2):
        for half in prange((n_bands - colour + 1) // 2):
            first = (colour + 2 * half) * band_rows
            for row in range(first, min(height, first + band_rows)):
                for col in range(width):
                    u0 = (
                        image_to_voxel[0, 0] * col
                        + image_to_voxel[0, 1] * row
                        + image_to_voxel[0, 3]
                    )
                    u1 = (
                        image_to_voxel[1, 0] * col
                        + image_to_voxel[1, 1] * row
                        + image_to_voxel[1, 3]
                    )
                    u2 = (
                        image_to_voxel[2, 0] * col
                        + image_to_voxel[2, 1] * row
                        + image_to_voxel[2, 3]
                    )
                    intensity = np.float32(frame[row, col])
                    label = np.int64(labels[row, col]) if has_labels else 0
                    if method == SDW:
                        _splat_sdw(
                            u0, u1, u2, intensity, label, gram, reach, radius2, alpha,
                            compounding, value, weight, label_weight,
                        )  # fmt: skip
                    elif method == NEAREST:
                        _splat_nearest(
                            u0, u1, u2, intensity, label, compounding, value, weight, label_weight
                        )
                    else:
                        _splat_linear(
                            u0, u1, u2, intensity, label, compounding, value, weight, label_weight
                        )


@njit(parallel=True, cache=True)
def fill_holes_pass(channels, source, open_holes, gram, reach, radius2, alpha, newly_filled):
    """One hole-filling pass: each open hole takes the 1/(d + alpha)^2-weighted mean of the
    source voxels (those filled by pixels) within the radius; holes never feed holes.

    `channels` (C, nx, ny, nz) is read at source voxels and written at filled holes only, so the
    pass can run in place and in parallel. Sets `newly_filled` where a hole got a value.
    """
    n_channels, nx, ny, nz = channels.shape
    for i in prange(nx):
        total = np.zeros(n_channels, dtype=np.float64)
        i_lo, i_hi = max(0, math.ceil(i - reach[0])), min(nx - 1, math.floor(i + reach[0]))
        for j in range(ny):
            j_lo, j_hi = max(0, math.ceil(j - reach[1])), min(ny - 1, math.floor(j + reach[1]))
            for k in range(nz):
                if not open_holes[i, j, k]:
                    continue
                k_lo, k_hi = max(0, math.ceil(k - reach[2])), min(nz - 1, math.floor(k + reach[2]))
                total[:] = 0.0
                weight_sum = 0.0
                for ii in range(i_lo, i_hi + 1):
                    for jj in range(j_lo, j_hi + 1):
                        for kk in range(k_lo, k_hi + 1):
                            if not source[ii, jj, kk]:
                                continue
                            di, dj, dk = ii - i, jj - j, kk - k
                            d2 = (
                                gram[0, 0] * di * di + gram[1, 1] * dj * dj + gram[2, 2] * dk * dk
                                + 2.0 * (gram[0, 1] * di * dj + gram[0, 2] * di * dk
                                         + gram[1, 2] * dj * dk)
                            )  # fmt: skip
                            if d2 > radius2:
                                continue
                            root = math.sqrt(d2) + alpha
                            w = 1.0 / (root * root)
                            weight_sum += w
                            for c in range(n_channels):
                                total[c] += w * channels[c, ii, jj, kk]
                if weight_sum > 0.0:
                    for c in range(n_channels):
                        channels[c, i, j, k] = total[c] / weight_sum
                    newly_filled[i, j, k] = True
