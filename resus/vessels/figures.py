"""Pictures of a vessel map: its surfaces against the truth, and the needle over a slice."""

from __future__ import annotations

from pathlib import Path

import numpy as np
import trimesh
from scipy import ndimage

from resus.vessels.map import VesselMap
from resus.vessels.needle import NeedlePlan, SkinModel
from resus.vessels.track import VesselTrack
from sim.labels import VESSEL_CLASSES, label_colour_unit

MM = 1e3
TRUTH_GREY = (0.55, 0.55, 0.55)
"""Colour of the true surfaces under the map's."""
VIEWS = (((0, 1), "top"), ((1, 2), "side"), ((0, 2), "end"))
VIEW_SAMPLES = 20000
"""Surface points drawn per mesh in the projections."""
SLICE_MARGIN = 8.0e-3
"""Extra slice around the needle path in the needle picture (m)."""
SLICE_PIXEL = 0.1e-3
"""Pixel size of the needle picture's slice (m)."""


def save_mesh_views(
    path: Path,
    meshes: dict[str, trimesh.Trimesh],
    truth: dict[str, trimesh.Trimesh],
    view_pose: np.ndarray,
    title: str,
) -> Path:
    """Top, side and end projections of the map's surfaces (colour) over the true ones (grey),
    drawn as area-uniform surface points after `view_pose` (e.g. base to phantom, so the axes
    are anatomical: x to the patient's right, y distal, z out of the skin)."""
    from matplotlib.figure import Figure

    figure = Figure(figsize=(16, 5.5))
    panels = figure.subplots(1, 3)
    layers = [(mesh, TRUTH_GREY, "truth") for mesh in truth.values()]
    layers += [
        (mesh, label_colour_unit(VESSEL_CLASSES[name]), f"map {name}")
        for name, mesh in meshes.items()
    ]
    projected = [(surface_points(mesh, view_pose), colour, label) for mesh, colour, label in layers]
    for panel, ((h, v), name) in zip(panels, VIEWS, strict=True):
        for points, colour, label in projected:
            panel.scatter(points[:, h] * MM, points[:, v] * MM, s=0.2, color=colour, alpha=0.4)
            panel.plot([], [], color=colour, label=label)
        panel.set_aspect("equal")
        panel.set_title(name)
        panel.set_xlabel(f"{'xyz'[h]} (mm)")
        panel.set_ylabel(f"{'xyz'[v]} (mm)")
    handles, labels = panels[0].get_legend_handles_labels()
    unique = dict(zip(labels, handles, strict=True))
    panels[0].legend(unique.values(), unique.keys(), loc="best", fontsize=8)
    figure.suptitle(title)
    figure.tight_layout()
    figure.savefig(path, dpi=90)
    return path


def surface_points(mesh: trimesh.Trimesh, pose: np.ndarray) -> np.ndarray:
    """`VIEW_SAMPLES` seeded area-uniform points on a mesh, moved by a 4x4 pose."""
    points, _ = trimesh.sample.sample_surface(mesh, VIEW_SAMPLES, seed=0)
    return points @ pose[:3, :3].T + pose[:3, 3]


def save_needle_slice(
    path: Path, vessel_map: VesselMap, plan: NeedlePlan, track: VesselTrack, skin: SkinModel
) -> Path:
    """The compounded B-mode in the needle's plane (along the vessel and the skin normal),
    with the map's classes outlined and the planned path drawn; without a safe site, the
    plane through the target's middle station, titled with the reason."""
    from matplotlib.figure import Figure

    if plan.safe:
        # plan_needle sets the tip and direction of every safe plan
        assert plan.target_point is not None and plan.direction is not None
        centre, along = plan.target_point, plan.direction
    elif len(track.positions):
        middle = len(track.positions) // 2
        centre, along = track.positions[middle], track.tangents[middle]
    else:
        centre, along = (
            vessel_map.grid.to_world((np.array(vessel_map.grid.shape) - 1) / 2),
            track.axis,
        )
    normal = skin.plane_near(centre)[1]
    along = along - (along @ normal) * normal
    along = along / np.linalg.norm(along)
    up = normal - (normal @ along) * along
    up /= np.linalg.norm(up)
    reach = plan.insertion_depth if plan.safe else 25.0e-3
    u = np.arange(-reach - SLICE_MARGIN, SLICE_MARGIN, SLICE_PIXEL)
    w = np.arange(-SLICE_MARGIN - 8.0e-3, reach + 2.0e-3, SLICE_PIXEL)
    uu, ww = np.meshgrid(u, w)
    points = centre + uu[..., None] * along + ww[..., None] * up
    voxels = vessel_map.grid.to_voxel(points.reshape(-1, 3)).T
    image = ndimage.map_coordinates(vessel_map.intensity, voxels, order=1, cval=0.0)
    labels = ndimage.map_coordinates(vessel_map.labels, voxels, order=0, cval=0)
    extent = (u[0] * MM, u[-1] * MM, w[0] * MM, w[-1] * MM)
    figure = Figure(figsize=(8, 6.5))
    panel = figure.subplots()
    panel.imshow(image.reshape(uu.shape), cmap="gray", origin="lower", extent=extent)
    for label in VESSEL_CLASSES.values():
        mask = (labels == label).reshape(uu.shape).astype(float)
        if mask.any():
            panel.contour(u * MM, w * MM, mask, levels=[0.5], colors=[label_colour_unit(label)])
    if plan.safe:
        ends = np.array([plan.entry, plan.target_point]) - centre
        panel.plot(ends @ along * MM, ends @ up * MM, color="yellow", lw=2, label="needle")
        panel.plot(*(ends[0] @ np.array([along, up]).T * MM), "o", color="yellow", label="entry")
        panel.plot(0, 0, "x", color="lime", ms=10, label="target")
        panel.legend(loc="lower left", fontsize=8)
        title = (
            f"{plan.target}: {plan.settings.angle_deg:g} deg, depth {plan.insertion_depth * MM:.1f}"
            f" mm, clearance {plan.clearance * MM:.1f} mm"
        )
    else:
        title = plan.reason
    panel.set_title(title, fontsize=9, wrap=True)
    panel.set_xlabel("along the vessel, proximal to the right (mm)")
    panel.set_ylabel("towards the skin (mm)")
    figure.tight_layout()
    figure.savefig(path, dpi=90)
    return path
