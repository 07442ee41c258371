"""Scan patterns: trajectories made from a few intuitive parameters over a phantom.

Parameters are given in the phantom frame (origin at the centre of the skin surface, +z out
of the skin, +y distal along the leg, +x the patient's right); the trajectory comes out in
the robot base frame through the scene's `phantom_to_base`. Every pattern projects its path
onto the skin with the probe normal to it, so it follows a curved (leg) surface too.

Each pattern is a frozen dataclass of its parameters (checked on creation, defaults stated
once) whose `trajectory(phantom, phantom_to_base)` makes the path; `linear_sweep` and its
siblings are the same as one call.

- `LinearPattern`: one straight sweep at a fixed tilt (the paper's scan).
- `FanPattern`: the probe stays on one spot and rocks about its array axis.
- `MultipassPattern`: parallel sweeps in one direction, side by side; the moves back to the
  next pass's start stay on the skin and are not imaging segments.
- `RasterPattern`: a zig-zag whose passes alternate direction, joined by U-turns on the skin
  (no lift, the probe keeps its orientation); the U-turns are not imaging segments.
- `CompressionPattern`: stations along the vessels where the probe, transverse to them, presses
  from light contact to a target force and releases (force mode, imaging), sliding on at light
  contact to the next; each station is a stop and a zero-length imaging segment.
"""

from __future__ import annotations

import dataclasses
import itertools
from dataclasses import dataclass
from typing import ClassVar

import numpy as np
from scipy.spatial.transform import Rotation

from resus.acquisition.safety import SafetyLimits
from resus.acquisition.trajectory import Trajectory
from resus.errors import ResusError
from sim.phantom import Phantom
from sim.transforms import make_pose

WAYPOINT_SPACING = 0.005
"""Distance between waypoints along a pattern (m): fine enough to follow a curved skin."""
FAN_STEP_DEG = 1.0
"""Angle between a fan's waypoints (deg)."""
PRESS_FORCE_MARGIN = 0.8
"""A compression's press force may reach this fraction of the scanner's force limit: the
admittance loop overshoots the setpoint while it rises, and the limit stops the scan."""


def probe_orientation(skin_normal: np.ndarray, direction: np.ndarray, tilt: float) -> np.ndarray:
    """Probe rotation (3x3, phantom frame) normal to the skin, array across the sweep.

    The probe's z points into the tissue (-normal), its x (the array) is `direction` x normal
    so the image is a transverse cut of vessels running along `direction`, and `tilt`
    (radians) rocks the probe about its array axis so the image leans along the sweep.
    """
    z_axis = -skin_normal / np.linalg.norm(skin_normal)
    x_axis = np.cross(direction, skin_normal)
    norm = np.linalg.norm(x_axis)
    if norm < 1e-9:
        raise ResusError("sweep direction must not be along the skin normal")
    x_axis /= norm
    y_axis = np.cross(z_axis, x_axis)
    upright = np.column_stack([x_axis, y_axis, z_axis])
    return upright @ Rotation.from_rotvec([tilt, 0.0, 0.0]).as_matrix()


def sweep_heading(direction: tuple[float, float]) -> np.ndarray:
    """Unit (x, y, 0) heading in the phantom frame from a 2D direction."""
    heading = np.array([direction[0], direction[1], 0.0], dtype=np.float64)
    if not (np.all(np.isfinite(heading)) and np.linalg.norm(heading) > 0):
        raise ResusError(f"the sweep direction must be a non-zero (x, y) vector, got {direction}")
    return heading / np.linalg.norm(heading)


def lateral_of(heading: np.ndarray) -> np.ndarray:
    """The in-skin direction of the probe's array on flat skin: heading x up."""
    return np.array([heading[1], -heading[0], 0.0])


