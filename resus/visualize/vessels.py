"""A vessel map in rerun: its artery and vein surfaces and the proposed needle path."""

from __future__ import annotations

import json
from pathlib import Path

import numpy as np
import rerun as rr
import trimesh

from resus.visualize.entities import VESSEL_MAP
from sim.labels import VESSEL_CLASSES, label_colour

NEEDLE_COLOUR = (40, 220, 80)
MM = 1e-3


def log_vessel_map(stream: rr.RecordingStream, folder: Path, name: str) -> list[str]:
    """Log (static) the surfaces and needle that `map_vessels` wrote into `folder` (PLY in mm,
    base frame) under `world/vessel_map/<name>`; returns the entity paths logged."""
    logged = []
    for vessel, value in VESSEL_CLASSES.items():
        path = folder / f"{vessel}.ply"
        if not path.is_file():  # the map found no such vessel
            continue
        mesh = trimesh.load_mesh(path)
        entity = f"{VESSEL_MAP}/{name}/{vessel}"
        stream.log(
            entity,
            rr.Mesh3D(
                vertex_positions=np.asarray(mesh.vertices) * MM,
                triangle_indices=mesh.faces,
                vertex_normals=mesh.vertex_normals,
                albedo_factor=label_colour(value),
            ),
            static=True,
        )
        logged.append(entity)
    needle = json.loads((folder / "vessels.json").read_text())["needle"]
    if needle["safe"]:
        entity = f"{VESSEL_MAP}/{name}/needle"
        line = np.array([needle["entry_mm"], needle["target_mm"]]) * MM
        stream.log(entity, rr.LineStrips3D([line], colors=NEEDLE_COLOUR, radii=0.0004), static=True)
        logged.append(entity)
    return logged
