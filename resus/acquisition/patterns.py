"""Scan patterns: trajectories made from a few intuitive parameters over a phantom.

Parameters are given in the phantom frame (origin at the centre of the skin surface, +z out
of the skin, +y distal along the leg, +x the patient's right); the trajectory comes out in
the robot base frame through the scene's `phantom_to_base`. Every pattern projects its path
onto the skin with the probe normal to it, so it follows a curved (leg) surface too.

- `linear_sweep`: one straight sweep at a fixed tilt (the paper's scan).
- `fan_sweep`: the probe stays on one spot and rocks about its array axis.
- `multipass_sweep`: parallel sweeps in one direction, side by side; the moves back to the
  next pass's start stay on the skin and are not imaging segments.
- `raster_sweep`: a zig-zag whose passes alternate direction, joined by U-turns on the skin
  (no lift, the probe keeps its orientation); the U-turns are not imaging segments.
"""

from __future__ import annotations

import dataclasses

import numpy as np
from scipy.spatial.transform import Rotation

from resus.acquisition.trajectory import Trajectory
from resus.errors import ResusError
from sim.phantom import Phantom
from sim.transforms import make_pose

WAYPOINT_SPACING = 0.005
"""Distance between waypoints along a pattern (m): fine enough to follow a curved skin."""
FAN_STEP_DEG = 1.0
"""Angle between a fan's waypoints (deg)."""


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
        raise ResusError(f"--direction must be a non-zero (x, y) vector, got {direction}")
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
            "change --start, --direction or --length"
        )
    normals = phantom.skin_normal(x, y)
    return np.stack(
        [
            phantom_to_base @ make_pose(probe_orientation(n, heading, tilt), [xi, yi, zi])
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


def _check_sweep_parameters(length: float, speed: float, acceleration: float) -> None:
    if not length > 0:
        raise ResusError(f"--length must be positive, got {length}")
    if not speed > 0:
        raise ResusError(f"--speed must be positive, got {speed}")
    if not acceleration > 0:
        raise ResusError(f"--acceleration must be positive, got {acceleration}")


def _check_passes(passes: int, offset: float) -> None:
    if passes < 1:
        raise ResusError(f"--passes must be at least 1, got {passes}")
    if passes > 1 and not (np.isfinite(offset) and offset != 0):
        raise ResusError(f"--offset must be a non-zero distance (m) between passes, got {offset}")


def _pieced_trajectory(
    phantom: Phantom,
    phantom_to_base: np.ndarray,
    pieces: list[tuple[np.ndarray, bool]],
    heading: np.ndarray,
    tilt: float,
    settings: dict,
) -> Trajectory:
    """A trajectory through consecutive polylines; those flagged True are imaging segments."""
    points, spans = [], []
    for piece, imaging in pieces:
        first = len(points) - 1 if points else 0
        points.extend(piece[1:] if points else piece)
        if imaging:
            spans.append((first, len(points) - 1))
    xy = np.array(points)
    waypoints = skin_poses(phantom, phantom_to_base, xy, heading, np.full(len(xy), tilt))
    trajectory = Trajectory(waypoints=waypoints, **settings)
    knots = np.concatenate([[0.0], np.cumsum(trajectory.segment_lengths)])
    segments = tuple((float(knots[a]), float(knots[b])) for a, b in spans)
    return dataclasses.replace(trajectory, imaging_segments=segments)


def linear_sweep(
    phantom: Phantom,
    phantom_to_base: np.ndarray,
    *,
    start: tuple[float, float] = (0.0, -0.04),
    direction: tuple[float, float] = (0.0, 1.0),
    length: float = 0.08,
    speed: float = 0.01,
    contact_force: float | None = 4.0,
    frame_rate: float = 30.0,
    tilt_deg: float = 0.0,
    acceleration: float = 0.05,
) -> Trajectory:
    """The paper's scan: a straight sweep along the skin, probe normal to it, at one tilt.

    `start` and `direction` are (x, y) in the phantom frame; the path follows the skin height
    under it, so it also works over a curved (leg-like) surface.
    """
    _check_sweep_parameters(length, speed, acceleration)
    heading = sweep_heading(direction)
    xy = _straight(np.asarray(start, dtype=np.float64), np.asarray(start) + length * heading[:2])
    tilt = np.radians(tilt_deg)
    return Trajectory(
        waypoints=skin_poses(phantom, phantom_to_base, xy, heading, np.full(len(xy), tilt)),
        speed=speed,
        acceleration=acceleration,
        contact_force=contact_force,
        frame_rate=frame_rate,
        name="linear",
        pattern={
            "pattern": "linear",
            "start": [float(v) for v in start],
            "direction": [float(v) for v in heading[:2]],
            "length": float(length),
            "tilt_deg": float(tilt_deg),
        },
    )


def fan_sweep(
    phantom: Phantom,
    phantom_to_base: np.ndarray,
    *,
    start: tuple[float, float] = (0.0, 0.0),
    direction: tuple[float, float] = (0.0, 1.0),
    fan_deg: float = 40.0,
    speed: float = 0.01,
    contact_force: float | None = 4.0,
    frame_rate: float = 30.0,
    tilt_deg: float = 0.0,
    acceleration: float = 0.05,
) -> Trajectory:
    """The probe stays at `start` and rocks about its array axis through `fan_deg`.

    The beam leans from `tilt_deg - fan_deg / 2` to `tilt_deg + fan_deg / 2` towards
    `direction`; `speed` is the speed of the image's deepest point (the trajectory's
    rotation radius), so frame spacing at depth is speed / frame rate as for a linear sweep.
    """
    if not 0 < fan_deg < 180:
        raise ResusError(f"--fan-angle must lie in (0, 180) degrees, got {fan_deg}")
    _check_sweep_parameters(1.0, speed, acceleration)
    heading = sweep_heading(direction)
    count = max(2, int(np.ceil(fan_deg / FAN_STEP_DEG)) + 1)
    tilts = np.radians(tilt_deg + np.linspace(-0.5 * fan_deg, 0.5 * fan_deg, count))
    xy = np.repeat(np.asarray(start, dtype=np.float64)[None], count, axis=0)
    return Trajectory(
        waypoints=skin_poses(phantom, phantom_to_base, xy, heading, tilts),
        speed=speed,
        acceleration=acceleration,
        contact_force=contact_force,
        frame_rate=frame_rate,
        name="fan",
        pattern={
            "pattern": "fan",
            "start": [float(v) for v in start],
            "direction": [float(v) for v in heading[:2]],
            "fan_deg": float(fan_deg),
            "tilt_deg": float(tilt_deg),
        },
    )


def multipass_sweep(
    phantom: Phantom,
    phantom_to_base: np.ndarray,
    *,
    start: tuple[float, float] = (-0.01, -0.04),
    direction: tuple[float, float] = (0.0, 1.0),
    length: float = 0.08,
    passes: int = 2,
    offset: float = 0.02,
    speed: float = 0.01,
    contact_force: float | None = 4.0,
    frame_rate: float = 30.0,
    tilt_deg: float = 0.0,
    acceleration: float = 0.05,
) -> Trajectory:
    """`passes` parallel sweeps in the same direction, each `offset` m further along the
    probe's array (phantom +x for a +y sweep); the returns between them are transit."""
    _check_sweep_parameters(length, speed, acceleration)
    _check_passes(passes, offset)
    heading = sweep_heading(direction)
    step, along = offset * lateral_of(heading)[:2], length * heading[:2]
    first = np.asarray(start, dtype=np.float64)
    pieces: list[tuple[np.ndarray, bool]] = []
    for k in range(passes):
        if k:
            pieces.append((_straight(first + (k - 1) * step + along, first + k * step), False))
        pieces.append((_straight(first + k * step, first + k * step + along), True))
    settings = _settings("multipass", speed, acceleration, contact_force, frame_rate)
    settings["pattern"] = {
        "pattern": "multipass",
        "start": [float(v) for v in start],
        "direction": [float(v) for v in heading[:2]],
        "length": float(length),
        "passes": int(passes),
        "offset": float(offset),
        "tilt_deg": float(tilt_deg),
    }
    return _pieced_trajectory(
        phantom, phantom_to_base, pieces, heading, np.radians(tilt_deg), settings
    )


def raster_sweep(
    phantom: Phantom,
    phantom_to_base: np.ndarray,
    *,
    start: tuple[float, float] = (-0.01, -0.04),
    direction: tuple[float, float] = (0.0, 1.0),
    length: float = 0.08,
    passes: int = 2,
    offset: float = 0.02,
    speed: float = 0.01,
    contact_force: float | None = 4.0,
    frame_rate: float = 30.0,
    tilt_deg: float = 0.0,
    acceleration: float = 0.05,
) -> Trajectory:
    """A zig-zag: passes alternate direction, `offset` m apart along the probe's array, joined
    by half-circle U-turns on the skin beyond each pass's end. The probe keeps its orientation
    throughout (every frame is parallel), so the U-turns need no wrist rotation; they are
    marked as non-imaging so their frames can be discarded."""
    _check_sweep_parameters(length, speed, acceleration)
    _check_passes(passes, offset)
    heading = sweep_heading(direction)
    step, along = offset * lateral_of(heading)[:2], length * heading[:2]
    first = np.asarray(start, dtype=np.float64)
    pieces: list[tuple[np.ndarray, bool]] = []
    for k in range(passes):
        forward = k % 2 == 0
        begin = first + k * step + (0.0 if forward else 1.0) * along
        end = first + k * step + (1.0 if forward else 0.0) * along
        if k:
            bulge = heading if not forward else -heading
            pieces.append((_u_turn(begin - step, begin, bulge), False))
        pieces.append((_straight(begin, end), True))
    settings = _settings("raster", speed, acceleration, contact_force, frame_rate)
    settings["pattern"] = {
        "pattern": "raster",
        "start": [float(v) for v in start],
        "direction": [float(v) for v in heading[:2]],
        "length": float(length),
        "passes": int(passes),
        "offset": float(offset),
        "tilt_deg": float(tilt_deg),
    }
    return _pieced_trajectory(
        phantom, phantom_to_base, pieces, heading, np.radians(tilt_deg), settings
    )


def _settings(
    name: str, speed: float, acceleration: float, contact_force: float | None, frame_rate: float
) -> dict:
    return {
        "name": name,
        "speed": speed,
        "acceleration": acceleration,
        "contact_force": contact_force,
        "frame_rate": frame_rate,
    }
