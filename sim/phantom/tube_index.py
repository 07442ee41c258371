"""A spatial index over a chain of round-cone segments: exact nearest-surface queries, fast.

See `tube_kernels` for how the grid is built and searched. The grid covers the segments'
bounding box grown by `cutoff`, so a point outside it is farther than `cutoff` from every tube.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from sim.phantom import tube_kernels
from sim.phantom.centreline import SegmentChain

DEFAULT_CELL_SIZE = 1.0e-3


@dataclass(frozen=True, eq=False)
class TubeIndex:
    """Candidate lists per grid cell for the segments of `chain`."""

    chain: SegmentChain
    packed: np.ndarray
    """The chain's segments packed for the kernels (`tube_kernels.pack_segments`)."""
    cutoff: float
    cell_size: float
    origin: np.ndarray
    shape: np.ndarray
    cell_start: np.ndarray
    items: np.ndarray
    item_distance: np.ndarray
    cell_state: np.ndarray

    @classmethod
    def build(
        cls, chain: SegmentChain, cutoff: float, cell_size: float = DEFAULT_CELL_SIZE
    ) -> TubeIndex:
        """Index `chain` for queries that need the nearest surface within `cutoff`."""
        if not cell_size > 0 or not cutoff >= 0:
            raise ValueError(
                f"cell_size must be positive and cutoff >= 0, got {cell_size}, {cutoff}"
            )
        seg = chain.segments
        if len(seg):
            lo = np.minimum(seg[:, 0:3] - seg[:, 6:7], seg[:, 3:6] - seg[:, 7:8]).min(axis=0)
            hi = np.maximum(seg[:, 0:3] + seg[:, 6:7], seg[:, 3:6] + seg[:, 7:8]).max(axis=0)
            origin = lo - cutoff - cell_size
            shape = np.ceil((hi + cutoff + cell_size - origin) / cell_size).astype(np.int64)
        else:
            origin, shape = np.zeros(3), np.ones(3, np.int64)
        packed = tube_kernels.pack_segments(seg)
        arrays = tube_kernels.build_grid(packed, origin, float(cell_size), shape, float(cutoff))
        return cls(chain, packed, float(cutoff), float(cell_size), origin, shape, *arrays)

    def kernel_grid(self) -> tube_kernels.Grid:
        """The grid as the query kernels take it."""
        return tube_kernels.Grid(
            self.packed,
            self.origin,
            self.cell_size,
            self.shape,
            self.cell_start,
            self.items,
            self.item_distance,
            self.cell_state,
        )

    def nearest(self, points: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
        """Distance to the nearest surface and that segment; (inf, -1) beyond the cutoff."""
        return tube_kernels.nearest_segments(points, self.kernel_grid(), self.cutoff)

    def distance(self, points: np.ndarray) -> np.ndarray:
        """Exact signed distance to the union of the tubes, everywhere."""
        distance, _ = self.nearest(points)
        far = ~np.isfinite(distance)
        if far.any() and len(self.chain):
            distance[far] = tube_kernels.brute_force_distance(points[far], self.packed)
        return distance

    def distance_volume(self, origin: np.ndarray, spacing: float, shape: tuple) -> np.ndarray:
        """Distance on a lattice `origin + spacing * (i, j, k)`, clamped to the cutoff."""
        return tube_kernels.distance_volume(
            np.asarray(origin, dtype=np.float64),
            float(spacing),
            np.asarray(shape, dtype=np.int64),
            self.kernel_grid(),
            self.cutoff,
        )
