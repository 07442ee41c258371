"""A scan trajectory: a TCP path through waypoints, timed by a trapezoidal speed profile.

The path runs through `waypoints` (4x4 TCP poses in the robot base frame), linearly in
position and by slerp in rotation. Its length counts a rotation as the arc that a point at
`rotation_radius` below the probe face sweeps, so a fan (pure rocking) has a length and a speed
too. The time law accelerates at `acceleration` to `speed`, cruises, and decelerates to rest;
`stops` split it into such moves, rest to rest, with the probe held still for a while at each
stop (a compression scan's stations). `force_profile` lets the force-mode setpoint vary over
time (a press at each station) instead of holding `contact_force`.
Saved as YAML (schema `resus.trajectory/1`) with poses as UR `[x, y, z, rx, ry, rz]`, so the
same file runs in simulation, on the emulator and on a real robot; files written before stops
and force profiles existed load as before. `imaging_segments` marks the stretches of path whose
frames are meant for imaging (a raster's passes, not its U-turns; a zero-length segment at a
stop: the frames taken there); frames elsewhere are recorded but may be discarded.
"""

from __future__ import annotations

from dataclasses import dataclass, field
from functools import cached_property
from pathlib import Path

import numpy as np
import yaml
from scipy.spatial.transform import Rotation

from resus.errors import ResusError
from resus.yaml_file import read_yaml
from sim.transforms import PoseInterpolator, is_rigid, pose_from_ur, pose_to_ur

SCHEMA = "resus.trajectory/1"
ARC_TOLERANCE = 1e-9
"""Arc lengths (m) this close count as one place: a stop and a zero-length imaging segment."""


def _trapezoid(length: float, speed: float, accel: float) -> tuple[float, float, float]:
    """(peak speed, ramp time, cruise time) of a rest-to-rest move of `length` (m) that
    accelerates at `accel` to at most `speed` (a triangle when it never gets there)."""
    if speed * speed / accel >= length:
        peak = float(np.sqrt(length * accel))
        return peak, peak / accel, 0.0
    ramp = speed / accel
    return speed, ramp, (length - speed * ramp) / speed


def _travelled(t: np.ndarray, profile: tuple[float, float, float], accel: float) -> np.ndarray:
    """Distance covered at times `t` (s, clipped to the move) by a `_trapezoid` move."""
    peak, ramp, cruise = profile
    t = np.clip(t, 0.0, 2 * ramp + cruise)
    rising = 0.5 * accel * np.minimum(t, ramp) ** 2
    cruising = peak * np.clip(t - ramp, 0.0, cruise)
    falling_t = np.clip(t - ramp - cruise, 0.0, ramp)
    falling = peak * falling_t - 0.5 * accel * falling_t**2
    return rising + cruising + falling


def _pairs(values: object, name: str) -> tuple[tuple[float, float], ...]:
    """`values` as a tuple of (float, float) pairs, or a ResusError naming the setting."""
    try:
        pairs = tuple((float(a), float(b)) for a, b in values)  # type: ignore[attr-defined]
    except (TypeError, ValueError):
        raise ResusError(f"Trajectory.{name} must be a list of pairs, got {values!r}") from None
    if not np.all(np.isfinite(pairs)):
        raise ResusError(f"Trajectory.{name} must be finite numbers, got {list(pairs)}")
    return pairs


