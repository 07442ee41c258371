"""The RESUS paper's volume: a parallelepiped fitted to the sweep with RANSAC planes.

How the method is read here (Morales et al.; design.md stage 1):

1. Each frame is reduced to a 3 x 3 pixel image whose pixels are the real image's corner
   pixels, edge midpoints and centre (columns 0, (W-1)/2, W-1; rows 0, (H-1)/2, H-1), placed in
   the world with the frame's pose.
2. Side faces: the left column (col 0), right column (col W-1), top row (row 0, the transducer
   face) and bottom row (row H-1) of every frame form four point clouds; a plane is fitted to
   each with RANSAC (3-point hypotheses, inliers within a threshold, least-squares refit on the
   inliers of the best hypothesis).
3. Base faces: the 3 x 3 points of every frame moved by the rotation of its pose only (no
   translation) overlap in one "rotation-only" cloud around the origin; the normal of the
   plane RANSAC fits to it is the sweep's mean frame orientation, robust to outlier frames. The
   two base planes have that normal, oriented from the first frame to the last, and are placed
   at the start and end frames: just touching the start frame's points on the outside
   (minimum of normal . point) and the end frame's (maximum), so both frames lie inside.
4. The six planes are intersected three at a time (one of each pair) into eight corners. The
   origin is the corner nearest the start frame's top-left pixel; z runs from it to the corner
   nearest the end frame's top-left pixel (the edge that stays on the same side faces); x and y
   are the two other edges leaving the origin, ordered so that x, y, z is right-handed. When the
   fitted side planes are not exactly parallel the volume is the parallelepiped spanned by the
   three edges at the origin.
5. Volume coordinates are the unit cube scaled by the voxel counts: with `n` voxels along an
   edge, the corner voxels' centres sit on the edge's ends (step = edge / (n - 1)).

RANSAC draws from `numpy.random.default_rng(seed)`, so the same sweep always gives the same
grid.
"""

from __future__ import annotations

from itertools import product

import numpy as np

from resus.errors import ResusError
from resus.reconstruction.grid import VolumeGrid, frame_points_world

DEFAULT_RANSAC_ITERATIONS = 200
DEFAULT_INLIER_THRESHOLD = 0.5e-3  # metres


def three_by_three_pixels(height: int, width: int) -> np.ndarray:
    """Homogeneous pixels (9, 4) of the 3 x 3 subsampled frame, row-major (row, then col)."""
    cols = (0.0, (width - 1) / 2, width - 1.0)
    rows = (0.0, (height - 1) / 2, height - 1.0)
    return np.array([[c, r, 0.0, 1.0] for r in rows for c in cols])


def ransac_plane(
    points: np.ndarray,
    rng: np.random.Generator,
    iterations: int = DEFAULT_RANSAC_ITERATIONS,
    inlier_threshold: float = DEFAULT_INLIER_THRESHOLD,
) -> tuple[np.ndarray, float]:
    """Plane `normal . x = offset` (unit normal) fitted to points (P, 3) by RANSAC + refit."""
    points = np.asarray(points, dtype=np.float64)
    scale = np.ptp(points, axis=0).max()
    best_inliers: np.ndarray | None = None
    for _ in range(iterations):
        sample = points[rng.choice(len(points), size=3, replace=False)]
        normal = np.cross(sample[1] - sample[0], sample[2] - sample[0])
        norm = np.linalg.norm(normal)
        if norm <= 1e-12 * max(scale, 1e-12) ** 2:
            continue
        normal /= norm
        inliers = np.abs((points - sample[0]) @ normal) <= inlier_threshold
        if best_inliers is None or inliers.sum() > best_inliers.sum():
            best_inliers = inliers
    if best_inliers is None or best_inliers.sum() < 3:
        raise ResusError("cannot fit a plane to the sweep: its points are collinear")
    return _least_squares_plane(points[best_inliers])


def _least_squares_plane(points: np.ndarray) -> tuple[np.ndarray, float]:
    """Total-least-squares plane through points: normal = smallest singular vector."""
    centroid = points.mean(axis=0)
    _, singular, vt = np.linalg.svd(points - centroid)
    if singular[1] <= 1e-9 * max(singular[0], 1e-300):
        raise ResusError("cannot fit a plane to the sweep: its points are collinear")
    normal = vt[2]
    return normal, float(normal @ centroid)


def _intersect(planes: list[tuple[np.ndarray, float]]) -> np.ndarray:
    """The point common to three planes."""
    normals = np.array([p[0] for p in planes])
    offsets = np.array([p[1] for p in planes])
    if abs(np.linalg.det(normals)) < 1e-9:
        raise ResusError("RANSAC planes do not enclose a volume (two are parallel)")
    return np.linalg.solve(normals, offsets)


