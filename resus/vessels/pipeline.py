"""A sweep's label images to a scored vessel map, a needle site and the files that show them.

The one place that runs map, tracks, needle plan, scoring against the phantom and writing, so
that `resus vessels` and `resus demo` give the same files and the same numbers.
"""

from __future__ import annotations

import contextlib
import json
from collections.abc import Iterator, Mapping
from dataclasses import asdict, dataclass, field
from pathlib import Path
from typing import TYPE_CHECKING

import numpy as np
import trimesh
from tqdm import tqdm

from resus.errors import ResusError, check_choice
from resus.reconstruction.grid import VolumeGrid
from resus.sweep.model import Sweep
from resus.vessels.anatomy import AnatomicalFrame, VesselPart
from resus.vessels.map import VesselMap, VesselMapSettings, build_vessel_map, lookup_nearest
from resus.vessels.metrics import NeedleTruth, VesselScore, needle_truth, score_map
from resus.vessels.needle import NeedlePlan, NeedleSettings, SkinModel, plan_needle
from resus.vessels.track import VesselTrack, vessel_track
from sim.labels import LABEL_NAMES, VESSEL_CLASSES, label_colour
from sim.transforms import invert_pose

if TYPE_CHECKING:
    from sim.phantom import Phantom
    from sim.robot.scene_config import SceneConfig


MAP_STEPS = ("vessel map", "needle site", "scores", "files")
"""The steps of `map_vessels`, one tick each on its progress bar."""


@dataclass(frozen=True)
class VesselJob:
    """What to map and which vessel the needle goes to."""

    target: str = "vein"
    """Needle target: the vein for a central line, the artery for REBOA."""
    needle: NeedleSettings = field(default_factory=NeedleSettings)
    map: VesselMapSettings = field(default_factory=VesselMapSettings)

    def __post_init__(self) -> None:
        check_choice("VesselJob.target", self.target, VESSEL_CLASSES)


@dataclass(frozen=True)
class MeshSummary:
    """Size and closure of one class's surface."""

    faces: int
    watertight: bool

    @classmethod
    def of(cls, mesh: trimesh.Trimesh) -> MeshSummary:
        return cls(len(mesh.faces), bool(mesh.is_watertight))


@dataclass(frozen=True)
class VesselMapResult:
    """What `map_vessels` found and wrote: the content of vessels.json, typed."""

    sources: dict[str, str]
    """What was mapped (e.g. the sweep and where its labels came from)."""
    scene: SceneConfig
    grid: VolumeGrid
    anatomy: str
    """Why the classes were given as they were."""
    parts: tuple[VesselPart, ...]
    meshes: dict[str, MeshSummary]
    needle: NeedlePlan
    scores: dict[str, VesselScore] | None
    """Per-class scores against the phantom; None when the sweep is not simulated."""
    not_scored: str
    """Why `scores` is None ("" when the map was scored)."""
    needle_truth: NeedleTruth | None
    """The planned path on the phantom (a simulated sweep with a safe site only)."""
    files: tuple[str, ...]
    """The files written beside vessels.json, relative to the output folder."""
    extra: dict[str, object] = field(default_factory=dict)
    """More sections of vessels.json from before the map (e.g. "compression": how the
    frames were relabelled)."""

    def scores_to_dict(self) -> dict[str, dict] | str:
        """vessels.json's "scores": the per-class scores, or why there are none."""
        if self.scores is None:
            return self.not_scored
        return {name: score.to_dict() for name, score in self.scores.items()}

    def to_dict(self) -> dict:
        """JSON-able form, as vessels.json holds it (`needle_truth` only where checked)."""
        data: dict[str, object] = {
            **self.sources,
            "scene": {
                **self.scene.to_dict(),
                "phantom_to_base": self.scene.phantom_to_base.tolist(),
            },
            "grid": self.grid.describe(),
            "anatomy": self.anatomy,
            "parts": [part.to_dict() for part in self.parts],
            "meshes": {name: asdict(summary) for name, summary in self.meshes.items()},
            "needle": self.needle.to_dict(),
            "scores": self.scores_to_dict(),
        }
        if self.needle_truth is not None:
            data["needle_truth"] = self.needle_truth.to_dict()
        data.update(self.extra)
        data["files"] = list(self.files)
        return data