def skin_poses(
    phantom: Phantom,
    phantom_to_base: np.ndarray,
    xy: np.ndarray,
    heading: np.ndarray,
    tilts: np.ndarray,
) -> np.ndarray:
    """Base-frame TCP poses (N, 4, 4) on the skin above phantom points `xy` (N, 2).

    The probe is normal to the skin, its array across `heading`, rocked by `tilts` (N,) rad.
    """
    x, y = xy[:, 0], xy[:, 1]
    z = phantom.skin_height(x, y)
    if not np.all(np.isfinite(z)):
        outside = xy[int(np.flatnonzero(~np.isfinite(z))[0])]
        raise ResusError(
            f"the path leaves the phantom's skin at ({outside[0]:.3f}, {outside[1]:.3f}) m: "
            "change the pattern's start, direction or length"
        )
    normals = phantom.skin_normal(x, y)
    return np.stack(
        [
            phantom_to_base @ make_pose(probe_orientation(n, heading, tilt), np.array([xi, yi, zi]))
            for xi, yi, zi, n, tilt in zip(x, y, z, normals, tilts, strict=True)
        ]
    )


def _straight(start: np.ndarray, end: np.ndarray) -> np.ndarray:
    """Points (N, 2) from start to end, at most WAYPOINT_SPACING apart."""
    count = max(2, int(np.ceil(np.linalg.norm(end - start) / WAYPOINT_SPACING)) + 1)
    return start + np.linspace(0.0, 1.0, count)[:, None] * (end - start)


def _u_turn(start: np.ndarray, end: np.ndarray, heading: np.ndarray) -> np.ndarray:
    """Half circle (N, 2) from start to end bulging along `heading` (start and end included)."""
    centre, radius_vector = 0.5 * (start + end), 0.5 * (start - end)
    radius = float(np.linalg.norm(radius_vector))
    count = max(3, int(np.ceil(np.pi * radius / WAYPOINT_SPACING)) + 1)
    angles = np.linspace(0.0, np.pi, count)[:, None]
    return centre + np.cos(angles) * radius_vector + np.sin(angles) * radius * heading[:2]


@dataclass(frozen=True)
class SweepPattern:
    """What every pattern shares: where it starts on the skin (x, y in the phantom frame, m),
    the sweep direction (x, y), the probe's speed (m/s) and acceleration (m/s^2), the contact
    force (N; None for position control), the frame rate (1/s) and the tilt about the array
    axis (deg). Each subclass's defaults are the one place its sweep defaults live."""

    start: tuple[float, float] = (0.0, -0.04)
    direction: tuple[float, float] = (0.0, 1.0)
    speed: float = 0.01
    contact_force: float | None = 4.0
    frame_rate: float = 30.0
    tilt_deg: float = 0.0
    acceleration: float = 0.05

    name: ClassVar[str] = ""

    def __post_init__(self) -> None:
        self._require_positive("speed", "acceleration", "frame_rate")
        if self.contact_force is not None and not self.contact_force > 0:
            raise ResusError(
                f"{type(self).__name__}.contact_force must be positive or None, "
                f"got {self.contact_force}"
            )
        sweep_heading(self.direction)

    def _require_positive(self, *fields: str) -> None:
        """Raise naming `Pattern.field` and its value for the first of `fields` that is not a
        finite number above 0 (NaN and inf fail too)."""
        for field in fields:
            value = getattr(self, field)
            if not (np.isfinite(value) and value > 0):
                raise ResusError(f"{type(self).__name__}.{field} must be positive, got {value}")

    def _require_at_least(self, field: str, lowest: int) -> None:
        """Raise naming `Pattern.field` and its value if that count is below `lowest`."""
        value = getattr(self, field)
        if value < lowest:
            raise ResusError(
                f"{type(self).__name__}.{field} must be at least {lowest}, got {value}"
            )

    @property
    def heading(self) -> np.ndarray:
        """Unit (x, y, 0) sweep direction in the phantom frame."""
        return sweep_heading(self.direction)

    def _trajectory(self, waypoints: np.ndarray, **shape: float | int) -> Trajectory:
        """The trajectory through `waypoints` with this pattern's motion settings, recording
        the pattern's name, start, direction, tilt and `shape` parameters."""
        return Trajectory(
            waypoints=waypoints,
            speed=self.speed,
            acceleration=self.acceleration,
            contact_force=self.contact_force,
            frame_rate=self.frame_rate,
            name=self.name,
            pattern={
                "pattern": self.name,
                "start": [float(v) for v in self.start],
                "direction": [float(v) for v in self.heading[:2]],
                **shape,
                "tilt_deg": float(self.tilt_deg),
            },
        )

    def trajectory(self, phantom: Phantom, phantom_to_base: np.ndarray) -> Trajectory:
        """The pattern over `phantom`, in the base frame through `phantom_to_base`."""
        raise NotImplementedError


