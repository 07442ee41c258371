"""A needle insertion site from the vessel map: skin entry, direction and depth.

The needle lies in the plane of the target vessel and the skin normal, at `angle_deg` to the
skin, pointing proximally (towards the head, as for femoral access), and ends at the centre
of the target's lumen at one trunk station. The skin is where the probe face touched it: the
plane of the tracked probe face nearest to the entry point (the sweep's own poses; nothing
about the phantom is assumed).

A station is a candidate when its vessel is a straight single tube there (curvature at most
`max_curvature`, at least `min_branch_distance` along the leg from any branching slice and
`end_margin` from the mapped stretch's ends) and the whole path lies inside the scanned
volume (otherwise what lies along it is unknown). It is safe when the path keeps
`min_clearance` from the other vessel's surface. Clearance is the exact distance from points
every `path_step` along the path to the other vessel's mesh: the path starts on the skin,
outside every vessel, so a path that entered the other vessel would cross its surface and
measure 0. Of the safe stations the one with the largest clearance is chosen.
"""

from __future__ import annotations

import math
from dataclasses import dataclass, field

import numpy as np
import trimesh

from resus.errors import ResusError
from resus.vessels.mesh_distance import MeshDistance
from resus.vessels.track import VesselTrack

MM = 1e3
REJECTIONS = ("curved", "near a branch", "near the map's end", "outside the scan", "too close")


@dataclass(frozen=True)
class NeedleSettings:
    """Every knob of the insertion-site search, with its default."""

    angle_deg: float = 45.0
    """Angle between the needle and the skin (degrees)."""
    min_clearance: float = 3.0e-3
    """Smallest allowed distance from the path to the other vessel's surface (m)."""
    min_branch_distance: float = 10.0e-3
    """Smallest distance along the leg from the target's nearest branching (m)."""
    max_curvature: float = 25.0
    """Largest curvature of the target there (1/m; 25/m is a 40 mm radius of curvature)."""
    end_margin: float = 5.0e-3
    """Smallest distance along the leg from either end of the mapped stretch (m)."""
    path_step: float = 0.1e-3
    """Spacing of the points at which the path is checked (m)."""
    entry_tolerance: float = 1.0e-3
    """Path length next to the skin exempt from the scanned-volume check (the image starts
    half a pixel below the probe face) (m)."""

    def __post_init__(self) -> None:
        if not 5.0 <= self.angle_deg <= 90.0:
            raise ResusError(
                f"NeedleSettings.angle_deg must be between 5 and 90 degrees, got {self.angle_deg}"
            )
        for name in ("min_clearance", "min_branch_distance", "max_curvature", "end_margin"):
            if not getattr(self, name) >= 0:
                raise ResusError(f"NeedleSettings.{name} must be >= 0, got {getattr(self, name)}")
        if not self.path_step > 0:
            raise ResusError(f"NeedleSettings.path_step must be positive, got {self.path_step}")


