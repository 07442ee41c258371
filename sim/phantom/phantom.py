"""A vessel phantom you can query: labels, tissue, depth and nearest vessel surface per point.

The geometry is exact: every tube is a chain of round cones sampled from its spline, indexed
by a uniform grid (`TubeIndex`); nothing is voxelised except the meshes made for display.
"""

from __future__ import annotations

from dataclasses import dataclass
from functools import cached_property

import numpy as np
import trimesh

from sim.phantom import body as body_shape
from sim.phantom.centreline import SegmentChain, sample_tube
from sim.phantom.layer_waves import LayerWaves
from sim.phantom.meshing import body_mesh, tube_mesh
from sim.phantom.sample_kernels import label_points, sample_points
from sim.phantom.spec import ARTERY, VEIN, Material, PhantomSpec, VesselSpec
from sim.phantom.tube_index import DEFAULT_CELL_SIZE, TubeIndex
from sim.phantom.tube_kernels import Grid

VESSEL_SEARCH_RADIUS = 5.0e-3
"""The default of `Phantom.sample`'s `search_radius`: beyond this distance from every vessel
surface, `TissueSample.vessel_distance` is +inf (m)."""
MESH_NAMES = ("artery", "vein", "body", "bone")


@dataclass
class TissueSample:
    """What the phantom holds at each of N points."""

    label: np.ndarray
    """(N,) uint8: 0 background, 1 artery, 2 vein (0 outside the body)."""
    material: np.ndarray
    """(N,) int8 index into `Phantom.materials`; -1 outside the phantom (air)."""
    depth: np.ndarray
    """(N,) depth below the skin along its normal (m), negative in air."""
    vessel_distance: np.ndarray
    """(N,) signed distance to the nearest vessel surface (negative inside), +inf beyond the
    search radius (`VESSEL_SEARCH_RADIUS` unless the query set one)."""
    vessel_normal: np.ndarray
    """(N, 3) outward unit normal of that nearest vessel surface; zeros if none."""
    vessel_index: np.ndarray
    """(N,) int16 index into `spec.vessels` of the nearest vessel, -1 if none."""

    @classmethod
    def empty(cls, count: int) -> TissueSample:
        """Uninitialised buffers for `count` points, to reuse across `Phantom.sample` calls."""
        return cls(
            np.empty(count, np.uint8),
            np.empty(count, np.int8),
            np.empty(count),
            np.empty(count),
            np.empty((count, 3)),
            np.empty(count, np.int16),
        )

    def __len__(self) -> int:
        return len(self.label)


def _as_points(points: np.ndarray) -> np.ndarray:
    points = np.ascontiguousarray(points, dtype=np.float64)
    if points.ndim != 2 or points.shape[1] != 3:
        raise ValueError(f"points must have shape (N, 3), got {points.shape}")
    return points


