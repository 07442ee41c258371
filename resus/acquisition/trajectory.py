"""A scan trajectory: a TCP path through waypoints, timed by a trapezoidal speed profile.

The path runs through `waypoints` (4x4 TCP poses in the robot base frame), linearly in
position and by slerp in rotation. Its length counts a rotation as the arc that a point at
`rotation_radius` below the probe face sweeps, so a fan (pure rocking) has a length and a speed
too. The time law accelerates at `acceleration` to `speed`, cruises, and decelerates to rest.
Saved as YAML (schema `resus.trajectory/1`) with poses as UR `[x, y, z, rx, ry, rz]`, so the
same file runs in simulation, on the emulator and on a real robot. `imaging_segments` marks the
stretches of path whose frames are meant for the volume (a raster's passes, not its U-turns);
frames elsewhere are recorded but may be discarded.
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
    """Arc-length intervals (m) whose frames are for imaging, in path order; None: all of it."""

    def __post_init__(self) -> None:
        waypoints = np.asarray(self.waypoints, dtype=np.float64)
        object.__setattr__(self, "waypoints", waypoints)
        if waypoints.ndim != 3 or waypoints.shape[1:] != (4, 4) or len(waypoints) < 2:
            raise ResusError(f"trajectory needs at least 2 waypoints of 4x4, got {waypoints.shape}")
        bad = np.flatnonzero(~is_rigid(waypoints))
        if bad.size:
            raise ResusError(f"trajectory waypoint {bad[0]} is not a rigid transform")
        for name in ("speed", "acceleration", "frame_rate", "rotation_radius"):
            if not getattr(self, name) > 0:
                raise ResusError(f"trajectory {name} must be positive, got {getattr(self, name)}")
        if self.contact_force is not None and not self.contact_force > 0:
            raise ResusError(f"trajectory contact_force must be positive, got {self.contact_force}")
        if self.approach_height < 0:
            raise ResusError(f"trajectory approach_height must be >= 0, got {self.approach_height}")
        if self.path_length <= 0:
            raise ResusError("trajectory waypoints do not move: path length is zero")
        if self.imaging_segments is not None:
            segments = tuple((float(a), float(b)) for a, b in self.imaging_segments)
            bounds = np.array(segments).ravel()
            tolerance = 1e-9 + 1e-9 * self.path_length
            if (
                not segments
                or np.any(np.diff(bounds) <= 0)
                or bounds[0] < -tolerance
                or bounds[-1] > self.path_length + tolerance
            ):
                raise ResusError(
                    "trajectory imaging_segments must be increasing, non-overlapping arc-length "
                    f"intervals within [0, {self.path_length:.4f}] m, got {list(segments)}"
                )
            object.__setattr__(self, "imaging_segments", segments)
        repeated = np.flatnonzero(self.segment_lengths <= 0)
        if repeated.size:
            raise ResusError(f"trajectory waypoints {repeated[0]} and {repeated[0] + 1} coincide")

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
    def _profile(self) -> tuple[float, float, float]:
        """(peak speed, ramp time, cruise time) of the trapezoidal (or triangular) time law."""
        length, speed, accel = self.path_length, self.speed, self.acceleration
        if speed * speed / accel >= length:  # never reaches cruise speed: triangle
            peak = float(np.sqrt(length * accel))
            return peak, peak / accel, 0.0
        ramp = speed / accel
        return speed, ramp, (length - speed * ramp) / speed

    @property
    def duration(self) -> float:
        """Seconds from rest at the first waypoint to rest at the last."""
        _, ramp, cruise = self._profile
        return 2 * ramp + cruise

    def arc_length_at(self, t: np.ndarray | float) -> np.ndarray:
        """Distance travelled along the path at time t (clamped to [0, duration])."""
        peak, ramp, cruise = self._profile
        t = np.clip(np.asarray(t, dtype=np.float64), 0.0, self.duration)
        accel = self.acceleration
        rising = 0.5 * accel * np.minimum(t, ramp) ** 2
        cruising = peak * np.clip(t - ramp, 0.0, cruise)
        falling_t = np.clip(t - ramp - cruise, 0.0, ramp)
        falling = peak * falling_t - 0.5 * accel * falling_t**2
        return rising + cruising + falling

    def imaging_segment_at(self, t: np.ndarray | float) -> np.ndarray:
        """Index of the imaging segment the path is in at time t, -1 outside every segment."""
        s = self.arc_length_at(t)
        if self.imaging_segments is None:
            return np.zeros(np.shape(s), dtype=np.int64)
        index = np.full(np.shape(s), -1, dtype=np.int64)
        for k, (low, high) in enumerate(self.imaging_segments):
            index[(s >= low) & (s <= high)] = k
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
            )
        except ResusError as error:
            raise ResusError(str(error), path) from None
        except (KeyError, TypeError, ValueError) as error:
            reason = f"bad trajectory field ({type(error).__name__}: {error})"
            raise ResusError(reason, path) from None
