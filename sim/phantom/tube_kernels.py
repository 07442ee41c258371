"""Numba kernels: exact distance to round-cone segments and a uniform-grid index over them.

A segment row is `(ax, ay, az, bx, by, bz, ra, rb)`: the convex hull of the sphere of radius ra
at a and the sphere of radius rb at b. Its signed distance is exact (Inigo Quilez's round cone);
a union's distance is the minimum over its segments (exact outside; inside, minus the depth in
the deepest segment).

The grid stores, per cell, the segments that can be the nearest one for some point of the
cell and closer than `cutoff`: segment s is kept iff d_s(c) - h <= min(U(c), cutoff), with c the
cell centre, h its half-diagonal and U(c) = min_s d_s(c) + h an upper bound of the distance
inside the cell (distances are 1-Lipschitz). Candidates are sorted by d_s(c), so a query stops
at the first one with d_s(c) - |p - c| >= best. A cell's state tells whether it lies wholly
inside the union (U < 0), wholly outside (min d_s(c) - h > 0), or across its surface.
"""

from __future__ import annotations

import math
from typing import NamedTuple

import numpy as np
from numba import njit, prange

OUTSIDE, INSIDE, SURFACE = 0, 1, 2
STOP_SLACK = 1.0e-6
"""Margin on the early stop, covering the float32 rounding of stored centre distances (m)."""


PACKED_WIDTH = 18
"""Packed segment row: a(3), b - a(3), ra, rb, |b-a|^2, 1/|b-a|^2, ra - rb, |b-a|^2 - (ra-rb)^2,
max(ra, rb), |b-a|, unit axis u(3), sin of the side's tilt (ra - rb) / |b-a|."""


class Grid(NamedTuple):
    """A built grid as the query kernels take it: packed segments and their candidate lists.

    The per-point kernels taking a Grid are inlined into their callers (`inline="always"`):
    passing the tuple through a compiled call at every point was measured 15-20 % slower.
    """

    segments: np.ndarray
    """Packed segment rows (`pack_segments`)."""
    origin: np.ndarray
    """(3,) corner of the grid (m)."""
    cell_size: float
    shape: np.ndarray
    """(3,) int64 cells along x, y, z."""
    cell_start: np.ndarray
    """(cells + 1,) where each cell's candidates start in `items` and `dists`."""
    items: np.ndarray
    """Candidate segments, per cell, nearest to the cell centre first."""
    dists: np.ndarray
    """float32 distance of each candidate from its cell centre."""
    state: np.ndarray
    """Per cell: INSIDE, OUTSIDE or SURFACE of the union."""


def pack_segments(segments: np.ndarray) -> np.ndarray:
    """Rows `(ax, ay, az, bx, by, bz, ra, rb)` to packed rows with the constants kernels reuse."""
    a, b, ra, rb = segments[:, 0:3], segments[:, 3:6], segments[:, 6], segments[:, 7]
    ba = b - a
    l2 = (ba * ba).sum(axis=1)
    if len(segments) and not (np.sqrt(l2) > np.abs(ra - rb)).all():
        raise ValueError("a tube's radius changes faster than its centreline advances")
    columns = [a, ba, ra, rb, l2, 1.0 / np.maximum(l2, 1e-300), ra - rb, l2 - (ra - rb) ** 2]
    length = np.sqrt(l2)
    columns += [np.maximum(ra, rb), length, ba / np.maximum(length, 1e-300)[:, None]]
    return np.ascontiguousarray(np.column_stack([*columns, (ra - rb) / np.maximum(length, 1e-300)]))


@njit(cache=True)
def round_cone_distance(px, py, pz, seg):
    """Signed distance from a point to one packed round cone (negative inside)."""
    bax, bay, baz = seg[3], seg[4], seg[5]
    ra, rb, l2, il2, rr, a2 = seg[6], seg[7], seg[8], seg[9], seg[10], seg[11]
    pax, pay, paz = px - seg[0], py - seg[1], pz - seg[2]
    y = pax * bax + pay * bay + paz * baz
    z = y - l2
    qx, qy, qz = pax * l2 - bax * y, pay * l2 - bay * y, paz * l2 - baz * y
    x2 = qx * qx + qy * qy + qz * qz
    y2 = y * y * l2
    z2 = z * z * l2
    k = math.copysign(rr * rr * x2, rr) if rr != 0.0 else 0.0
    if math.copysign(a2 * z2, z) > k:
        return math.sqrt(x2 + z2) * il2 - rb
    if math.copysign(a2 * y2, y) < k:
        return math.sqrt(x2 + y2) * il2 - ra
    return (math.sqrt(x2 * a2 * il2) + y * rr) * il2 - ra


@njit(cache=True)
def outside_bound(px, py, pz, seg, best):
    """True if the capsule around the cone (radius max(ra, rb)) shows it is no closer than best."""
    reach = best + seg[12]
    if reach <= 0.0:
        return True
    pax, pay, paz = px - seg[0], py - seg[1], pz - seg[2]
    t = min(1.0, max(0.0, (pax * seg[3] + pay * seg[4] + paz * seg[5]) * seg[9]))
    dx, dy, dz = pax - t * seg[3], pay - t * seg[4], paz - t * seg[5]
    return dx * dx + dy * dy + dz * dz >= reach * reach