@dataclass(frozen=True)
class LinearPattern(SweepPattern):
    """The paper's scan: a straight sweep of `length` m along the skin, probe normal to it,
    at one tilt. The path follows the skin height, so it works over a curved leg too."""

    length: float = 0.08
    name: ClassVar[str] = "linear"

    def __post_init__(self) -> None:
        super().__post_init__()
        if not (np.isfinite(self.length) and self.length > 0):
            raise ResusError(f"LinearPattern.length must be positive, got {self.length}")

    @property
    def middle(self) -> np.ndarray:
        """(x, y) of the sweep's midpoint on the phantom's top plane (m)."""
        return np.asarray(self.start, dtype=np.float64) + self.length / 2 * self.heading[:2]

    def trajectory(self, phantom: Phantom, phantom_to_base: np.ndarray) -> Trajectory:
        start = np.asarray(self.start, dtype=np.float64)
        xy = _straight(start, start + self.length * self.heading[:2])
        tilts = np.full(len(xy), np.radians(self.tilt_deg))
        waypoints = skin_poses(phantom, phantom_to_base, xy, self.heading, tilts)
        return self._trajectory(waypoints, length=float(self.length))


@dataclass(frozen=True)
class FanPattern(SweepPattern):
    """The probe stays at `start` and rocks about its array axis through `fan_deg`.

    The beam leans from `tilt_deg - fan_deg / 2` to `tilt_deg + fan_deg / 2` towards
    `direction`; `speed` is the speed of the image's deepest point (the trajectory's
    rotation radius), so frame spacing at depth is speed / frame rate as for a linear sweep.
    """

    start: tuple[float, float] = (0.0, 0.0)
    fan_deg: float = 40.0
    name: ClassVar[str] = "fan"

    def __post_init__(self) -> None:
        super().__post_init__()
        if not 0 < self.fan_deg < 180:
            raise ResusError(f"FanPattern.fan_deg must lie in (0, 180) degrees, got {self.fan_deg}")

    def trajectory(self, phantom: Phantom, phantom_to_base: np.ndarray) -> Trajectory:
        count = max(2, int(np.ceil(self.fan_deg / FAN_STEP_DEG)) + 1)
        half = 0.5 * self.fan_deg
        tilts = np.radians(self.tilt_deg + np.linspace(-half, half, count))
        xy = np.repeat(np.asarray(self.start, dtype=np.float64)[None], count, axis=0)
        waypoints = skin_poses(phantom, phantom_to_base, xy, self.heading, tilts)
        return self._trajectory(waypoints, fan_deg=float(self.fan_deg))


