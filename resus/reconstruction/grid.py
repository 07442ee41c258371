"""The voxel grid a sweep is reconstructed onto: an origin and three step vectors.

One type serves both volume definitions (the axis-aligned box and the paper's RANSAC
parallelepiped): voxel `(i, j, k)` has its centre at `origin + i*axes[0] + j*axes[1] +
k*axes[2]` (metres). Voxel centres sit on integer indices, as in VTK, ITK and PLUS: the origin
is the centre of voxel (0, 0, 0), not its corner. The step vectors may be non-orthogonal.
Arrays on a grid are indexed `[i, j, k]`, shape `(nx, ny, nz)`.
"""

from __future__ import annotations

import math
import os
from dataclasses import dataclass
from itertools import product

import numpy as np

from resus.errors import ResusError

FILE_POSITION_TOLERANCE = 1e-6
"""Metres: volume files round positions, so grids this close put their voxels alike."""


@dataclass(frozen=True)
class VolumeGrid:
    """A parallelepiped of voxels: origin (3,), axes (3, 3) step vectors (rows), shape (3,)."""

    origin: np.ndarray
    axes: np.ndarray
    shape: tuple[int, int, int]

    def __post_init__(self) -> None:
        origin = np.asarray(self.origin, dtype=np.float64).reshape(3)
        axes = np.asarray(self.axes, dtype=np.float64).reshape(3, 3)
        shape = tuple(int(n) for n in self.shape)
        if len(shape) != 3 or min(shape) < 1:
            raise ResusError(f"grid shape must be three positive voxel counts, got {self.shape}")
        if not (np.isfinite(origin).all() and np.isfinite(axes).all()):
            raise ResusError("grid origin and axes must be finite")
        if abs(np.linalg.det(axes)) <= 1e-12 * np.prod(np.linalg.norm(axes, axis=1)):
            raise ResusError("grid axes are degenerate (coplanar step vectors)")
        object.__setattr__(self, "origin", origin)
        object.__setattr__(self, "axes", axes)
        object.__setattr__(self, "shape", shape)

    @property
    def spacing(self) -> np.ndarray:
        """Voxel size along each axis (m): the lengths of the step vectors."""
        return np.linalg.norm(self.axes, axis=1)

    @property
    def directions(self) -> np.ndarray:
        """Unit vectors of the three axes (rows)."""
        return self.axes / self.spacing[:, None]

    @property
    def n_voxels(self) -> int:
        """Number of voxels."""
        return math.prod(self.shape)

    @property
    def gram(self) -> np.ndarray:
        """Metric of index space: a voxel offset `delta` is `sqrt(delta @ gram @ delta)` metres."""
        return self.axes @ self.axes.T

    @property
    def voxel_to_world(self) -> np.ndarray:
        """4x4 matrix taking homogeneous voxel indices `(i, j, k, 1)` to world metres."""
        matrix = np.eye(4)
        matrix[:3, :3] = self.axes.T
        matrix[:3, 3] = self.origin
        return matrix

    @property
    def world_to_voxel(self) -> np.ndarray:
        """4x4 matrix taking world points (metres) to continuous voxel indices."""
        return np.linalg.inv(self.voxel_to_world)

    def to_world(self, indices: np.ndarray) -> np.ndarray:
        """World positions (..., 3) of continuous voxel indices (..., 3)."""
        return np.asarray(indices, dtype=np.float64) @ self.axes + self.origin

    def to_voxel(self, points: np.ndarray) -> np.ndarray:
        """Continuous voxel indices (..., 3) of world points (..., 3)."""
        return (np.asarray(points, dtype=np.float64) - self.origin) @ np.linalg.inv(self.axes)

    def corners(self) -> np.ndarray:
        """World positions (8, 3) of the centres of the eight corner voxels."""
        last = np.array(self.shape) - 1
        return self.to_world(np.array(list(product(*[(0, n) for n in last])), dtype=float))

    def reach(self, radius: float) -> np.ndarray:
        """Half-width in voxel indices, per axis, of a world ball of `radius` metres."""
        return radius * np.sqrt(np.diag(np.linalg.inv(self.gram)))

    def bytes_needed(self, bytes_per_voxel: int) -> int:
        """Memory for arrays totalling `bytes_per_voxel` bytes on each voxel."""
        return self.n_voxels * bytes_per_voxel

    def places_like(self, other: VolumeGrid, tolerance: float = FILE_POSITION_TOLERANCE) -> bool:
        """Whether `other` puts its voxels where this grid does: origins and axes equal to
        `tolerance` metres (`numpy.allclose`), the shapes aside."""
        return bool(
            np.allclose(self.origin, other.origin, atol=tolerance)
            and np.allclose(self.axes, other.axes, atol=tolerance)
        )

    def describe(self) -> str:
        """One line: shape, spacing in mm, origin in mm."""
        spacing = ", ".join(f"{s * 1e3:.4g}" for s in self.spacing)
        origin = ", ".join(f"{o * 1e3:.6g}" for o in self.origin)
        size = " x ".join(str(n) for n in self.shape)
        return f"{size} voxels, spacing ({spacing}) mm, origin ({origin}) mm"


