"""Stage 5: a sweep's vessel labels compounded into a 3D map of artery and vein surfaces.

Two reconstructions on one axis-aligned grid around the labelled vessels
(`resus.reconstruction.compounding`, squared-distance-weighted compounding with hole filling):
the B-mode frames with the label images as class channels (intensity for pictures, the
segmentation's class per voxel), and the vessel indicator (1 where a pixel is labelled artery
or vein) as intensity, which gives each voxel the weighted share of vessel pixels around it.
That share is smooth across the vessel wall, so marching cubes at 0.5 puts the surface
between voxels, not on their faces.

The vessel mask (share > 0.5) is split into 6-connected parts; parts under
`min_part_volume` are specks and dropped, the rest get their class by anatomy
(`resus.vessels.anatomy`), or keep the labels' class where the labels were already told apart
(by compression, `resus.vessels.compression`). Each voxel belongs to the part nearest to it,
so a class's surface is the 0.5 level of the share over its parts' territory only. Surfaces
are Taubin-smoothed (a low-pass filter that does not shrink the mesh, unlike plain Laplacian
smoothing).
"""

from __future__ import annotations

import functools
from dataclasses import dataclass, field
from pathlib import Path

import numpy as np
import trimesh
from scipy import ndimage
from skimage.measure import marching_cubes

from resus.errors import ResusError, check_choice
from resus.reconstruction.compounding import ReconstructionSettings, reconstruct
from resus.reconstruction.grid import VolumeGrid, aabb_grid
from resus.sweep.model import pixels_to_world
from resus.vessels.anatomy import AnatomicalFrame, VesselPart, assign_by_anatomy, find_parts
from sim.labels import LABEL_NAMES, VEIN, VESSEL_CLASSES

CLASS_RULES = ("anatomy", "labels")
"""How the map's parts get their class (`VesselMapSettings.classes`)."""

SURFACE_LEVEL = 0.5
"""Vessel share at which the surface is drawn: where vessel and background pixels balance."""
LEVEL_OFFSET = 1.0e-3
"""Shares are kept at least this far from the level (moves the surface < 0.1% of a voxel)."""


@dataclass(frozen=True)
class VesselMapSettings:
    """Every knob of the vessel map, with its default."""

    spacing: float = 0.3e-3
    """Voxel size of the map's grid (m)."""
    margin: float = 3.0e-3
    """Grid margin around the labelled vessel pixels (m)."""
    min_part_volume: float = 20e-9
    """Connected vessel parts smaller than this are specks and dropped (m^3; 20 mm^3 is a
    sphere of 1.7 mm radius, a few frames' worth of a false detection; the smallest femoral
    branch in view, 2 mm radius, has more than that in 2 mm of length)."""
    smoothing_iterations: int = 10
    """Taubin smoothing passes on each surface (0: none)."""
    reconstruction: ReconstructionSettings = field(default_factory=ReconstructionSettings)
    """Compounding settings for both reconstructions (radius, alpha, hole filling)."""
    classes: str = "anatomy"
    """How the map's parts get their class: 'anatomy' (the femoral artery lies lateral to the
    vein, whatever the labels say) or 'labels' (each part keeps the labels' majority class:
    labels already told apart, e.g. by compression)."""

    def __post_init__(self) -> None:
        check_choice("VesselMapSettings.classes", self.classes, CLASS_RULES)
        if not self.spacing > 0:
            raise ResusError(f"VesselMapSettings.spacing must be positive, got {self.spacing}")
        for name in ("margin", "min_part_volume", "smoothing_iterations"):
            if not getattr(self, name) >= 0:
                raise ResusError(
                    f"VesselMapSettings.{name} must be >= 0, got {getattr(self, name)}"
                )


@dataclass
class VesselMap:
    """The compounded volumes, the anatomy-labelled vessel volume and the class surfaces."""

    grid: VolumeGrid
    intensity: np.ndarray
    """Compounded B-mode (nx, ny, nz) float32."""
    vessel_share: np.ndarray
    """Weighted share of vessel pixels per voxel, 0..1 (float32)."""
    segmented: np.ndarray
    """The segmentation's class per voxel (argmax of the compounded class channels)."""
    filled: np.ndarray
    """Voxels that hold data (observed or hole-filled)."""
    labels: np.ndarray
    """Map classes per voxel after speck removal and the anatomy rule (uint8: 0, 1, 2)."""
    parts: list[VesselPart]
    anatomy: str
    """Why the classes were given as they were."""
    meshes: dict[str, trimesh.Trimesh]
    """`artery` / `vein` surfaces in world metres (a class absent from the map is missing)."""

    def label_at(self, points: np.ndarray) -> np.ndarray:
        """Map class at world points (nearest voxel; 0 outside the grid)."""
        return lookup_nearest(self.grid, self.labels, points)

    def covered(self, points: np.ndarray) -> np.ndarray:
        """Whether world points fall in voxels that hold data."""
        return lookup_nearest(self.grid, self.filled, points).astype(bool)


def lookup_nearest(grid: VolumeGrid, volume: np.ndarray, points: np.ndarray) -> np.ndarray:
    """Values of `volume` at the voxels nearest to world points; 0 outside the grid."""
    index = np.rint(grid.to_voxel(np.asarray(points, dtype=np.float64).reshape(-1, 3)))
    inside = np.all((index >= 0) & (index < np.array(grid.shape)), axis=1)
    values = np.zeros(len(index), dtype=volume.dtype)
    values[inside] = volume[tuple(index[inside].astype(np.int64).T)]
    return values