@dataclass(frozen=True)
class Trajectory:
    """A timed TCP path plus how to scan along it."""

    waypoints: np.ndarray
    """(K, 4, 4) TCP poses in the robot base frame, K >= 2."""
    speed: float = 0.01
    """Cruise speed along the path (m/s)."""
    acceleration: float = 0.05
    """Acceleration at the start and end of the path (m/s^2)."""
    contact_force: float | None = 4.0
    """Force held along the probe axis during the sweep (N); None for pure position control."""
    frame_rate: float = 30.0
    """Frames per second the probe is expected to deliver (Hz)."""
    approach_height: float = 0.01
    """The probe starts and ends this far above the path, along its own axis (m)."""
    rotation_radius: float = 0.05
    """Radius at which a rotation counts as path length (m): about the imaging depth."""
    name: str = "trajectory"
    pattern: dict = field(default_factory=dict)
    """The pattern parameters the path was made from (provenance, not used to run it)."""
    imaging_segments: tuple[tuple[float, float], ...] | None = None
    """Arc-length intervals (m) whose frames are for imaging, in path order; None: all of it.
    An interval of zero length must lie at a stop: the frames taken while the probe rests there."""
    stops: tuple[tuple[float, float], ...] = ()
    """(arc length m, seconds) where the probe comes to rest and stays, in path order; the
    moves between them are timed rest to rest. Empty: one move from end to end."""
    force_profile: tuple[tuple[float, float], ...] | None = None
    """(time s, force N) knots of the force held along the probe axis during the sweep, time
    from the start of the path, linear between knots and held beyond the first and last; it
    must start at `contact_force` (the force of the descent into contact). Per time, not per
    arc length: at a stop the probe presses on one spot while its arc length stands still.
    None: `contact_force` throughout."""

    def __post_init__(self) -> None:
        waypoints = np.asarray(self.waypoints, dtype=np.float64)
        object.__setattr__(self, "waypoints", waypoints)
        if waypoints.ndim != 3 or waypoints.shape[1:] != (4, 4) or len(waypoints) < 2:
            raise ResusError(
                f"Trajectory.waypoints must be at least 2 poses of 4x4, got {waypoints.shape}"
            )
        bad = np.flatnonzero(~is_rigid(waypoints))
        if bad.size:
            raise ResusError(f"Trajectory.waypoints[{bad[0]}] is not a rigid transform")
        for name in ("speed", "acceleration", "frame_rate", "rotation_radius"):
            if not getattr(self, name) > 0:
                raise ResusError(f"Trajectory.{name} must be positive, got {getattr(self, name)}")
        if self.contact_force is not None and not self.contact_force > 0:
            raise ResusError(f"Trajectory.contact_force must be positive, got {self.contact_force}")
        if self.approach_height < 0:
            raise ResusError(f"Trajectory.approach_height must be >= 0, got {self.approach_height}")
        if self.path_length <= 0:
            raise ResusError("Trajectory.waypoints do not move: the path length is zero")
        object.__setattr__(self, "stops", self._checked_stops())
        if self.imaging_segments is not None:
            object.__setattr__(self, "imaging_segments", self._checked_segments())
        if self.force_profile is not None:
            object.__setattr__(self, "force_profile", self._checked_force_profile())
        repeated = np.flatnonzero(self.segment_lengths <= 0)
        if repeated.size:
            raise ResusError(
                f"Trajectory.waypoints[{repeated[0]}] and [{repeated[0] + 1}] coincide"
            )

    def _within_path(self, arc: np.ndarray) -> bool:
        """Whether every arc length lies on the path (to ARC_TOLERANCE)."""
        return bool(np.all((arc >= -ARC_TOLERANCE) & (arc <= self.path_length + ARC_TOLERANCE)))

    def _checked_stops(self) -> tuple[tuple[float, float], ...]:
        stops = _pairs(self.stops, "stops")
        arcs = np.array([arc for arc, _ in stops])
        if stops and (np.any(np.diff(arcs) <= ARC_TOLERANCE) or not self._within_path(arcs)):
            raise ResusError(
                "Trajectory.stops must lie at increasing arc lengths within "
                f"[0, {self.path_length:.4f}] m, got {list(stops)}"
            )
        if any(not seconds > 0 for _, seconds in stops):
            raise ResusError(f"Trajectory.stops must last a positive time (s), got {list(stops)}")
        return tuple((float(np.clip(arc, 0.0, self.path_length)), s) for arc, s in stops)

    def _checked_segments(self) -> tuple[tuple[float, float], ...]:
        segments = _pairs(self.imaging_segments, "imaging_segments")
        bounds = np.array(segments).ravel()
        stop_arcs = np.array([arc for arc, _ in self.stops])
        at_stops = all(b > a or np.any(np.abs(stop_arcs - a) <= ARC_TOLERANCE) for a, b in segments)
        if (
            not segments
            or np.any(bounds[1::2] < bounds[::2])
            or np.any(bounds[2::2] <= bounds[1:-1:2])
            or not self._within_path(bounds)
            or not at_stops
        ):
            raise ResusError(
                "Trajectory.imaging_segments must be increasing, non-overlapping arc-length "
                f"intervals within [0, {self.path_length:.4f}] m, of zero length only at a "
                f"stop, got {list(segments)}"
            )
        return segments

    def _checked_force_profile(self) -> tuple[tuple[float, float], ...]:
        knots = _pairs(self.force_profile, "force_profile")
        if self.contact_force is None:
            raise ResusError("Trajectory.force_profile needs force mode: set contact_force")
        times = np.array([t for t, _ in knots])
        if not knots or times[0] < 0 or np.any(np.diff(times) <= 0):
            raise ResusError(
                "Trajectory.force_profile must be (time s, force N) knots at increasing "
                f"times >= 0, got {list(knots)}"
            )
        if any(not force > 0 for _, force in knots):
            raise ResusError(f"Trajectory.force_profile forces must be positive, got {list(knots)}")
        if abs(knots[0][1] - self.contact_force) > 1e-9:
            raise ResusError(
                f"Trajectory.force_profile starts at {knots[0][1]} N, not at contact_force "
                f"{self.contact_force} N (the force the probe settles at before the path)"
            )
        return knots

    @cached_property
    def segment_lengths(self) -> np.ndarray:
        """Length of each segment: translation, or rotation arc at rotation_radius if longer."""
        translation = np.linalg.norm(np.diff(self.waypoints[:, :3, 3], axis=0), axis=1)
        relative = np.einsum(
            "kji,kjl->kil", self.waypoints[:-1, :3, :3], self.waypoints[1:, :3, :3]
        )
        angles = Rotation.from_matrix(relative).magnitude()
        return np.maximum(translation, angles * self.rotation_radius)

    @cached_property
    def path_length(self) -> float:
        """Total path length (m)."""
        return float(self.segment_lengths.sum())

    @cached_property
    def _phases(self) -> list[tuple[float, float, float, tuple[float, float, float] | None]]:
        """The time law as (start time, start arc, length, move profile) phases in order: a
        rest-to-rest move (`_trapezoid`) between stops, or a stop's rest (profile None, its
        length the rest's duration)."""
        phases: list[tuple[float, float, float, tuple[float, float, float] | None]] = []
        time, arc = 0.0, 0.0
        for stop_arc, seconds in (*self.stops, (self.path_length, 0.0)):
            if stop_arc - arc > ARC_TOLERANCE:
                profile = _trapezoid(stop_arc - arc, self.speed, self.acceleration)
                phases.append((time, arc, stop_arc - arc, profile))
                time += 2 * profile[1] + profile[2]
            arc = stop_arc
            if seconds > 0:
                phases.append((time, arc, seconds, None))
                time += seconds
        return phases

    @property
    def duration(self) -> float:
        """Seconds from rest at the first waypoint to rest at the last, the stops included."""
        start, _, length, profile = self._phases[-1]
        return start + (length if profile is None else 2 * profile[1] + profile[2])

    def arc_length_at(self, t: np.ndarray | float) -> np.ndarray:
        """Distance travelled along the path at time t (clamped to [0, duration])."""
        t = np.clip(np.asarray(t, dtype=np.float64), 0.0, self.duration)
        arc = np.zeros(np.shape(t))
        for start, first_arc, _, profile in self._phases:
            since = t - start
            here = since >= 0
            moved = 0.0 if profile is None else _travelled(since, profile, self.acceleration)
            arc = np.where(here, first_arc + moved, arc)
        return arc

    def stop_times(self) -> np.ndarray:
        """(K, 2) start and end (s) of the rest at each stop."""
        rests = [(start, start + length) for start, _, length, p in self._phases if p is None]
        return np.array(rests, dtype=np.float64).reshape(-1, 2)

    def force_at(self, t: np.ndarray | float) -> np.ndarray:
        """Force-mode setpoint (N) along the probe axis at time t (NaN: position control)."""
        t = np.asarray(t, dtype=np.float64)
        if self.force_profile is None:
            force = np.nan if self.contact_force is None else self.contact_force
            return np.full(np.shape(t), force)
        times, forces = np.array(self.force_profile).T
        return np.interp(t, times, forces)

    @property
    def force_range(self) -> tuple[float, float] | None:
        """Least and greatest set force (N) over the sweep; None for position control."""
        if self.contact_force is None:
            return None
        if self.force_profile is None:
            return self.contact_force, self.contact_force
        forces = [force for _, force in self.force_profile]
        return min(forces), max(forces)

    @property
    def station_segments(self) -> tuple[int, ...]:
        """Indices of the zero-length imaging segments: stations, where the probe rests."""
        return tuple(k for k, (a, b) in enumerate(self.imaging_segments or ()) if b == a)

    def imaging_segment_at(self, t: np.ndarray | float) -> np.ndarray:
        """Index of the imaging segment the path is in at time t, -1 outside every segment."""
        s = self.arc_length_at(t)
        if self.imaging_segments is None:
            return np.zeros(np.shape(s), dtype=np.int64)
        index = np.full(np.shape(s), -1, dtype=np.int64)
        for k, (low, high) in enumerate(self.imaging_segments):
            index[(s >= low - ARC_TOLERANCE) & (s <= high + ARC_TOLERANCE)] = k
        return index

    def pose_at(self, t: float) -> np.ndarray:
        """TCP pose (4x4, base frame) at time t."""
        return self.poses_at(np.array([t]))[0]

    @cached_property
    def _knots(self) -> np.ndarray:
        """Arc length at each waypoint."""
        return np.concatenate([[0.0], np.cumsum(self.segment_lengths)])

    @cached_property
    def _along_path(self) -> PoseInterpolator:
        """TCP pose as a function of arc length."""
        return PoseInterpolator(self._knots, self.waypoints)

    def poses_at(self, times: np.ndarray) -> np.ndarray:
        """TCP poses (T, 4, 4) at each time."""
        return self._along_path(self.arc_length_at(times))

    def approach_pose(self, pose: np.ndarray) -> np.ndarray:
        """`pose` lifted by approach_height against its own z axis (out of the tissue)."""
        lifted = pose.copy()
        lifted[:3, 3] -= self.approach_height * pose[:3, 2]
        return lifted

    def to_yaml(self, path: str | Path) -> None:
        """Write the trajectory file."""
        document = {
            "schema": SCHEMA,
            "name": self.name,
            "speed": self.speed,
            "acceleration": self.acceleration,
            "contact_force": self.contact_force,
            "frame_rate": self.frame_rate,
            "approach_height": self.approach_height,
            "rotation_radius": self.rotation_radius,
            "pattern": self.pattern,
            "imaging_segments": (
                None
                if self.imaging_segments is None
                else [[float(a), float(b)] for a, b in self.imaging_segments]
            ),
            "stops": [[float(a), float(b)] for a, b in self.stops],
            "force_profile": (
                None
                if self.force_profile is None
                else [[float(t), float(f)] for t, f in self.force_profile]
            ),
            "waypoints": [[float(v) for v in pose] for pose in pose_to_ur(self.waypoints)],
        }
        Path(path).write_text(yaml.safe_dump(document, sort_keys=False))

    @classmethod
    def from_yaml(cls, path: str | Path) -> Trajectory:
        """Read a trajectory file; any problem is a ResusError naming the file."""
        path = Path(path)
        document = read_yaml(path, "trajectory", SCHEMA)
        try:
            waypoints = pose_from_ur(np.asarray(document["waypoints"], dtype=np.float64))
            return cls(
                waypoints=waypoints,
                speed=float(document["speed"]),
                acceleration=float(document["acceleration"]),
                contact_force=(
                    None if document["contact_force"] is None else float(document["contact_force"])
                ),
                frame_rate=float(document["frame_rate"]),
                approach_height=float(document["approach_height"]),
                rotation_radius=float(document.get("rotation_radius", 0.05)),
                name=str(document.get("name", path.stem)),
                pattern=dict(document.get("pattern") or {}),
                imaging_segments=document.get("imaging_segments"),
                stops=document.get("stops") or (),
                force_profile=document.get("force_profile"),
            )
        except ResusError as error:
            raise ResusError(str(error), path) from None
        except (KeyError, TypeError, ValueError) as error:
            reason = f"bad trajectory field ({type(error).__name__}: {error})"
            raise ResusError(reason, path) from None