@njit(cache=True)
def round_cone_normal(px, py, pz, seg):
    """Outward unit normal of the round cone's surface nearest to a point (its gradient)."""
    ax, ay, az, length = seg[0], seg[1], seg[2], seg[13]
    ux, uy, uz, sin_tilt = seg[14], seg[15], seg[16], seg[17]
    cos_tilt = math.sqrt(max(0.0, 1.0 - sin_tilt * sin_tilt))
    pax, pay, paz = px - ax, py - ay, pz - az
    along = pax * ux + pay * uy + paz * uz
    rx, ry, rz = pax - along * ux, pay - along * uy, paz - along * uz
    radial = math.sqrt(rx * rx + ry * ry + rz * rz)
    if radial > 0.0:
        rx, ry, rz = rx / radial, ry / radial, rz / radial
    else:  # on the axis: any direction across it
        rx, ry, rz = (-uy, ux, 0.0) if abs(uz) < 0.9 else (0.0, -uz, uy)
        norm = math.sqrt(rx * rx + ry * ry + rz * rz)
        rx, ry, rz = rx / norm, ry / norm, rz / norm
    # The side touches the end spheres where the normal's axial part is sin_tilt: beyond those
    # tangency circles the nearest surface is a sphere, and the normal points from its centre.
    axial_a = along * cos_tilt - radial * sin_tilt
    axial_b = (along - length) * cos_tilt - radial * sin_tilt
    if axial_b > 0.0 or axial_a < 0.0:
        along_centre = length if axial_b > 0.0 else 0.0
        dx, dy, dz = pax - along_centre * ux, pay - along_centre * uy, paz - along_centre * uz
        norm = math.sqrt(dx * dx + dy * dy + dz * dz)
        if norm > 0.0:
            return dx / norm, dy / norm, dz / norm
    return (
        cos_tilt * rx + sin_tilt * ux,
        cos_tilt * ry + sin_tilt * uy,
        cos_tilt * rz + sin_tilt * uz,
    )


@njit(cache=True)
def _cell_range(lo, hi, origin, cell_size, count):
    first = max(0, math.ceil((lo - origin) / cell_size - 0.5))
    last = min(count - 1, math.floor((hi - origin) / cell_size - 0.5))
    return first, last


@njit(cache=True)
def _visit_cells(segments, origin, cell_size, shape, reach, threshold, mode, counts, items, dists):
    """For each segment, each cell centre within `reach` of its box: update the cell.

    mode 0: `threshold[c] = min(threshold[c], d)`; mode 1: count candidates (d <= threshold[c]);
    mode 2: write them at `counts[c]` (the running fill position).
    """
    nx, ny, nz = shape[0], shape[1], shape[2]
    for s in range(segments.shape[0]):
        seg = segments[s]
        lo = np.empty(3)
        hi = np.empty(3)
        for axis in range(3):
            lo[axis] = seg[axis] + min(0.0, seg[3 + axis]) - seg[12] - reach
            hi[axis] = seg[axis] + max(0.0, seg[3 + axis]) + seg[12] + reach
        i0, i1 = _cell_range(lo[0], hi[0], origin[0], cell_size, nx)
        j0, j1 = _cell_range(lo[1], hi[1], origin[1], cell_size, ny)
        k0, k1 = _cell_range(lo[2], hi[2], origin[2], cell_size, nz)
        for i in range(i0, i1 + 1):
            cx = origin[0] + (i + 0.5) * cell_size
            for j in range(j0, j1 + 1):
                cy = origin[1] + (j + 0.5) * cell_size
                for k in range(k0, k1 + 1):
                    cz = origin[2] + (k + 0.5) * cell_size
                    d = round_cone_distance(cx, cy, cz, seg)
                    c = (i * ny + j) * nz + k
                    if mode == 0:
                        threshold[c] = min(threshold[c], d)
                    elif d <= threshold[c]:
                        if mode == 1:
                            counts[c] += 1
                        else:
                            items[counts[c]] = s
                            dists[counts[c]] = d
                            counts[c] += 1


