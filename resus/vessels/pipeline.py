"""A sweep's label images to a scored vessel map, a needle site and the files that show them.

The one place that runs map, tracks, needle plan, scoring against the phantom and writing, so
that `resus vessels` and `resus demo` give the same files and the same numbers.
"""

from __future__ import annotations

import json
from dataclasses import dataclass, field
from pathlib import Path

import numpy as np

from resus.errors import ResusError
from resus.sweep.model import Sweep
from resus.vessels.map import VesselMapSettings
from resus.vessels.needle import NeedleSettings
from sim.robot.scene_config import SceneConfig

TARGETS = {"vein": 2, "artery": 1}
"""Needle targets and their label values: the vein for a central line, the artery for REBOA."""


@dataclass(frozen=True)
class VesselJob:
    """What to map and which vessel the needle goes to."""

    target: str = "vein"
    needle: NeedleSettings = field(default_factory=NeedleSettings)
    map: VesselMapSettings = field(default_factory=VesselMapSettings)

    def __post_init__(self) -> None:
        if self.target not in TARGETS:
            raise ResusError(f"--target must be vein or artery, got {self.target!r}")


def map_vessels(
    sweep: Sweep,
    labels: np.ndarray,
    scene: SceneConfig,
    out: Path,
    sources: dict[str, str],
    job: VesselJob | None = None,
    progress: bool = False,
) -> dict:
    """Map the vessels of `sweep` from `labels`, plan the needle, score a simulated sweep
    against its phantom, and write meshes, the label volume, pictures and `vessels.json`
    into `out`. `sources` names the sweep and the labels in the metrics. Returns the metrics."""
    from resus.vessels.anatomy import AnatomicalFrame
    from resus.vessels.map import build_vessel_map
    from resus.vessels.needle import SkinModel, plan_needle
    from resus.vessels.track import vessel_track

    job = job or VesselJob()
    out.mkdir(parents=True, exist_ok=True)
    frame = AnatomicalFrame.from_scene(scene)
    vessel_map = build_vessel_map(
        sweep.frames, labels, sweep.probe_to_base, sweep.image_to_probe, frame, job.map,
        progress=progress,
    )  # fmt: skip
    tracks = {
        name: vessel_track(vessel_map.labels == label, vessel_map.grid, frame.proximal)
        for name, label in TARGETS.items()
    }
    other = "artery" if job.target == "vein" else "vein"
    skin = SkinModel.from_poses(sweep.probe_to_base)
    plan = plan_needle(
        tracks[job.target], job.target, vessel_map.meshes.get(other), skin, vessel_map.covered,
        vessel_map.label_at, TARGETS[job.target], job.needle,
    )  # fmt: skip
    metrics = {
        **sources,
        "scene": {**scene.to_dict(), "phantom_to_base": scene.phantom_to_base.tolist()},
        "grid": vessel_map.grid.describe(),
        "anatomy": vessel_map.anatomy,
        "parts": [part.to_dict() for part in vessel_map.parts],
        "meshes": {
            name: {"faces": len(mesh.faces), "watertight": bool(mesh.is_watertight)}
            for name, mesh in vessel_map.meshes.items()
        },
        "needle": plan.to_dict(),
    }
    truth_meshes = {}
    if sweep.source == "sim":
        from resus.acquisition.simulation import phantom_spec
        from resus.vessels.metrics import needle_truth, score_map
        from sim.phantom import Phantom
        from sim.transforms import invert_pose

        truth = Phantom(phantom_spec(scene))
        metrics["scores"] = score_map(vessel_map, truth, scene.phantom_to_base, tracks)
        if plan.safe:
            metrics["needle_truth"] = needle_truth(
                plan.path(job.needle.path_step),
                TARGETS[job.target],
                truth,
                invert_pose(scene.phantom_to_base),
            )
        truth_meshes = _truth_in_box(truth, scene.phantom_to_base, vessel_map)
    else:
        metrics["scores"] = f"not scored: the sweep's source is {sweep.source!r}, not 'sim'"
    written = _write_files(out, vessel_map, plan, tracks[job.target], skin, truth_meshes, scene)
    metrics["files"] = [str(path.relative_to(out)) for path in written]
    (out / "vessels.json").write_text(json.dumps(metrics, indent=2))
    return metrics


def _write_files(out, vessel_map, plan, track, skin, truth_meshes, scene) -> list[Path]:
    """Meshes, the label volume for 3D Slicer, and the two pictures."""
    from resus.reconstruction.io import write_volume
    from resus.vessels.figures import save_mesh_views, save_needle_slice
    from sim.transforms import invert_pose

    written = write_meshes(out, vessel_map.meshes)
    written.append(
        write_volume(out / "vessel_labels.nrrd", vessel_map.labels, vessel_map.grid,
                     ["background", "artery", "vein"])
    )  # fmt: skip
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


def write_meshes(out: Path, meshes: dict) -> list[Path]:
    """Each class as PLY and STL in millimetres (as 3D Slicer reads them, world coordinates
    unchanged like the NRRD volumes), and all classes in one GLB in metres (glTF's unit)."""
    import trimesh

    from resus.vessels.figures import COLOURS

    written = []
    scene = trimesh.Scene()
    for name, mesh in meshes.items():
        in_mm = mesh.copy()
        in_mm.apply_scale(1e3)
        for suffix in ("ply", "stl"):
            written.append(out / f"{name}.{suffix}")
            in_mm.export(written[-1])
        coloured = mesh.copy()
        coloured.visual.face_colors = [int(255 * c) for c in COLOURS[name]] + [255]
        scene.add_geometry(coloured, geom_name=name)
    written.append(out / "vessel_map.glb")
    scene.export(written[-1])
    return written


def _truth_in_box(truth, phantom_to_base, vessel_map) -> dict:
    """The phantom's artery and vein surfaces (world metres), cut to the map's grid box."""
    from resus.vessels.map import lookup_nearest

    inside = np.ones(vessel_map.grid.shape, dtype=bool)
    meshes = {}
    for name in ("artery", "vein"):
        mesh = truth.mesh(name, 0.4e-3).apply_transform(phantom_to_base)
        keep = lookup_nearest(vessel_map.grid, inside, mesh.triangles_center)
        meshes[name] = mesh.submesh([np.flatnonzero(keep)], append=True)
    return meshes