@dataclass(frozen=True)
class SkinModel:
    """The skin as the tracked probe faces: one point and outward normal per frame."""

    points: np.ndarray
    normals: np.ndarray

    @classmethod
    def from_poses(cls, probe_to_base: np.ndarray) -> SkinModel:
        """The probe face centres (TCP origins); the outward normal is minus the probe's z."""
        poses = np.asarray(probe_to_base)
        return cls(poses[:, :3, 3].copy(), -poses[:, :3, 2].copy())

    def plane_near(self, point: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
        """Point and outward unit normal of the probe face nearest to `point`."""
        nearest = int(np.argmin(np.linalg.norm(self.points - point, axis=1)))
        normal = self.normals[nearest]
        return self.points[nearest], normal / np.linalg.norm(normal)


@dataclass
class NeedlePlan:
    """The chosen site (or why there is none)."""

    target: str
    safe: bool
    reason: str
    settings: NeedleSettings
    entry: np.ndarray | None = None
    """Skin entry point (world, m)."""
    target_point: np.ndarray | None = None
    """Needle tip: the centre of the target's lumen (world, m)."""
    direction: np.ndarray | None = None
    """Unit needle direction, entry to tip (world)."""
    insertion_depth: float = math.nan
    """Needle length from the skin to the lumen centre (m)."""
    wall_depth: float = math.nan
    """Needle length from the skin to where it enters the target's lumen (m)."""
    vessel_depth: float = math.nan
    """Depth of the lumen centre below the skin, along the skin normal (m)."""
    clearance: float = math.nan
    """Smallest distance from the path to the other vessel's surface (m)."""
    station: dict = field(default_factory=dict)
    """Vessel radius, curvature and branch distance at the chosen station."""
    rejected: dict = field(default_factory=dict)
    """How many stations failed each check (in the order checked)."""

    def path(self, step: float) -> np.ndarray:
        """Points (K, 3) every `step` metres from the entry to the tip."""
        if self.entry is None or self.target_point is None:
            raise ResusError(f"no needle path: {self.reason}")
        return path_points(self.entry, self.target_point, step)

    def to_dict(self) -> dict:
        def mm(value: float) -> float | None:
            return None if not math.isfinite(value) else round(value * MM, 3)

        def point(value: np.ndarray | None) -> list[float] | None:
            return None if value is None else [round(float(v) * MM, 3) for v in value]

        return {
            "target": self.target,
            "safe": self.safe,
            "reason": self.reason,
            "angle_deg": self.settings.angle_deg,
            "min_clearance_mm": mm(self.settings.min_clearance),
            "entry_mm": point(self.entry),
            "target_mm": point(self.target_point),
            "direction": None if self.direction is None else [float(v) for v in self.direction],
            "insertion_depth_mm": mm(self.insertion_depth),
            "wall_depth_mm": mm(self.wall_depth),
            "vessel_depth_mm": mm(self.vessel_depth),
            "clearance_mm": mm(self.clearance),
            "station": self.station,
            "rejected": self.rejected,
        }


def path_points(entry: np.ndarray, tip: np.ndarray, step: float) -> np.ndarray:
    """Points from `entry` to `tip` inclusive, at most `step` apart."""
    count = max(2, math.ceil(np.linalg.norm(tip - entry) / step) + 1)
    return entry + np.linspace(0.0, 1.0, count)[:, None] * (tip - entry)


def needle_line(
    tip: np.ndarray, tangent: np.ndarray, skin: SkinModel, angle: float
) -> tuple[np.ndarray, np.ndarray, float]:
    """Entry point, unit direction and skin depth of a needle reaching `tip` at `angle` (rad)
    to the skin, in the plane of `tangent` (pointing proximally) and the skin normal."""
    entry = tip
    for _ in range(3):  # the skin plane is taken at the entry point, which depends on it
        origin, normal = skin.plane_near(entry)
        along = tangent - (tangent @ normal) * normal
        along /= np.linalg.norm(along)
        direction = math.cos(angle) * along - math.sin(angle) * normal
        depth = float((origin - tip) @ normal)
        entry = tip - depth / math.sin(angle) * direction
    return entry, direction, depth


def plan_needle(
    track: VesselTrack,
    target: str,
    other_mesh: trimesh.Trimesh | None,
    skin: SkinModel,
    covered,
    label_at,
    target_label: int,
    settings: NeedleSettings | None = None,
) -> NeedlePlan:
    """Choose the insertion site on `track` (the target's trunk).

    `covered(points)` says which world points lie in the scanned volume and `label_at(points)`
    gives the map's class there (to find where the needle enters the target's lumen).
    """
    settings = settings or NeedleSettings()
    angle = math.radians(settings.angle_deg)
    distance_to_other = MeshDistance(other_mesh) if other_mesh is not None else None
    rejected = dict.fromkeys(REJECTIONS, 0)
    best: NeedlePlan | None = None
    closest_clearance = -math.inf
    for i in range(len(track.positions)):
        if track.curvature[i] > settings.max_curvature:
            rejected["curved"] += 1
            continue
        if track.branch_distance[i] < settings.min_branch_distance:
            rejected["near a branch"] += 1
            continue
        if track.end_distance[i] < settings.end_margin:
            rejected["near the map's end"] += 1
            continue
        tip = track.positions[i]
        entry, direction, depth = needle_line(tip, track.tangents[i], skin, angle)
        points = path_points(entry, tip, settings.path_step)
        away_from_skin = np.linalg.norm(points - entry, axis=1) > settings.entry_tolerance
        if depth <= 0 or not covered(points[away_from_skin]).all():
            rejected["outside the scan"] += 1
            continue
        clearance = math.inf if distance_to_other is None else distance_to_other.minimum(points)
        closest_clearance = max(closest_clearance, clearance)
        if clearance < settings.min_clearance:
            rejected["too close"] += 1
            continue
        if best is not None and clearance <= best.clearance:
            continue
        inside = np.flatnonzero(label_at(points) == target_label)
        best = NeedlePlan(
            target=target,
            safe=True,
            reason="",
            settings=settings,
            entry=entry,
            target_point=tip,
            direction=direction,
            insertion_depth=float(np.linalg.norm(tip - entry)),
            wall_depth=float(np.linalg.norm(points[inside[0]] - entry))
            if len(inside)
            else math.nan,
            vessel_depth=depth,
            clearance=clearance,
            station={
                "radius_mm": round(float(track.radii[i]) * MM, 3),
                "curvature_per_m": round(float(track.curvature[i]), 2),
                "branch_distance_mm": round(float(track.branch_distance[i]) * MM, 2),
                "end_distance_mm": round(float(track.end_distance[i]) * MM, 2),
            },
        )
    checked = len(track.positions)
    summary = ", ".join(f"{count} {why}" for why, count in rejected.items() if count)
    if best is None:
        reason = f"no safe site on the {target}: of {checked} trunk stations, {summary or 'none'}"
        if math.isfinite(closest_clearance) and rejected["too close"]:
            reason += (
                f" (largest clearance {closest_clearance * MM:.2f} mm < required "
                f"{settings.min_clearance * MM:.2f} mm)"
            )
        return NeedlePlan(target, False, reason, settings, rejected=rejected)
    best.rejected = rejected
    best.reason = (
        f"the station with the largest clearance ({best.clearance * MM:.2f} mm >= "
        f"{settings.min_clearance * MM:.2f} mm) among the straight, unbranched stretches of the "
        f"{target}, {best.station['branch_distance_mm']:.1f} mm from the nearest branching; "
        f"{checked} stations checked ({summary or 'all passed'})"
    )
    return best
