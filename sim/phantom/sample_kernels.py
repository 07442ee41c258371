"""Numba kernels behind `Phantom.labels` and `Phantom.sample`: one pass over the points."""

from __future__ import annotations

import numpy as np
from numba import njit, prange

from sim.phantom.body import depth_below_skin, inside_body
from sim.phantom.layer_waves import layer_at
from sim.phantom.tube_kernels import (
    INSIDE,
    OUTSIDE,
    locate_cell,
    nearest_in_grid,
    round_cone_distance,
    round_cone_normal,
    search_offset,
)


@njit(cache=True, inline="always")
def inside_label(px, py, pz, grid, segment_label):
    """Label of the tube of `grid` (a `tube_kernels.Grid`) containing the point, 0 if none."""
    c = locate_cell(px, py, pz, grid)
    if c < 0 or grid.state[c] == OUTSIDE:
        return 0
    first = grid.cell_start[c]
    if grid.state[c] == INSIDE:
        return segment_label[grid.items[first]]
    offset = search_offset(px, py, pz, c, grid)
    for m in range(first, grid.cell_start[c + 1]):
        if grid.dists[m] - offset >= 0.0:
            break
        s = grid.items[m]
        if round_cone_distance(px, py, pz, grid.segments[s]) < 0.0:
            return segment_label[s]
    return 0


@njit(cache=True, inline="always")
def may_be_inside(px, py, pz, grid):
    """False where the point's cell of `grid` lies wholly outside its tubes (or the point lies
    off the grid): one lookup that rules out every tube of the grid."""
    c = locate_cell(px, py, pz, grid)
    return c >= 0 and grid.state[c] != OUTSIDE


@njit(cache=True, parallel=True)
def label_points(points, body_kind, body_params, grid, segment_label, out):
    """Label (0 background, 1 artery, 2 vein) of each point; 0 outside the body."""
    for p in prange(points.shape[0]):
        x, y, z = points[p, 0], points[p, 1], points[p, 2]
        label = 0
        if inside_body(body_kind, body_params, x, y, z):
            label = inside_label(x, y, z, grid, segment_label)
        out[p] = label


@njit(cache=True, parallel=True)
def sample_points(
    points,
    body_kind,
    body_params,
    layer_bottoms,
    layer_waves,
    wave_taper,
    wave_reach,
    blood_index,
    vessels,
    segment_tube,
    segment_label,
    cutoff,
    structures,
    bone_index,
    bones,
    bone_mark,
    node_index,
    nodes,
    node_mark,
    hilum_index,
    hila,
    hilum_mark,
    muscle_index,
    muscles,
    muscle_mark,
    nerve_index,
    nerves,
    nerve_mark,
    fascicle_index,
    fascicles,
    fascicle_mark,
    label,
    material,
    depth,
    distance,
    normal,
    index,
):
    """Everything the ultrasound needs per point, written into the output arrays.

    `vessels` and the structures (`bones` ... `fascicles`) are `tube_kernels.Grid`s, the
    vessels' within `cutoff`; each structure's `*_mark` is 1 per segment; `structures` is the
    grid of all their tubes together, which tells at one lookup that most points lie in none.
    A point in a vessel's lumen is blood, else in bone bone, else in a lymph node node (or
    hilum, in its hilum), else in the nerve nerve (or fascicle, in one of its fascicles), else
    in a muscle belly muscle, else the layer at its depth, its boundaries moved by
    `layer_waves` (`layer_waves.layer_at`; a material index of -1 means none of that kind
    exists).
    """
    for p in prange(points.shape[0]):
        x, y, z = points[p, 0], points[p, 1], points[p, 2]
        depth[p] = depth_below_skin(body_kind, body_params, x, y, z)
        d, s = nearest_in_grid(x, y, z, vessels)
        if d < cutoff:
            distance[p] = d
            normal[p, 0], normal[p, 1], normal[p, 2] = round_cone_normal(
                x, y, z, vessels.segments[s]
            )
            index[p] = segment_tube[s]
        else:
            distance[p] = np.inf
            normal[p, 0], normal[p, 1], normal[p, 2] = 0.0, 0.0, 0.0
            index[p] = -1
        label[p] = 0
        material[p] = -1
        if inside_body(body_kind, body_params, x, y, z):
            if d < 0.0:
                label[p] = segment_label[s]
                material[p] = blood_index
            else:
                material[p] = layer_at(
                    depth[p], x, y, layer_bottoms, layer_waves, wave_taper, wave_reach
                )
                if not may_be_inside(x, y, z, structures):
                    continue  # in no structure: the layer's material stands
                if bone_index >= 0 and inside_label(x, y, z, bones, bone_mark) > 0:
                    material[p] = bone_index
                elif node_index >= 0 and inside_label(x, y, z, nodes, node_mark) > 0:
                    material[p] = node_index
                    if hilum_index >= 0 and inside_label(x, y, z, hila, hilum_mark) > 0:
                        material[p] = hilum_index
                elif nerve_index >= 0 and inside_label(x, y, z, nerves, nerve_mark) > 0:
                    material[p] = nerve_index
                    if fascicle_index >= 0 and inside_label(x, y, z, fascicles, fascicle_mark) > 0:
                        material[p] = fascicle_index
                elif muscle_index >= 0 and inside_label(x, y, z, muscles, muscle_mark) > 0:
                    material[p] = muscle_index