def map_vessels(
    sweep: Sweep,
    labels: np.ndarray,
    scene: SceneConfig,
    out: Path,
    sources: dict[str, str],
    job: VesselJob | None = None,
    progress: bool | tqdm = False,
    extra: Mapping[str, object] | None = None,
) -> VesselMapResult:
    """Map the vessels of `sweep` from `labels`, plan the needle, score a simulated sweep
    against its phantom, and write meshes, the label volume, pictures and `vessels.json`
    into `out`. `sources` names the sweep and the labels in the metrics; `extra` adds
    sections to vessels.json (e.g. how the labels were classified before the map).

    `progress`: True for a bar of its own over the `MAP_STEPS`, or a bar to advance by them
    (`map_progress`: one bar, one rate and one time left for several maps).
    """
    inputs = (sweep, labels, scene, out, sources, job or VesselJob())
    if isinstance(progress, tqdm):
        return _map_vessels(*inputs, progress, dict(extra or {}))
    with map_progress(1, progress) as bar:
        return _map_vessels(*inputs, bar, dict(extra or {}))


def map_progress(maps: int, enabled: bool = True) -> tqdm:
    """A bar over the steps of `maps` calls of `map_vessels`, with rate and time left."""
    return tqdm(
        total=maps * len(MAP_STEPS),
        desc="vessel maps" if maps > 1 else "vessel map",
        unit="step",
        disable=not enabled,
    )


@contextlib.contextmanager
def _step(bar: tqdm, name: str) -> Iterator[None]:
    """Name the running step on the bar, and tick when it is done."""
    bar.set_postfix_str(name)
    yield
    bar.update()


def _map_vessels(
    sweep: Sweep,
    labels: np.ndarray,
    scene: SceneConfig,
    out: Path,
    sources: dict[str, str],
    job: VesselJob,
    bar: tqdm,
    extra: dict[str, object],
) -> VesselMapResult:
    """`map_vessels`, one tick of `bar` per step."""
    out.mkdir(parents=True, exist_ok=True)
    with _step(bar, MAP_STEPS[0]):
        frame = AnatomicalFrame.from_scene(scene)
        vessel_map = build_vessel_map(
            sweep.frames, labels, sweep.probe_to_base, sweep.image_to_probe, frame, job.map
        )
        tracks = {
            name: vessel_track(vessel_map.labels == label, vessel_map.grid, frame.proximal)
            for name, label in VESSEL_CLASSES.items()
        }
    with _step(bar, MAP_STEPS[1]):
        other = next(name for name in VESSEL_CLASSES if name != job.target)
        skin = SkinModel.from_poses(sweep.probe_to_base)
        plan = plan_needle(
            tracks[job.target], job.target, vessel_map.meshes.get(other), skin,
            vessel_map.covered, vessel_map.label_at, VESSEL_CLASSES[job.target], job.needle,
        )  # fmt: skip
    with _step(bar, MAP_STEPS[2]):
        scored = _score(sweep, scene, vessel_map, tracks, plan, job)
    with _step(bar, MAP_STEPS[3]):
        written = _write_files(
            out, vessel_map, plan, tracks[job.target], skin, scored.truth_meshes, scene
        )
        result = VesselMapResult(
            sources=dict(sources),
            scene=scene,
            grid=vessel_map.grid,
            anatomy=vessel_map.anatomy,
            parts=tuple(vessel_map.parts),
            meshes={name: MeshSummary.of(mesh) for name, mesh in vessel_map.meshes.items()},
            needle=plan,
            scores=scored.scores,
            not_scored=scored.not_scored,
            needle_truth=scored.needle_truth,
            files=tuple(str(path.relative_to(out)) for path in written),
            extra=extra,
        )
        (out / "vessels.json").write_text(json.dumps(result.to_dict(), indent=2))
    return result


@dataclass(frozen=True)
class _Scored:
    """The map against the phantom: per-class scores, the needle path on the true geometry,
    the true surfaces in the map's box; or why a sweep was not scored."""

    scores: dict[str, VesselScore] | None
    not_scored: str
    needle_truth: NeedleTruth | None
    truth_meshes: dict[str, trimesh.Trimesh]


