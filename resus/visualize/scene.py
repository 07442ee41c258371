"""The phantom in rerun: its vessels and body outline, placed in the base frame by the scene."""

from __future__ import annotations

import numpy as np
import rerun as rr
import trimesh

from resus.visualize.entities import PHANTOM
from resus.visualize.transforms import pose_transform
from sim.labels import VESSEL_CLASSES, label_colour
from sim.phantom import Phantom
from sim.robot.scene_config import SceneConfig

MESH_RESOLUTION = 1.0e-3
"""Vessel surface resolution for display (m): coarser than the simulator's, light to log."""
OUTLINE_ANGLE_DEG = 20.0
"""Body edges where the surface bends more than this are drawn as its outline."""


def feature_edges(mesh: trimesh.Trimesh, angle_deg: float = OUTLINE_ANGLE_DEG) -> np.ndarray:
    """(E, 2, 3) end points of the edges where the surface bends by more than `angle_deg`."""
    sharp = mesh.face_adjacency_angles > np.radians(angle_deg)
    return mesh.vertices[mesh.face_adjacency_edges[sharp]]


def log_phantom(stream: rr.RecordingStream, scene: SceneConfig, phantom: Phantom) -> None:
    """Log (static) `phantom_to_base`, the body outline and the vessel surfaces."""
    stream.log(PHANTOM, pose_transform(scene.phantom_to_base), static=True)
    body = phantom.mesh("body", MESH_RESOLUTION)
    stream.log(
        f"{PHANTOM}/body",
        rr.LineStrips3D(feature_edges(body), colors=(200, 170, 140), radii=0.0005),
        static=True,
    )
    for name, value in VESSEL_CLASSES.items():
        try:
            mesh = phantom.mesh(name, MESH_RESOLUTION)
        except ValueError:  # a phantom without this vessel class
            continue
        stream.log(
            f"{PHANTOM}/{name}",
            rr.Mesh3D(
                vertex_positions=mesh.vertices,
                triangle_indices=mesh.faces,
                vertex_normals=mesh.vertex_normals,
                albedo_factor=label_colour(value),
            ),
            static=True,
        )