def vessel_grid(
    labels: np.ndarray, poses: np.ndarray, image_to_probe: np.ndarray, spacing: float, margin: float
) -> VolumeGrid:
    """Axis-aligned grid over every labelled vessel pixel and the probe face above it (so the
    tissue a needle crosses from the skin is mapped too), `margin` metres around them."""
    low, high = np.full(3, np.inf), np.full(3, -np.inf)
    for label, pose in zip(labels, poses, strict=True):
        rows, cols = np.nonzero(label)
        if len(rows):
            points = pixels_to_world(pose, image_to_probe, cols, rows)
            points = np.vstack([points, pose[:3, 3]])
            low, high = np.minimum(low, points.min(axis=0)), np.maximum(high, points.max(axis=0))
    if not np.all(np.isfinite(low)):
        raise ResusError("no pixel is labelled artery or vein: there is nothing to map")
    return aabb_grid(spacing, bounds=(low - margin, high + margin))


def build_vessel_map(
    frames: np.ndarray,
    labels: np.ndarray,
    poses: np.ndarray,
    image_to_probe: np.ndarray,
    frame: AnatomicalFrame,
    settings: VesselMapSettings | None = None,
) -> VesselMap:
    """Map the vessels of a sweep from its (N, H, W) label images (0 / 1 artery / 2 vein)."""
    settings = settings or VesselMapSettings()
    labels = np.asarray(labels)
    if labels.shape != np.shape(frames) or labels.dtype != np.uint8:
        raise ResusError(f"labels must be uint8 like the frames {np.shape(frames)}")
    if labels.max(initial=0) > VEIN:
        raise ResusError(f"labels must be 0, 1 (artery) or 2 (vein), found {labels.max()}")
    grid = vessel_grid(labels, poses, image_to_probe, settings.spacing, settings.margin)
    compound = functools.partial(
        reconstruct, poses=poses, image_to_probe=image_to_probe, grid=grid,
        settings=settings.reconstruction,
    )  # fmt: skip
    bmode = compound(frames, labels=labels, n_classes=len(LABEL_NAMES))
    # labels and n_classes >= 2 were given, so the reconstruction has a label volume
    assert bmode.labels is not None
    indicator = (np.asarray(label > 0, dtype=np.float32) for label in labels)
    share = compound(indicator)
    vessel_share = np.where(share.filled, share.volume, 0.0).astype(np.float32)
    part_index, parts = find_parts(
        vessel_share > SURFACE_LEVEL, bmode.labels, grid, frame, settings.min_part_volume
    )
    anatomy = assign_by_anatomy(parts) if settings.classes == "anatomy" else keep_labels(parts)
    owner = nearest_part(part_index, grid)
    map_labels = np.zeros(grid.shape, dtype=np.uint8)
    meshes = {}
    for name, label in VESSEL_CLASSES.items():
        members = [part.index for part in parts if part.label == label]
        if not members:
            continue
        map_labels[np.isin(part_index, members)] = label
        territory = np.isin(owner, members)
        mesh = surface_mesh(np.where(territory, vessel_share, 0.0), grid, settings)
        if mesh is not None:
            meshes[name] = mesh
    return VesselMap(
        grid, bmode.volume, vessel_share, bmode.labels, share.filled, map_labels, parts, anatomy,
        meshes,
    )  # fmt: skip


def keep_labels(parts: list[VesselPart]) -> str:
    """Give every part the labels' majority class in it; returns the reasoning."""
    for part in parts:
        part.label = part.segmented_label
    names = [LABEL_NAMES[part.label] for part in parts]
    counts = ", ".join(f"{names.count(name)} {name}" for name in VESSEL_CLASSES)
    return f"each part keeps its labels' majority class ({counts} part(s))"


def nearest_part(part_index: np.ndarray, grid: VolumeGrid) -> np.ndarray:
    """For every voxel, the index of the part (speck or not) whose voxel is nearest."""
    if not part_index.any():
        return part_index
    nearest = ndimage.distance_transform_edt(
        part_index == 0, sampling=grid.spacing, return_distances=False, return_indices=True
    )
    return part_index[tuple(nearest)]


def surface_mesh(
    share: np.ndarray, grid: VolumeGrid, settings: VesselMapSettings
) -> trimesh.Trimesh | None:
    """Smoothed 0.5-level surface of `share` in world metres (None if it has none)."""
    if not (share.max() > SURFACE_LEVEL):
        return None
    # A voxel exactly at the level makes marching cubes put several vertices on one point;
    # merged, they turn the surface non-manifold there and smoothing then tears it apart.
    offset = np.float32(LEVEL_OFFSET)
    share = np.where(share < SURFACE_LEVEL, np.minimum(share, SURFACE_LEVEL - offset),
                     np.maximum(share, SURFACE_LEVEL + offset))  # fmt: skip
    vertices, faces, _, _ = marching_cubes(share, level=SURFACE_LEVEL, gradient_direction="ascent")
    if np.linalg.det(grid.axes) < 0:
        faces = faces[:, ::-1]
    mesh = trimesh.Trimesh(grid.to_world(vertices), faces, process=False)
    if settings.smoothing_iterations:
        trimesh.smoothing.filter_taubin(mesh, iterations=settings.smoothing_iterations)
    return mesh


def segment_frames(frames: np.ndarray, checkpoint: Path, progress: bool = True) -> np.ndarray:
    """Label images for every frame from a segmentation checkpoint (`resus train`'s output),
    as `resus.segmentation.load_model` labels them (mirrored too when it learnt flips)."""
    from resus.segmentation.trained_model import load_model

    return load_model(checkpoint).predict(np.asarray(frames), progress=progress)