def ransac_grid(
    poses: np.ndarray,
    image_to_probe: np.ndarray,
    frame_shape: tuple[int, int],
    shape: tuple[int, int, int] | None = None,
    *,
    spacing: float | None = None,
    iterations: int = DEFAULT_RANSAC_ITERATIONS,
    inlier_threshold: float = DEFAULT_INLIER_THRESHOLD,
    seed: int = 0,
) -> VolumeGrid:
    """The paper's parallelepiped around a sweep (see the module docstring).

    Voxel counts are `shape` (nx, ny, nz), or else derived from `spacing` (metres) as
    `ceil(edge length / spacing) + 1` per edge.
    """
    poses = np.asarray(poses, dtype=np.float64)
    if poses.ndim != 3 or len(poses) < 2:
        raise ResusError("a RANSAC grid needs at least two frames")
    if (shape is None) == (spacing is None):
        raise ResusError("ransac_grid needs exactly one of shape (voxel counts) or spacing")
    rng = np.random.default_rng(seed)
    height, width = frame_shape
    grid_pixels = three_by_three_pixels(height, width).reshape(3, 3, 4)  # [row, col]
    points = frame_points_world(poses, image_to_probe, grid_pixels.reshape(9, 4)).reshape(
        len(poses), 3, 3, 3
    )
    side_clouds = {
        "left": points[:, :, 0],
        "right": points[:, :, 2],
        "top": points[:, 0, :],
        "bottom": points[:, 2, :],
    }
    sides = {
        name: ransac_plane(cloud.reshape(-1, 3), rng, iterations, inlier_threshold)
        for name, cloud in side_clouds.items()
    }
    rotation_only = np.einsum(
        "nij,pj->npi", poses[:, :3, :3], (image_to_probe @ grid_pixels.reshape(9, 4).T).T[:, :3]
    )
    normal, _ = ransac_plane(rotation_only.reshape(-1, 3), rng, iterations, inlier_threshold)
    start, end = points[0].reshape(9, 3), points[-1].reshape(9, 3)
    if normal @ (end.mean(axis=0) - start.mean(axis=0)) < 0:
        normal = -normal
    bases = {
        "start": (normal, float((start @ normal).min())),
        "end": (normal, float((end @ normal).max())),
    }
    if bases["end"][1] - bases["start"][1] <= 0:
        raise ResusError("the sweep does not advance along its mean frame normal")

    corners = {
        (lateral, axial, base): _intersect([sides[lateral], sides[axial], bases[base]])
        for lateral, axial, base in product(("left", "right"), ("top", "bottom"), ("start", "end"))
    }
    start_top_left, end_top_left = points[0, 0, 0], points[-1, 0, 0]
    origin_key = min(
        (k for k in corners if k[2] == "start"),
        key=lambda k: np.linalg.norm(corners[k] - start_top_left),
    )
    lateral, axial, _ = origin_key
    other_lateral = "right" if lateral == "left" else "left"
    other_axial = "bottom" if axial == "top" else "top"
    origin = corners[origin_key]
    z_edge = corners[(lateral, axial, "end")] - origin
    if np.linalg.norm(corners[(lateral, axial, "end")] - end_top_left) > np.linalg.norm(
        corners[origin_key] - end_top_left
    ):
        raise ResusError("the sweep's end frame is not beyond its start frame")
    lateral_edge = corners[(other_lateral, axial, "start")] - origin
    axial_edge = corners[(lateral, other_axial, "start")] - origin
    x_edge, y_edge = lateral_edge, axial_edge
    if np.linalg.det(np.array([x_edge, y_edge, z_edge])) < 0:
        x_edge, y_edge = axial_edge, lateral_edge
    edges = np.array([x_edge, y_edge, z_edge])
    if shape is None:
        if spacing is None or not spacing > 0:  # None was refused above, with shape None
            raise ResusError(f"ransac_grid spacing must be positive, got {spacing}")
        nx, ny, nz = (
            int(np.ceil(length / spacing)) + 1 for length in np.linalg.norm(edges, axis=1)
        )
        shape = (nx, ny, nz)
    counts = np.array(shape, dtype=np.int64)
    if counts.shape != (3,) or np.any(counts < 2):
        raise ResusError(f"RANSAC grid voxel counts must be three integers >= 2, got {shape}")
    return VolumeGrid(origin=origin, axes=edges / (counts - 1)[:, None], shape=tuple(counts))
