"""Checks of the scan as imaging: safety limits, frame spacing, and stretches where the image
plane stands still or moves backwards (the paper lost animals' data to both).

Frame geometry is the probe's image rectangle at each frame pose; spacing is the largest
distance any of its four corners moves from one frame to the next, so rocking counts at depth.
"""

from __future__ import annotations

import numpy as np

from resus.acquisition.safety import SafetyLimits
from resus.acquisition.trajectory import Trajectory
from resus.planning.checks import CheckResult, place_at
from resus.planning.sampling import FrameSamples, PathSamples
from resus.reconstruction.grid import frame_corner_pixels, frame_points_world
from sim.ultrasound.probe import LinearProbe

STATIONARY_TIME = 1.0
"""A stretch this long (s) in which the image plane advances less than STATIONARY_ADVANCE
voxels counts as standing still."""
STATIONARY_ADVANCE = 0.5
BACKTRACK_TOLERANCE = 1e-5
"""Backward motion of the image plane (m per frame) tolerated as rounding."""
SPACING_MARGIN = 0.95
"""Advice aims this fraction of the voxel size."""


def check_safety(trajectory: Trajectory, samples: PathSamples, limits: SafetyLimits) -> CheckResult:
    """The scanner's own limits (workspace box, TCP speed, force) hold for the whole plan."""
    approach = np.stack([trajectory.approach_pose(p) for p in samples.poses[[0, -1]]])
    forces = trajectory.force_range
    reasons = limits.plan_violations(
        np.concatenate([approach, samples.poses]),
        trajectory.speed,
        None if forces is None else forces[1],
    )
    if not reasons:
        return CheckResult(
            "safety limits", True, "inside the workspace box, speed and force limits"
        )
    place = None
    for index, pose in enumerate(samples.poses):
        if limits.position_violation(pose[:3, 3]) is not None:
            place = place_at(trajectory, samples.times[index])
            break
    return CheckResult(
        "safety limits",
        False,
        "; ".join(reasons),
        place,
        f"keep the speed <= {limits.max_speed} m/s, the contact force <= {limits.max_force} N "
        "and the path "
        "inside the workspace box",
    )


def frame_corners(frames: FrameSamples, probe: LinearProbe) -> np.ndarray:
    """World positions (N, 4, 3) of each frame's four corner pixels."""
    pixels = frame_corner_pixels(probe.rows, probe.cols)
    return frame_points_world(frames.poses, probe.image_to_probe(), pixels)


def frame_spacing(frames: FrameSamples, probe: LinearProbe) -> np.ndarray:
    """(N - 1,) largest corner displacement from frame i to i + 1; NaN across segments."""
    corners = frame_corners(frames, probe)
    spacing = np.linalg.norm(np.diff(corners, axis=0), axis=2).max(axis=1)
    same = (frames.segment[1:] == frames.segment[:-1]) & (frames.segment[1:] >= 0)
    return np.where(same, spacing, np.nan)


def check_frame_spacing(
    trajectory: Trajectory, frames: FrameSamples, probe: LinearProbe, voxel_size: float
) -> CheckResult:
    """Neighbouring imaging frames lie at most one voxel apart anywhere in the image."""
    spacing = frame_spacing(frames, probe)
    if not np.isfinite(spacing).any():
        return CheckResult("frame spacing", False, "fewer than two imaging frames")
    worst = float(np.nanmax(spacing))
    summary = f"max {worst * 1e3:.2f} mm between frames (voxel {voxel_size * 1e3:.2f} mm)"
    if worst <= voxel_size:
        return CheckResult("frame spacing", True, summary)
    first = int(np.flatnonzero(spacing > voxel_size)[0])
    last = int(np.flatnonzero(spacing > voxel_size)[-1])
    factor = SPACING_MARGIN * voxel_size / worst
    advice = (
        f"slow to {trajectory.speed * factor * 1e3:.1f} mm/s, or raise the frame rate to "
        f"{trajectory.frame_rate / factor:.0f} Hz, or use voxels of {worst * 1e3:.2f} mm"
    )
    return CheckResult(
        "frame spacing",
        False,
        summary,
        place_at(trajectory, frames.times[first], frames.times[last + 1]),
        advice,
    )


def plane_advance(frames: FrameSamples, probe: LinearProbe) -> np.ndarray:
    """(N - 1,) signed motion of the image centre along the image normal, frame to frame."""
    centre = np.array([0.0, 0.0, 0.5 * probe.depth, 1.0])
    centres = (frames.poses @ centre)[:, :3]
    normals = frames.poses[:, :3, 1]
    return np.einsum("ni,ni->n", np.diff(centres, axis=0), normals[:-1])


def check_progress(
    trajectory: Trajectory, frames: FrameSamples, probe: LinearProbe, voxel_size: float
) -> CheckResult:
    """Within each imaging segment the image plane keeps moving one way (stations, where the
    probe rests to image in place, excepted)."""
    advance = plane_advance(frames, probe)
    window = max(1, round(STATIONARY_TIME * trajectory.frame_rate))
    stations = trajectory.station_segments
    swept = [k for k in np.unique(frames.segment[frames.segment >= 0]) if k not in stations]
    for segment in swept:
        members = np.flatnonzero(frames.segment[:-1] == segment)
        members = members[frames.segment[members + 1] == segment]
        steps = advance[members]
        if not len(steps):
            continue
        sense = np.sign(steps.sum()) or 1.0
        backward = np.flatnonzero(sense * steps < -BACKTRACK_TOLERANCE)
        if len(backward):
            start, end = members[backward[0]], members[backward[-1]] + 1
            return CheckResult(
                "progress",
                False,
                f"the image plane moves backwards over {len(backward)} frames "
                f"({-sense * steps[backward].sum() * 1e3:.1f} mm) in imaging segment {segment}",
                place_at(trajectory, frames.times[start], frames.times[end]),
                "make the path advance one way in each imaging segment (no zig-zag within a pass)",
            )
        if len(steps) >= window:
            moved = np.abs(np.convolve(steps, np.ones(window), mode="valid"))
            still = np.flatnonzero(moved < STATIONARY_ADVANCE * voxel_size)
            if len(still):
                start = members[still[0]]
                return CheckResult(
                    "progress",
                    False,
                    f"the image plane advances {moved[still[0]] * 1e3:.2f} mm in "
                    f"{STATIONARY_TIME:.0f} s (stationary) in imaging segment {segment}",
                    place_at(trajectory, frames.times[start], frames.times[start + window]),
                    "remove the pause, or sweep across the probe's array instead of along it",
                )
    if not swept:
        return CheckResult("progress", True, f"imaging at {len(stations)} stations only")
    at_stations = f" ({len(stations)} stations image in place)" if stations else ""
    return CheckResult(
        "progress", True, f"every imaging segment advances steadily one way{at_stations}"
    )