@njit(cache=True)
def build_grid(segments, origin, cell_size, shape, cutoff):
    """Candidate lists per cell: (cell_start, items, item_distance, cell_state)."""
    ncell = shape[0] * shape[1] * shape[2]
    half_diagonal = 0.5 * math.sqrt(3.0) * cell_size
    reach = cutoff + 2.0 * half_diagonal
    nearest = np.full(ncell, np.inf)
    unused_i = np.zeros(1, np.int32)
    unused_f = np.zeros(1, np.float32)
    no_counts = np.zeros(1, np.int64)
    _visit_cells(
        segments, origin, cell_size, shape, reach, nearest, 0, no_counts, unused_i, unused_f
    )
    threshold = np.empty(ncell)
    state = np.empty(ncell, np.uint8)
    for c in range(ncell):
        threshold[c] = min(nearest[c] + half_diagonal, cutoff) + half_diagonal
        if nearest[c] + half_diagonal < 0.0:
            state[c] = INSIDE
        elif nearest[c] - half_diagonal > 0.0:
            state[c] = OUTSIDE
        else:
            state[c] = SURFACE
    counts = np.zeros(ncell, np.int64)
    _visit_cells(
        segments, origin, cell_size, shape, reach, threshold, 1, counts, unused_i, unused_f
    )
    cell_start = np.zeros(ncell + 1, np.int64)
    for c in range(ncell):
        cell_start[c + 1] = cell_start[c] + counts[c]
    items = np.empty(cell_start[ncell], np.int32)
    dists = np.empty(cell_start[ncell], np.float32)
    fill = cell_start[:ncell].copy()
    _visit_cells(segments, origin, cell_size, shape, reach, threshold, 2, fill, items, dists)
    for c in range(ncell):  # insertion sort: lists are short
        for m in range(cell_start[c] + 1, cell_start[c + 1]):
            d, s = dists[m], items[m]
            n = m - 1
            while n >= cell_start[c] and dists[n] > d:
                dists[n + 1], items[n + 1] = dists[n], items[n]
                n -= 1
            dists[n + 1], items[n + 1] = d, s
    return cell_start, items, dists, state


@njit(cache=True, inline="always")
def locate_cell(px, py, pz, grid):
    """Flat index of the grid cell holding a point, or -1 outside the grid."""
    origin, cell_size, shape = grid.origin, grid.cell_size, grid.shape
    fx = (px - origin[0]) / cell_size
    fy = (py - origin[1]) / cell_size
    fz = (pz - origin[2]) / cell_size
    if not (0.0 <= fx < shape[0] and 0.0 <= fy < shape[1] and 0.0 <= fz < shape[2]):
        return -1
    return (int(fx) * shape[1] + int(fy)) * shape[2] + int(fz)


@njit(cache=True, inline="always")
def search_offset(px, py, pz, c, grid):
    """How far the point lies from the centre of its cell c, plus STOP_SLACK: a candidate whose
    distance from the centre exceeds the best found by more than this cannot be nearer."""
    origin, cell_size, shape = grid.origin, grid.cell_size, grid.shape
    k = c % shape[2]
    j = (c // shape[2]) % shape[1]
    i = c // (shape[2] * shape[1])
    dx = px - (origin[0] + (i + 0.5) * cell_size)
    dy = py - (origin[1] + (j + 0.5) * cell_size)
    dz = pz - (origin[2] + (k + 0.5) * cell_size)
    return math.sqrt(dx * dx + dy * dy + dz * dz) + STOP_SLACK


@njit(cache=True, inline="always")
def nearest_in_grid(px, py, pz, grid):
    """(distance, segment) of the point's nearest candidate; (inf, -1) if its cell has none or
    it lies outside the grid."""
    best, best_segment = np.inf, -1
    c = locate_cell(px, py, pz, grid)
    if c < 0:
        return best, best_segment
    first, last = grid.cell_start[c], grid.cell_start[c + 1]
    if first == last:
        return best, best_segment
    offset = search_offset(px, py, pz, c, grid)
    segments = grid.segments
    for m in range(first, last):
        if grid.dists[m] - offset >= best:
            break
        s = grid.items[m]
        if outside_bound(px, py, pz, segments[s], best):
            continue
        d = round_cone_distance(px, py, pz, segments[s])
        if d < best:
            best, best_segment = d, s
    return best, best_segment


@njit(cache=True, parallel=True)
def nearest_segments(points, grid, cutoff):
    """Per point: distance to the nearest segment and its index, (inf, -1) beyond `cutoff`."""
    n = points.shape[0]
    distance = np.full(n, np.inf)
    segment = np.full(n, -1, np.int64)
    for p in prange(n):
        d, s = nearest_in_grid(points[p, 0], points[p, 1], points[p, 2], grid)
        if d < cutoff:
            distance[p], segment[p] = d, s
    return distance, segment


@njit(cache=True, parallel=True)
def brute_force_distance(points, segments):
    """Per point: distance to the union of all segments (for points the grid does not cover)."""
    distance = np.full(points.shape[0], np.inf)
    for p in prange(points.shape[0]):
        best = np.inf
        for s in range(segments.shape[0]):
            best = min(
                best, round_cone_distance(points[p, 0], points[p, 1], points[p, 2], segments[s])
            )
        distance[p] = best
    return distance


@njit(cache=True, parallel=True)
def distance_volume(origin, spacing, shape, grid, cutoff):
    """Distance sampled on a regular lattice (float32), clamped to `cutoff` far from the tubes."""
    volume = np.full((shape[0], shape[1], shape[2]), np.float32(cutoff))
    for i in prange(shape[0]):
        x = origin[0] + i * spacing
        for j in range(shape[1]):
            y = origin[1] + j * spacing
            for k in range(shape[2]):
                z = origin[2] + k * spacing
                d, _ = nearest_in_grid(x, y, z, grid)
                volume[i, j, k] = min(d, cutoff)
    return volume