@dataclass(frozen=True)
class MultipassPattern(LinearPattern):
    """`passes` parallel sweeps in the same direction, each `offset` m further along the
    probe's array (phantom +x for a +y sweep); the returns between them are transit."""

    start: tuple[float, float] = (-0.01, -0.04)
    passes: int = 2
    offset: float = 0.02
    name: ClassVar[str] = "multipass"

    def __post_init__(self) -> None:
        super().__post_init__()
        self._require_at_least("passes", 1)
        if self.passes > 1 and not (np.isfinite(self.offset) and self.offset != 0):
            raise ResusError(
                f"{type(self).__name__}.offset must be a non-zero distance (m) between passes, "
                f"got {self.offset}"
            )

    def pieces(self) -> list[tuple[np.ndarray, bool]]:
        """The path as polylines (N, 2) in the phantom frame, each flagged True if imaging."""
        step, along = self.offset * lateral_of(self.heading)[:2], self.length * self.heading[:2]
        first = np.asarray(self.start, dtype=np.float64)
        pieces: list[tuple[np.ndarray, bool]] = []
        for k in range(self.passes):
            if k:
                pieces.append((_straight(first + (k - 1) * step + along, first + k * step), False))
            pieces.append((_straight(first + k * step, first + k * step + along), True))
        return pieces

    def trajectory(self, phantom: Phantom, phantom_to_base: np.ndarray) -> Trajectory:
        points: list[np.ndarray] = []
        spans = []
        for piece, imaging in self.pieces():
            first = len(points) - 1 if points else 0
            points.extend(piece[1:] if points else piece)
            if imaging:
                spans.append((first, len(points) - 1))
        xy = np.array(points)
        tilts = np.full(len(xy), np.radians(self.tilt_deg))
        waypoints = skin_poses(phantom, phantom_to_base, xy, self.heading, tilts)
        trajectory = self._trajectory(
            waypoints, length=float(self.length), passes=int(self.passes), offset=float(self.offset)
        )
        knots = np.concatenate([[0.0], np.cumsum(trajectory.segment_lengths)])
        segments = tuple((float(knots[a]), float(knots[b])) for a, b in spans)
        return dataclasses.replace(trajectory, imaging_segments=segments)


@dataclass(frozen=True)
class RasterPattern(MultipassPattern):
    """A zig-zag: passes alternate direction, `offset` m apart along the probe's array, joined
    by half-circle U-turns on the skin beyond each pass's end. The probe keeps its orientation
    throughout (every frame is parallel), so the U-turns need no wrist rotation; they are
    marked as non-imaging so their frames can be discarded."""

    name: ClassVar[str] = "raster"

    def pieces(self) -> list[tuple[np.ndarray, bool]]:
        step, along = self.offset * lateral_of(self.heading)[:2], self.length * self.heading[:2]
        first = np.asarray(self.start, dtype=np.float64)
        pieces: list[tuple[np.ndarray, bool]] = []
        for k in range(self.passes):
            forward = k % 2 == 0
            begin = first + k * step + (0.0 if forward else 1.0) * along
            end = first + k * step + (1.0 if forward else 0.0) * along
            if k:
                bulge = self.heading if not forward else -self.heading
                pieces.append((_u_turn(begin - step, begin, bulge), False))
            pieces.append((_straight(begin, end), True))
        return pieces