def available_memory() -> int:
    """Bytes of memory the machine can still give (MemAvailable, else free physical pages)."""
    try:
        with open("/proc/meminfo", encoding="ascii") as meminfo:
            for line in meminfo:
                if line.startswith("MemAvailable:"):
                    return int(line.split()[1]) * 1024
    except OSError:
        pass
    return os.sysconf("SC_AVPHYS_PAGES") * os.sysconf("SC_PAGE_SIZE")


def ensure_memory(grid: VolumeGrid, bytes_per_voxel: int, what: str = "reconstruction") -> None:
    """Refuse up front (ResusError) a grid whose arrays would not fit in available memory."""
    needed = grid.bytes_needed(bytes_per_voxel)
    available = available_memory()
    if needed > available:
        raise ResusError(
            f"{what} needs {needed / 2**30:.1f} GiB for {grid.shape[0]} x {grid.shape[1]} x "
            f"{grid.shape[2]} voxels but only {available / 2**30:.1f} GiB is available: "
            "use a coarser spacing or fewer voxels"
        )


def frame_corner_pixels(height: int, width: int) -> np.ndarray:
    """Homogeneous pixel coordinates (4, 4) of the four corner pixel centres, as PLUS uses."""
    cols, rows = (0.0, width - 1.0), (0.0, height - 1.0)
    return np.array([[c, r, 0.0, 1.0] for c in cols for r in rows])


def frame_points_world(
    poses: np.ndarray, image_to_probe: np.ndarray, pixels: np.ndarray
) -> np.ndarray:
    """World positions (N, P, 3) of homogeneous pixels (P, 4) in every frame (N poses)."""
    image_to_world = np.asarray(poses, dtype=np.float64) @ np.asarray(image_to_probe)
    return np.einsum("nij,pj->npi", image_to_world, pixels)[..., :3]


def aabb_grid(
    spacing: float,
    *,
    poses: np.ndarray | None = None,
    image_to_probe: np.ndarray | None = None,
    frame_shape: tuple[int, int] | None = None,
    bounds: tuple[np.ndarray, np.ndarray] | None = None,
) -> VolumeGrid:
    """Axis-aligned grid with cubic voxels of `spacing` metres, as PLUS defines its output.

    The box is either given (`bounds` = (min corner, max corner), metres) or the bounding box
    of every frame's four corner pixel centres in the world. Like PLUS, the origin is the min
    corner and each axis holds `round((max - min) / spacing) + 1` voxels (PLUS's reference
    volumes for the spine-phantom sweep have exactly these counts).
    """
    if not spacing > 0:
        raise ResusError(f"aabb_grid spacing must be positive, got {spacing}")
    if bounds is None:
        if poses is None or image_to_probe is None or frame_shape is None:
            raise ResusError("aabb_grid needs either bounds or poses, image_to_probe, frame_shape")
        corners = frame_points_world(poses, image_to_probe, frame_corner_pixels(*frame_shape))
        low, high = corners.reshape(-1, 3).min(axis=0), corners.reshape(-1, 3).max(axis=0)
    else:
        low, high = (np.asarray(b, dtype=np.float64).reshape(3) for b in bounds)
        if np.any(high < low):
            raise ResusError(f"grid bounds have max < min: {low} .. {high}")
    counts = np.round((high - low) / spacing).astype(np.int64) + 1
    return VolumeGrid(origin=low, axes=np.eye(3) * spacing, shape=tuple(counts))
