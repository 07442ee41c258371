"""Exact distance from points to a triangle mesh, without a spatial-index library.

trimesh's own closest-point query needs `rtree`, which this project does not ship. Here a
KD-tree on the vertices gives an upper bound `u` on each point's distance (its nearest
vertex); any triangle holding a closer point has its centroid within `u + R` of the point,
`R` the largest centroid-to-corner distance of any triangle. Those candidates are then
measured exactly (closest point on a triangle, Ericson's "Real-Time Collision Detection"
5.1.5), so the answer is exact, not a sampling approximation.
"""

from __future__ import annotations

import numpy as np
import trimesh
from scipy.spatial import cKDTree

CHUNK = 4096
"""Points measured per batch, bounding the memory of the candidate lists."""


def closest_points_on_triangles(points: np.ndarray, triangles: np.ndarray) -> np.ndarray:
    """Closest point (K, 3) on each triangle (K, 3, 3) to the matching point (K, 3)."""
    a, b, c = triangles[:, 0], triangles[:, 1], triangles[:, 2]
    ab, ac, ap = b - a, c - a, points - a
    bp, cp = points - b, points - c

    def dot(u: np.ndarray, v: np.ndarray) -> np.ndarray:
        return np.einsum("ij,ij->i", u, v)

    d1, d2 = dot(ab, ap), dot(ac, ap)
    d3, d4 = dot(ab, bp), dot(ac, bp)
    d5, d6 = dot(ab, cp), dot(ac, cp)
    va = d3 * d6 - d5 * d4
    vb = d5 * d2 - d1 * d6
    vc = d1 * d4 - d3 * d2
    with np.errstate(divide="ignore", invalid="ignore"):
        denominator = va + vb + vc
        v_face = vb / denominator
        w_face = vc / denominator
        v_ab = d1 / (d1 - d3)
        w_ac = d2 / (d2 - d6)
        w_bc = (d4 - d3) / ((d4 - d3) + (d5 - d6))
    result = a + v_face[:, None] * ab + w_face[:, None] * ac  # inside the face
    # Voronoi regions from lowest to highest precedence (Ericson tests A, B, AB, C, AC, BC).
    on_bc = (va <= 0) & (d4 - d3 >= 0) & (d5 - d6 >= 0)
    result[on_bc] = (b + w_bc[:, None] * (c - b))[on_bc]
    on_ac = (vb <= 0) & (d2 >= 0) & (d6 <= 0)
    result[on_ac] = (a + w_ac[:, None] * ac)[on_ac]
    at_c = (d6 >= 0) & (d5 <= d6)
    result[at_c] = c[at_c]
    on_ab = (vc <= 0) & (d1 >= 0) & (d3 <= 0)
    result[on_ab] = (a + v_ab[:, None] * ab)[on_ab]
    at_b = (d3 >= 0) & (d4 <= d3)
    result[at_b] = b[at_b]
    at_a = (d1 <= 0) & (d2 <= 0)
    result[at_a] = a[at_a]
    return result


class MeshDistance:
    """Exact unsigned distance from points to one mesh's surface (index built once)."""

    def __init__(self, mesh: trimesh.Trimesh) -> None:
        if len(mesh.faces) == 0:
            raise ValueError("cannot measure distances to an empty mesh")
        self.triangles = np.asarray(mesh.triangles, dtype=np.float64)
        centroids = self.triangles.mean(axis=1)
        self.reach = float(np.linalg.norm(self.triangles - centroids[:, None], axis=2).max())
        edges = self.triangles - np.roll(self.triangles, 1, axis=1)
        self.longest_edge = float(np.linalg.norm(edges, axis=2).max())
        self._vertex_tree = cKDTree(np.asarray(mesh.vertices, dtype=np.float64))
        self._centroid_tree = cKDTree(centroids)

    def minimum(self, points: np.ndarray) -> float:
        """Smallest distance from any of (N, 3) points to the surface.

        A point's distance is at least its nearest-vertex distance minus the longest edge
        (the closest surface point lies on a triangle whose corners are that near), so only
        points whose bound is below the smallest nearest-vertex distance are measured exactly.
        """
        points = np.asarray(points, dtype=np.float64).reshape(-1, 3)
        bound, _ = self._vertex_tree.query(points)
        contenders = points[bound - self.longest_edge <= bound.min()]
        return float(self(contenders).min())

    def __call__(self, points: np.ndarray) -> np.ndarray:
        """Distance (N,) from each of (N, 3) points to the nearest point of the surface."""
        points = np.asarray(points, dtype=np.float64).reshape(-1, 3)
        distances = np.empty(len(points))
        for start in range(0, len(points), CHUNK):
            chunk = points[start : start + CHUNK]
            bound, _ = self._vertex_tree.query(chunk)
            candidates = self._centroid_tree.query_ball_point(chunk, bound + self.reach + 1e-12)
            owner = np.repeat(np.arange(len(chunk)), [len(c) for c in candidates])
            faces = np.concatenate([np.asarray(c, dtype=np.int64) for c in candidates])
            closest = closest_points_on_triangles(chunk[owner], self.triangles[faces])
            pair_distance = np.linalg.norm(chunk[owner] - closest, axis=1)
            best = np.full(len(chunk), np.inf)
            np.minimum.at(best, owner, pair_distance)
            distances[start : start + len(chunk)] = best
        return distances