@dataclass(frozen=True)
class CompressionPattern(SweepPattern):
    """Presses at `stations` points along the vessels, `station_spacing` m apart from `start`
    along `direction` (the vessels' course), the probe's array across it (transverse images).

    At each station, in force mode and imaging throughout: `light_time` s at light contact
    (`contact_force`), a linear rise to `press_force` over `press_time` s, `hold_time` s at
    it, a linear fall back over `press_time` s and `light_time` s more at light contact. The
    probe slides on to the next station at light contact and `speed`; those transit frames are
    not imaging segments. The press force stays within PRESS_FORCE_MARGIN of the scanner's
    default force limit (20 N)."""

    start: tuple[float, float] = (0.0, -0.03)
    contact_force: float | None = 2.0
    stations: int = 3
    station_spacing: float = 0.03
    press_force: float = 12.0
    press_time: float = 2.0
    hold_time: float = 1.0
    light_time: float = 1.0
    name: ClassVar[str] = "compression"

    def __post_init__(self) -> None:
        super().__post_init__()
        kind = type(self).__name__
        if self.contact_force is None:
            raise ResusError(f"{kind}.contact_force must be set: the press runs in force mode")
        self._require_at_least("stations", 2)
        self._require_positive("station_spacing", "press_time")
        for field in ("hold_time", "light_time"):
            value = getattr(self, field)
            if not (np.isfinite(value) and value >= 0):
                raise ResusError(f"{kind}.{field} must be >= 0, got {value}")
        highest = PRESS_FORCE_MARGIN * SafetyLimits().max_force
        if not self.contact_force < self.press_force <= highest:
            raise ResusError(
                f"{kind}.press_force must lie above the light contact force "
                f"({self.contact_force} N) and at most {highest:g} N "
                f"({PRESS_FORCE_MARGIN:.0%} of the scanner's force limit), got {self.press_force}"
            )

    @property
    def station_points(self) -> np.ndarray:
        """(stations, 2) phantom-frame (x, y) of each station."""
        steps = np.arange(self.stations)[:, None] * self.station_spacing
        return np.asarray(self.start, dtype=np.float64) + steps * self.heading[:2]

    def press_knots(self, start: float) -> list[tuple[float, float]]:
        """(time s, force N) knots of one station's press beginning at `start` (s)."""
        light, press = float(self.contact_force or 0.0), self.press_force
        times = np.cumsum([start, self.light_time, self.press_time, self.hold_time,
                           self.press_time, self.light_time])  # fmt: skip
        forces = [light, light, press, press, light, light]
        knots = [(float(t), f) for t, f in zip(times, forces, strict=True)]
        return [knot for k, knot in enumerate(knots) if k == 0 or knot[0] > knots[k - 1][0]]

    @property
    def station_time(self) -> float:
        """Seconds the probe rests at each station."""
        return 2 * (self.light_time + self.press_time) + self.hold_time

    def trajectory(self, phantom: Phantom, phantom_to_base: np.ndarray) -> Trajectory:
        points = self.station_points
        pieces = [_straight(a, b) for a, b in itertools.pairwise(points)]
        xy = np.concatenate([pieces[0], *(piece[1:] for piece in pieces[1:])])
        tilts = np.full(len(xy), np.radians(self.tilt_deg))
        waypoints = skin_poses(phantom, phantom_to_base, xy, self.heading, tilts)
        trajectory = self._trajectory(
            waypoints, stations=int(self.stations), station_spacing=float(self.station_spacing),
            press_force=float(self.press_force), press_time=float(self.press_time),
            hold_time=float(self.hold_time), light_time=float(self.light_time),
        )  # fmt: skip
        knots = np.concatenate([[0.0], np.cumsum(trajectory.segment_lengths)])
        arcs = knots[np.cumsum([0, *(len(piece) - 1 for piece in pieces)])]
        stopped = dataclasses.replace(
            trajectory,
            stops=tuple((float(arc), self.station_time) for arc in arcs),
            imaging_segments=tuple((float(arc), float(arc)) for arc in arcs),
        )
        profile = [knot for start, _ in stopped.stop_times() for knot in self.press_knots(start)]
        return dataclasses.replace(stopped, force_profile=tuple(profile))


PATTERNS: dict[str, type[SweepPattern]] = {
    pattern.name: pattern
    for pattern in (LinearPattern, FanPattern, MultipassPattern, RasterPattern, CompressionPattern)
}
"""Every pattern by its name, as `resus plan --pattern` and the trajectory files call it."""


def linear_sweep(phantom: Phantom, phantom_to_base: np.ndarray, **parameters) -> Trajectory:
    """`LinearPattern(**parameters)` over `phantom`."""
    return LinearPattern(**parameters).trajectory(phantom, phantom_to_base)


def fan_sweep(phantom: Phantom, phantom_to_base: np.ndarray, **parameters) -> Trajectory:
    """`FanPattern(**parameters)` over `phantom`."""
    return FanPattern(**parameters).trajectory(phantom, phantom_to_base)


def multipass_sweep(phantom: Phantom, phantom_to_base: np.ndarray, **parameters) -> Trajectory:
    """`MultipassPattern(**parameters)` over `phantom`."""
    return MultipassPattern(**parameters).trajectory(phantom, phantom_to_base)


def raster_sweep(phantom: Phantom, phantom_to_base: np.ndarray, **parameters) -> Trajectory:
    """`RasterPattern(**parameters)` over `phantom`."""
    return RasterPattern(**parameters).trajectory(phantom, phantom_to_base)


def compression_sweep(phantom: Phantom, phantom_to_base: np.ndarray, **parameters) -> Trajectory:
    """`CompressionPattern(**parameters)` over `phantom`."""
    return CompressionPattern(**parameters).trajectory(phantom, phantom_to_base)
