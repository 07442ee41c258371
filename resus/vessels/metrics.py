"""How well a vessel map matches the phantom's true geometry, per vessel class.

Everything is measured in the phantom frame (the map's world points through
`inv(phantom_to_base)`) and only inside the scored region: the voxels that hold data, eroded
by `SCORED_EROSION` voxels, because the map cannot show vessels where the sweep never looked
and closes its surfaces where the data end.

- Dice on the map's grid: truth = the phantom's label at each voxel centre.
- Surface distances, both ways, on area-uniform surface samples: map surface to truth by the
  phantom's exact signed distance; truth surface (its fine marching-cubes mesh) to the map's
  surface by exact point-to-triangle distance. Mean surface distance is the average of the two
  one-way means (symmetric, whatever the two surfaces' areas in the region); HD95 is the
  larger of the two directions' 95th percentiles.
- Centreline distance: mean distance from the centroids of the map's round cross-sections to
  the nearest true centreline of that class (exact distance to its polyline).
"""

from __future__ import annotations

from collections.abc import Callable
from dataclasses import asdict, dataclass
from functools import partial
from typing import TYPE_CHECKING

import numpy as np
import trimesh
from scipy import ndimage

from resus.reconstruction.grid import VolumeGrid
from resus.vessels.map import VesselMap, lookup_nearest
from resus.vessels.mesh_distance import MeshDistance
from resus.vessels.track import VesselTrack
from sim.labels import ARTERY, VEIN, VESSEL_CLASSES
from sim.transforms import invert_pose

if TYPE_CHECKING:
    from sim.phantom import Phantom

SCORED_EROSION = 3
"""Voxels trimmed off the data's edge before scoring (where the map closes its surfaces)."""
SURFACE_SAMPLES = 20000
"""Surface samples per surface and direction."""
TRUTH_MESH_RESOLUTION = 0.2e-3
"""Cell size of the phantom's reference surface (m); its vertices lie on the exact surface."""
LABEL_CHUNK = 1_000_000
"""Voxel centres labelled per call to the phantom."""
MM = 1e3

InRegion = Callable[[np.ndarray], np.ndarray]
"""Which of (N, 3) phantom-frame points lie in the scored region (bool (N,))."""


@dataclass(frozen=True)
class SurfaceDistances:
    """Distances (mm) between a map surface and the true one, inside the scored region."""

    mean_mm: float
    """Symmetric mean: the average of the two one-way means."""
    hd95_mm: float
    """The larger of the two one-way 95th percentiles."""
    map_to_truth_mean_mm: float
    truth_to_map_mean_mm: float
    samples: tuple[int, int]
    """Surface samples in the region: on the map, on the truth."""


@dataclass(frozen=True)
class VesselScore:
    """One vessel class of the map against the phantom."""

    dice: float
    surface: SurfaceDistances | None
    """None when the map has no such surface or the region holds none of the true one."""
    centreline_distance_mm: float | None
    """None without cross-sections in the scored region."""

    @property
    def mean_surface_distance_mm(self) -> float | None:
        return None if self.surface is None else self.surface.mean_mm

    @property
    def hd95_mm(self) -> float | None:
        return None if self.surface is None else self.surface.hd95_mm

    def to_dict(self) -> dict:
        """JSON-able form, as vessels.json holds it (one-way means only where measured)."""
        data: dict = {
            "dice": self.dice,
            "mean_surface_distance_mm": self.mean_surface_distance_mm,
            "hd95_mm": self.hd95_mm,
        }
        if self.surface is not None:
            data["map_to_truth_mean_mm"] = self.surface.map_to_truth_mean_mm
            data["truth_to_map_mean_mm"] = self.surface.truth_to_map_mean_mm
            data["surface_samples"] = list(self.surface.samples)
        data["centreline_distance_mm"] = self.centreline_distance_mm
        return data


@dataclass(frozen=True)
class NeedleTruth:
    """A planned needle path checked on the phantom's exact geometry (mm)."""

    tip_in_target_lumen: bool
    tip_depth_in_target_mm: float
    """How far inside the target's wall the tip lies (negative: outside)."""
    clearance_from_other_mm: float
    """Smallest distance from the path to the other vessel (negative: it enters it)."""

    def to_dict(self) -> dict:
        return asdict(self)


def dice(predicted: np.ndarray, truth: np.ndarray) -> float:
    """Dice overlap 2|A and B| / (|A| + |B|) of two boolean arrays (1.0 when both are empty)."""
    total = int(predicted.sum()) + int(truth.sum())
    return 1.0 if total == 0 else 2.0 * int(np.sum(predicted & truth)) / total


def to_frame(points: np.ndarray, pose: np.ndarray) -> np.ndarray:
    """Points (N, 3) mapped through a 4x4 pose."""
    return np.asarray(points, dtype=np.float64) @ pose[:3, :3].T + pose[:3, 3]


def truth_labels(phantom: Phantom, grid: VolumeGrid, base_to_phantom: np.ndarray) -> np.ndarray:
    """The phantom's label at every voxel centre of `grid` (nx, ny, nz) uint8."""
    indices = np.indices(grid.shape).reshape(3, -1).T
    labels = np.empty(len(indices), dtype=np.uint8)
    for start in range(0, len(indices), LABEL_CHUNK):
        world = grid.to_world(indices[start : start + LABEL_CHUNK].astype(np.float64))
        labels[start : start + LABEL_CHUNK] = phantom.labels(to_frame(world, base_to_phantom))
    return labels.reshape(grid.shape)


