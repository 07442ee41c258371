"""Watertight surface meshes: tubes by marching cubes on their exact distance, body primitives."""

from __future__ import annotations

import math

import numpy as np
import trimesh
from skimage.measure import marching_cubes

from sim.phantom.spec import BodySpec
from sim.phantom.tube_index import TubeIndex

PADDING_CELLS = 2
MIN_LEVEL_OFFSET = 1.0e-3
"""Lattice values are kept at least this fraction of a cell away from the surface level, so no
two marching-cubes vertices come closer than mesh tools' merge tolerance (it moves the surface
by at most that fraction of a cell)."""


def tube_mesh(index: TubeIndex, resolution: float) -> trimesh.Trimesh:
    """Marching cubes on the exact signed distance of the indexed tubes, `resolution` apart."""
    if index.cutoff <= 2 * resolution:
        raise ValueError(f"resolution {resolution} is too coarse for the index cutoff")
    seg = index.chain.segments
    lo = np.minimum(seg[:, 0:3] - seg[:, 6:7], seg[:, 3:6] - seg[:, 7:8]).min(axis=0)
    hi = np.maximum(seg[:, 0:3] + seg[:, 6:7], seg[:, 3:6] + seg[:, 7:8]).max(axis=0)
    origin = lo - PADDING_CELLS * resolution
    shape = tuple(np.ceil((hi - origin) / resolution).astype(int) + PADDING_CELLS + 1)
    volume = index.distance_volume(origin, resolution, shape)
    offset = np.float32(MIN_LEVEL_OFFSET * resolution)
    volume = np.where(volume < 0, np.minimum(volume, -offset), np.maximum(volume, offset))
    vertices, faces, _, _ = marching_cubes(volume, level=0.0, spacing=(resolution,) * 3)
    mesh = trimesh.Trimesh(vertices + origin, faces, process=False)
    if mesh.volume < 0:
        mesh.invert()
    return mesh


def body_mesh(body: BodySpec, resolution: float) -> trimesh.Trimesh:
    """The block as a box, or the leg as a cylinder whose facets stray < `resolution`."""
    if body.kind == "block":
        mesh = trimesh.creation.box(extents=body.size)
        mesh.apply_translation((0.0, 0.0, -body.size[2] / 2))
        return mesh
    sagitta_angle = math.acos(max(-1.0, 1.0 - resolution / body.radius))
    sections = max(16, math.ceil(math.pi / sagitta_angle))
    mesh = trimesh.creation.cylinder(radius=body.radius, height=body.length, sections=sections)
    # Turn a rim vertex (local +x) to local -y, then the axis z to y: that vertex is the top line.
    mesh.apply_transform(trimesh.transformations.rotation_matrix(-math.pi / 2, (0.0, 0.0, 1.0)))
    mesh.apply_transform(trimesh.transformations.rotation_matrix(-math.pi / 2, (1.0, 0.0, 0.0)))
    mesh.apply_translation((0.0, 0.0, -body.radius))
    return mesh