def _score(
    sweep: Sweep,
    scene: SceneConfig,
    vessel_map: VesselMap,
    tracks: dict[str, VesselTrack],
    plan: NeedlePlan,
    job: VesselJob,
) -> _Scored:
    """Score a simulated sweep's map and needle path against its phantom."""
    if sweep.source != "sim":
        return _Scored(
            None, f"not scored: the sweep's source is {sweep.source!r}, not 'sim'", None, {}
        )
    from resus.acquisition.simulation import simulated_truth
    from sim.phantom import Phantom

    truth = Phantom(simulated_truth(scene, sweep.provenance))
    scores = score_map(vessel_map, truth, scene.phantom_to_base, tracks)
    checked = None
    if plan.safe:
        checked = needle_truth(
            plan.path(job.needle.path_step),
            VESSEL_CLASSES[job.target],
            truth,
            invert_pose(scene.phantom_to_base),
        )
    return _Scored(scores, "", checked, _truth_in_box(truth, scene.phantom_to_base, vessel_map))


def _write_files(
    out: Path,
    vessel_map: VesselMap,
    plan: NeedlePlan,
    track: VesselTrack,
    skin: SkinModel,
    truth_meshes: dict[str, trimesh.Trimesh],
    scene: SceneConfig,
) -> list[Path]:
    """Meshes, the label volume for 3D Slicer, and the two pictures."""
    from resus.reconstruction.io import write_volume
    from resus.vessels.figures import save_mesh_views, save_needle_slice

    written = write_meshes(out, vessel_map.meshes)
    written.append(
        write_volume(out / "vessel_labels.nrrd", vessel_map.labels, vessel_map.grid, LABEL_NAMES)
    )
    in_phantom_frame = bool(truth_meshes)
    written.append(
        save_mesh_views(
            out / "vessel_map.png",
            vessel_map.meshes,
            truth_meshes,
            invert_pose(scene.phantom_to_base) if in_phantom_frame else np.eye(4),
            "vessel map (colour) vs phantom truth (grey), "
            + ("phantom frame" if in_phantom_frame else "robot base frame"),
        )
    )
    written.append(save_needle_slice(out / "needle.png", vessel_map, plan, track, skin))
    return written


def write_meshes(out: Path, meshes: dict[str, trimesh.Trimesh]) -> list[Path]:
    """Each class as PLY and STL in millimetres (as 3D Slicer reads them, world coordinates
    unchanged like the NRRD volumes), and all classes in one GLB in metres (glTF's unit); no
    files at all for a map without vessels (a glTF scene cannot be empty)."""
    if not meshes:
        return []
    written = []
    scene = trimesh.Scene()
    for name, mesh in meshes.items():
        in_mm = mesh.copy()
        in_mm.apply_scale(1e3)
        for suffix in ("ply", "stl"):
            written.append(out / f"{name}.{suffix}")
            in_mm.export(written[-1])
        coloured = mesh.copy()
        # trimesh types `visual` as a union; an untextured mesh's is ColorVisuals
        coloured.visual.face_colors = [*label_colour(VESSEL_CLASSES[name]), 255]  # type: ignore[union-attr]
        scene.add_geometry(coloured, geom_name=name)
    written.append(out / "vessel_map.glb")
    scene.export(written[-1])
    return written


def _truth_in_box(
    truth: Phantom, phantom_to_base: np.ndarray, vessel_map: VesselMap
) -> dict[str, trimesh.Trimesh]:
    """The phantom's vessel surfaces by class name (world metres), cut to the map's grid box."""
    inside = np.ones(vessel_map.grid.shape, dtype=bool)
    meshes = {}
    for name in VESSEL_CLASSES:
        mesh = truth.mesh(name, 0.4e-3).apply_transform(phantom_to_base)
        keep = lookup_nearest(vessel_map.grid, inside, mesh.triangles_center)
        cut = mesh.submesh([np.flatnonzero(keep)], append=True)
        if not isinstance(cut, trimesh.Trimesh):  # submesh gives [] when it keeps no face
            raise ResusError(f"the phantom's {name} surface lies wholly outside the map's grid")
        meshes[name] = cut
    return meshes