def scored_region(filled: np.ndarray) -> np.ndarray:
    """Voxels holding data, `SCORED_EROSION` voxels in from every edge of the data."""
    return ndimage.binary_erosion(filled, iterations=SCORED_EROSION, border_value=0)


def surface_samples(mesh: trimesh.Trimesh, count: int, seed: int) -> np.ndarray:
    """Area-uniform random points (count, 3) on a mesh surface (seeded)."""
    points, _ = trimesh.sample.sample_surface(mesh, count, seed=seed)
    return np.asarray(points)


def distance_to_polylines(points: np.ndarray, polylines: list[np.ndarray]) -> np.ndarray:
    """Exact distance (N,) from points (N, 3) to the nearest segment of any polyline."""
    starts = np.concatenate([line[:-1] for line in polylines])
    ends = np.concatenate([line[1:] for line in polylines])
    step = ends - starts
    length2 = np.maximum(np.einsum("ij,ij->i", step, step), 1e-30)
    best = np.full(len(points), np.inf)
    for start in range(0, len(points), 256):
        chunk = points[start : start + 256, None, :]
        t = np.clip(np.einsum("nsj,sj->ns", chunk - starts, step) / length2, 0.0, 1.0)
        nearest = starts + t[..., None] * step
        best[start : start + 256] = np.linalg.norm(chunk - nearest, axis=2).min(axis=1)
    return best


def surface_scores(
    mesh: trimesh.Trimesh | None,
    truth_mesh: trimesh.Trimesh,
    truth_sdf: Callable[[np.ndarray], np.ndarray],
    in_region: InRegion,
    seed: int,
) -> SurfaceDistances | None:
    """Mean, HD95 and both one-way means (mm) between a map surface and the true one; None
    when either has no surface in the region (e.g. a map that fills the swept volume has its
    surface on the region's border, outside it), since the distances need samples of both."""
    truth_points = surface_samples(truth_mesh, SURFACE_SAMPLES, seed)
    truth_points = truth_points[in_region(truth_points)]
    if mesh is None or len(truth_points) == 0:
        return None
    map_points = surface_samples(mesh, SURFACE_SAMPLES, seed + 1)
    map_points = map_points[in_region(map_points)]
    if len(map_points) == 0:
        return None
    map_to_truth = np.abs(truth_sdf(map_points))
    truth_to_map = MeshDistance(mesh)(truth_points)
    return SurfaceDistances(
        mean_mm=float(0.5 * (map_to_truth.mean() + truth_to_map.mean()) * MM),
        hd95_mm=float(max(np.percentile(map_to_truth, 95), np.percentile(truth_to_map, 95)) * MM),
        map_to_truth_mean_mm=float(map_to_truth.mean() * MM),
        truth_to_map_mean_mm=float(truth_to_map.mean() * MM),
        samples=(len(map_points), len(truth_points)),
    )


def score_map(
    vessel_map: VesselMap,
    phantom: Phantom,
    phantom_to_base: np.ndarray,
    tracks: dict[str, VesselTrack],
    seed: int = 0,
) -> dict[str, VesselScore]:
    """Per-class scores of the map against the phantom, by class name."""
    base_to_phantom = invert_pose(phantom_to_base)
    grid = vessel_map.grid
    region = scored_region(vessel_map.filled)
    truth = truth_labels(phantom, grid, base_to_phantom)

    def in_region(phantom_points: np.ndarray) -> np.ndarray:
        world = to_frame(phantom_points, phantom_to_base)
        return lookup_nearest(grid, region, world).astype(bool)

    scores = {}
    for name, label in VESSEL_CLASSES.items():
        mesh = vessel_map.meshes.get(name)
        mesh_in_phantom = None if mesh is None else mesh.copy().apply_transform(base_to_phantom)
        scores[name] = VesselScore(
            dice=dice((vessel_map.labels == label) & region, (truth == label) & region),
            surface=surface_scores(
                mesh_in_phantom,
                phantom.mesh(name, TRUTH_MESH_RESOLUTION),
                partial(phantom.vessel_sdf, label=label),
                in_region,
                seed + 2 * label,
            ),
            centreline_distance_mm=centreline_distance(
                tracks.get(name), phantom, label, base_to_phantom, in_region
            ),
        )
    return scores


def centreline_distance(
    track: VesselTrack | None,
    phantom: Phantom,
    label: int,
    base_to_phantom: np.ndarray,
    in_region: InRegion,
) -> float | None:
    """Mean distance (mm) from the track's round cross-section centroids to the true
    centrelines of class `label` (None without cross-sections in the scored region)."""
    if track is None or not track.sections:
        return None
    centroids = to_frame(np.array([s.centroid for s in track.sections]), base_to_phantom)
    centroids = centroids[in_region(centroids)]
    if not len(centroids):
        return None
    lines = phantom.centrelines()
    polylines = [lines[v.name] for v in phantom.spec.vessels if v.label == label]
    return float(distance_to_polylines(centroids, polylines).mean() * MM)


def needle_truth(
    plan_path: np.ndarray, target: int, phantom: Phantom, base_to_phantom: np.ndarray
) -> NeedleTruth:
    """The planned path checked on the phantom: does its tip sit in the target's lumen, and
    how close does it come to the other vessel (exact distances)?"""
    points = to_frame(plan_path, base_to_phantom)
    other = VEIN if target == ARTERY else ARTERY
    tip_distance = float(phantom.vessel_sdf(points[-1:], target)[0])
    return NeedleTruth(
        tip_in_target_lumen=tip_distance < 0,
        tip_depth_in_target_mm=-tip_distance * MM,
        clearance_from_other_mm=float(phantom.vessel_sdf(points, other).min() * MM),
    )
