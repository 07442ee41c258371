"""Coverage: do the planned image planes show the target vessels?

Each vessel centreline (the phantom's, with its lumen radii) is cut by each frame's image
plane; a frame shows a class (artery or vein) when some vessel of that class crosses its
plane with the whole lumen inside the image rectangle (38 mm wide, 50 mm deep by default).
Coverage counts stations along the sweep (1 mm bins), so side-by-side passes add up.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from resus.acquisition.trajectory import Trajectory
from resus.planning.checks import CheckResult, place_at
from resus.planning.sampling import FrameSamples
from sim.phantom import LABEL_NAMES, Phantom
from sim.transforms import invert_pose
from sim.ultrasound.probe import LinearProbe

MIN_COVERAGE = 0.9
"""Fraction of imaging frames that must show each target class."""
VIEW_MARGIN = 0.002
"""Margin (m) kept between a vessel and the image edge when advising a move."""
MAX_LUMEN_RADIUS = 0.006
"""Lumen radius (m) assumed when advising a move (the largest femoral vein)."""
STATION_STEP = 0.001
"""Bin width (m) of stations along the sweep."""


@dataclass(frozen=True)
class Coverage:
    """Per frame and class: whether it is in view, and where its nearest crossing lies."""

    labels: tuple[int, ...]
    seen: np.ndarray
    """(N, C) bool: frame n shows class c."""
    lateral: np.ndarray
    """(N, C) probe-x (m) of the crossing of class c nearest the image centre; NaN if none."""


def _crossings(nodes: np.ndarray, to_probe: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """Probe-frame points (N, K, 3) where the polyline crosses each plane y = 0, and a mask."""
    local = np.einsum("nij,kj->nki", to_probe[:, :3, :3], nodes) + to_probe[:, None, :3, 3]
    y0, y1 = local[:, :-1, 1], local[:, 1:, 1]
    crosses = (y0 <= 0) != (y1 <= 0)
    weight = np.where(crosses, y0 / np.where(crosses, y0 - y1, 1.0), 0.0)
    points = local[:, :-1] + weight[..., None] * (local[:, 1:] - local[:, :-1])
    return points, crosses


def analyse_coverage(
    frames: FrameSamples,
    phantom: Phantom,
    phantom_to_base: np.ndarray,
    probe: LinearProbe,
    labels: tuple[int, ...],
) -> Coverage:
    """Which target classes each frame shows."""
    to_probe = invert_pose(frames.poses) @ phantom_to_base
    label_of = {vessel.name: vessel.label for vessel in phantom.spec.vessels}
    radii = phantom.centreline_radii()
    seen = np.zeros((len(frames.times), len(labels)), dtype=bool)
    lateral = np.full((len(frames.times), len(labels)), np.nan)
    nearest = np.full_like(lateral, np.inf)
    for name, nodes in phantom.centrelines().items():
        if label_of[name] not in labels:
            continue
        c = labels.index(label_of[name])
        points, crosses = _crossings(nodes, to_probe)
        radius = radii[name][:-1][None, :]
        x, z = points[..., 0], points[..., 2]
        inside = (np.abs(x) + radius <= 0.5 * probe.width) & (z - radius >= 0)
        inside &= z + radius <= probe.depth
        seen[:, c] |= (crosses & inside).any(axis=1)
        distance = np.where(crosses, np.abs(x), np.inf)
        best = distance.argmin(axis=1)
        closer = distance[np.arange(len(best)), best] < nearest[:, c]
        nearest[closer, c] = distance[closer, best[closer]]
        lateral[closer, c] = x[closer, best[closer]]
    return Coverage(labels, seen, lateral)


def _longest_run(mask: np.ndarray) -> tuple[int, int]:
    """First and last index of the longest run of True in `mask` (which has one)."""
    padded = np.concatenate([[0], mask.astype(np.int8), [0]])
    edges = np.flatnonzero(np.diff(padded))
    starts, ends = edges[::2], edges[1::2]
    k = int(np.argmax(ends - starts))
    return int(starts[k]), int(ends[k] - 1)


def station_bins(frames: FrameSamples, probe: LinearProbe) -> np.ndarray:
    """(N,) bin of each imaging frame along the sweep (-1 for transit frames).

    Frames are binned every STATION_STEP along the main direction their image centres move
    in, so passes side by side share bins and a class counts as covered at a station when any
    pass shows it there.
    """
    imaging = frames.imaging
    centres = (frames.poses[imaging] @ np.array([0.0, 0.0, 0.5 * probe.depth, 1.0]))[:, :3]
    bins = np.full(len(frames.times), -1, dtype=np.int64)
    if len(centres) < 2:
        bins[imaging] = 0
        return bins
    centred = centres - centres.mean(axis=0)
    axis = np.linalg.svd(centred, full_matrices=False)[2][0]
    along = centred @ axis
    bins[imaging] = np.floor((along - along.min()) / STATION_STEP).astype(np.int64)
    return bins


def _station_coverage(bins: np.ndarray, seen: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """(B,) whether any frame in each occupied bin shows the class (unoccupied: True), and
    (B,) whether each bin is occupied."""
    covered = np.ones(bins.max() + 1, dtype=bool)
    occupied = np.zeros_like(covered)
    np.logical_or.at(occupied, bins[bins >= 0], True)
    hits = np.zeros_like(covered)
    np.logical_or.at(hits, bins[bins >= 0], seen[bins >= 0])
    covered[occupied] = hits[occupied]
    return covered, occupied


def _shift_advice(
    trajectory: Trajectory,
    frames: FrameSamples,
    coverage: Coverage,
    missing: dict[int, np.ndarray],
    probe: LinearProbe,
    phantom_to_base: np.ndarray,
) -> str:
    """How far to move the path along the array to bring the missing classes into view."""
    room = 0.5 * probe.width - VIEW_MARGIN - MAX_LUMEN_RADIUS
    moves = []
    for c, members in missing.items():
        offsets = coverage.lateral[members, c]
        if np.isfinite(offsets).any():
            offset = float(np.nanmedian(offsets))
            moves.append(np.sign(offset) * max(abs(offset) - room, VIEW_MARGIN))
    if not moves:
        return "no target vessel crosses these image planes: sweep across the vessels"
    move = max(moves, key=abs)
    first = next(iter(missing.values()))[0]
    array_axis = (invert_pose(phantom_to_base) @ frames.poses[first])[:2, 0]
    shift = move * array_axis / np.linalg.norm(array_axis)
    advice = (
        f"move the path {abs(move) * 100:.1f} cm along phantom ({shift[0]:+.3f}, {shift[1]:+.3f})"
    )
    start = trajectory.pattern.get("start")
    if start is not None:
        advice += f" (start {start[0] + shift[0]:.3f},{start[1] + shift[1]:.3f})"
    return advice


def check_coverage(
    trajectory: Trajectory,
    frames: FrameSamples,
    coverage: Coverage,
    probe: LinearProbe,
    phantom_to_base: np.ndarray,
) -> CheckResult:
    """Every target class is in view at MIN_COVERAGE of the stations along the sweep."""
    bins = station_bins(frames, probe)
    names = [LABEL_NAMES[label] for label in coverage.labels]
    fractions, missing = [], {}
    run: tuple[np.ndarray, int] | None = None
    for c in range(len(coverage.labels)):
        covered, occupied = _station_coverage(bins, coverage.seen[:, c])
        fractions.append(float(covered[occupied].mean()))
        if fractions[-1] < MIN_COVERAGE:
            first, last = _longest_run(occupied & ~covered)
            members = np.flatnonzero((bins >= first) & (bins <= last))
            missing[c] = members
            run = run if run is not None else (members, c)
    summary = ", ".join(
        f"{n} at {f:.0%} of stations" for n, f in zip(names, fractions, strict=True)
    )
    if run is None:  # no class is missing: run is set with the first missing one
        return CheckResult("coverage", True, summary)
    members, c = run
    segment = frames.segment[members[0]]
    times = frames.times[members[frames.segment[members] == segment]]
    out_of_view = ", ".join(names[k] for k in missing)
    return CheckResult(
        "coverage",
        False,
        summary + f"; {out_of_view} out of view",
        place_at(trajectory, float(times.min()), float(times.max())),
        _shift_advice(trajectory, frames, coverage, missing, probe, phantom_to_base),
    )