class Phantom:
    """Geometry queries on one `PhantomSpec` (indexes are built on first use)."""

    def __init__(self, spec: PhantomSpec, cell_size: float = DEFAULT_CELL_SIZE) -> None:
        self.spec = spec
        self.cell_size = cell_size
        materials: list[Material] = [*spec.layers, spec.blood]
        self._blood_index = len(spec.layers)
        # -1 where there are no tubes of a kind: the sampling kernel then skips their lookup
        self._structure_material: dict[str, int] = {}
        for kind, (material, tubes) in spec.structures().items():
            if material is not None:
                materials.append(material)
            self._structure_material[kind] = len(materials) - 1 if tubes else -1
        self.materials: tuple[Material, ...] = tuple(materials)
        self._body_kind, self._body_params = body_shape.body_parameters(spec.body)
        self._layer_bottoms = np.cumsum([layer.thickness for layer in spec.layers[:-1]])
        waves = spec.layer_waves or LayerWaves()
        self._layer_waves = (
            waves.waves(),
            waves.taper(self._layer_bottoms),
            waves.reach(self._layer_bottoms),
        )
        self._vessel_indexes: dict[float, TubeIndex] = {}

    def _vessel_index_within(self, search_radius: float) -> TubeIndex:
        """The vessels' index for nearest-surface queries within `search_radius` (built once
        per radius: a smaller radius keeps fewer candidates, and most cells none)."""
        index = self._vessel_indexes.get(search_radius)
        if index is None:
            index = self._vessel_indexes[search_radius] = self._tube_index(
                self.spec.vessels, search_radius
            )
        return index

    def _tube_index(self, tubes: tuple[VesselSpec, ...], search_radius: float) -> TubeIndex:
        """An index over all of `tubes` for nearest-surface queries within `search_radius`
        (0: it tells only whether a point is inside one of them)."""
        chain = SegmentChain.from_tubes(tubes, list(range(len(tubes))))
        return TubeIndex.build(chain, search_radius, self.cell_size)

    @cached_property
    def _structure_grids(self) -> dict[str, tuple[Grid, np.ndarray]]:
        """Per kind of unlabelled structure, its kernel grid and the mark (1) of each segment.
        They need no search radius: nothing needs the distance to them, only inside or not."""
        grids = {}
        for kind, (_, members) in self.spec.structures().items():
            index = self._tube_index(members, 0.0)
            grids[kind] = (index.kernel_grid(), np.ones(len(index.chain), np.uint8))
        return grids

    @cached_property
    def _structure_union(self) -> Grid:
        """One grid over the tubes of every kind of structure: where its cell lies wholly
        outside them, a point is in none and the kinds' own lookups are skipped."""
        tubes = tuple(tube for _, members in self.spec.structures().values() for tube in members)
        return self._tube_index(tubes, 0.0).kernel_grid()

    @cached_property
    def _class_indexes(self) -> dict[str, TubeIndex]:
        """Per-class indexes (artery, vein, bone) for exact distances and meshes."""
        spec = self.spec
        groups = {
            "artery": (spec.vessels, [i for i, v in enumerate(spec.vessels) if v.label == ARTERY]),
            "vein": (spec.vessels, [i for i, v in enumerate(spec.vessels) if v.label == VEIN]),
            "bone": (spec.bones, list(range(len(spec.bones)))),
        }
        return {
            name: TubeIndex.build(
                SegmentChain.from_tubes(tubes, members), VESSEL_SEARCH_RADIUS, self.cell_size
            )
            for name, (tubes, members) in groups.items()
        }

    def labels(self, points: np.ndarray) -> np.ndarray:
        """(N, 3) points to (N,) uint8 labels: 0 background or outside, 1 artery, 2 vein."""
        points = _as_points(points)
        grid = self._vessel_index_within(0.0)  # inside or not: no distances needed
        out = np.empty(len(points), np.uint8)
        label_points(
            points,
            self._body_kind,
            self._body_params,
            grid.kernel_grid(),
            grid.chain.label,
            out,
        )
        return out

    def sample(
        self,
        points: np.ndarray,
        out: TissueSample | None = None,
        search_radius: float = VESSEL_SEARCH_RADIUS,
    ) -> TissueSample:
        """Label, material, depth and nearest vessel surface at (N, 3) points.

        Pass `out` (e.g. `TissueSample.empty(N)`) to reuse its buffers across calls. The
        nearest vessel surface is looked for within `search_radius` (m); a caller that needs
        it only near the walls saves most of the search by asking for less.
        """
        points = _as_points(points)
        if out is None:
            out = TissueSample.empty(len(points))
        elif len(out) != len(points):
            raise ValueError(f"out holds {len(out)} points but {len(points)} were given")
        if not search_radius >= 0:
            raise ValueError(f"search_radius must be >= 0, got {search_radius}")
        vessels, grids = self._vessel_index_within(search_radius), self._structure_grids
        material = self._structure_material
        sample_points(
            points,
            self._body_kind,
            self._body_params,
            self._layer_bottoms,
            *self._layer_waves,
            self._blood_index,
            vessels.kernel_grid(),
            vessels.chain.tube,
            vessels.chain.label,
            vessels.cutoff,
            self._structure_union,
            material["bone"],
            *grids["bone"],
            material["node"],
            *grids["node"],
            material["hilum"],
            *grids["hilum"],
            material["muscle"],
            *grids["muscle"],
            material["nerve"],
            *grids["nerve"],
            material["fascicle"],
            *grids["fascicle"],
            out.label,
            out.material,
            out.depth,
            out.vessel_distance,
            out.vessel_normal,
            out.vessel_index,
        )
        return out

    def skin_height(self, x: np.ndarray, y: np.ndarray) -> np.ndarray:
        """z of the skin above (x, y); NaN outside the body's footprint."""
        return body_shape.skin_height(self.spec.body, x, y)

    def skin_normal(self, x: np.ndarray, y: np.ndarray) -> np.ndarray:
        """Outward unit skin normal above (x, y), shape (..., 3); NaN outside the footprint."""
        return body_shape.skin_normal(self.spec.body, x, y)

    def vessel_sdf(self, points: np.ndarray, label: int) -> np.ndarray:
        """Exact signed distance to the union of class `label`'s vessels, negative inside."""
        if label not in (ARTERY, VEIN):
            raise ValueError(f"label must be {ARTERY} (artery) or {VEIN} (vein), got {label}")
        name = "artery" if label == ARTERY else "vein"
        return self._class_indexes[name].distance(_as_points(points))

    def mesh(self, what: str = "artery", resolution: float = 0.25e-3) -> trimesh.Trimesh:
        """Watertight surface of `artery`, `vein`, `body` or `bone` (metres, phantom frame)."""
        if what not in MESH_NAMES:
            raise ValueError(f"mesh must be one of {MESH_NAMES}, got {what!r}")
        if not resolution > 0:
            raise ValueError(f"resolution must be positive, got {resolution}")
        if what == "body":
            return body_mesh(self.spec.body, resolution)
        index = self._class_indexes[what]
        if not len(index.chain):
            raise ValueError(f"phantom {self.spec.name!r} has no {what}")
        return tube_mesh(index, resolution)

    @cached_property
    def _samples(self) -> dict:
        return {vessel.name: sample_tube(vessel) for vessel in self.spec.vessels}

    def centrelines(self) -> dict[str, np.ndarray]:
        """Each vessel's centreline as the (M, 3) nodes of its segment chain (<= 1 mm apart)."""
        return {name: samples.nodes.copy() for name, samples in self._samples.items()}

    def centreline_radii(self) -> dict[str, np.ndarray]:
        """Lumen radius (m) at each node returned by `centrelines`."""
        return {name: samples.radii.copy() for name, samples in self._samples.items()}
