"""Temporal calibration: how late the probe's frame times are against the robot's poses.

The method is PLUS's (TemporalCalibrationAlgo): move the probe back and forth in its image
plane, turn both streams into one position signal each, and find the time shift that makes
them agree best.

- Pose signal: the probe's displacement from the first frame, in the first frame's probe
  axes, along the direction of largest in-plane motion.
- Image signal: the same displacement as the images show it. Every frame is registered to a
  reference frame by phase correlation (sub-pixel); the content moves opposite to the probe,
  and `image_to_probe` turns the pixel shift into metres in the probe frame.

For each candidate offset `d` (a grid over `search`), the pose signal is interpolated at the
frames' recorded times plus `d`, from the Sweep's own poses (the robot pose stream sampled at
the frame times), and scored by its correlation with the image signal over the frames whose
shifted times stay inside the sweep for every candidate. The best grid point is refined with a
parabola through its neighbours. The frames were really taken at `timestamp + offset`: scan
again with `--time-offset` increased by `offset`.

`oscillation` makes the calibration motion: back and forth along the probe's array axis
(in-plane, lateral), a few cycles, each longer than the search range so the correlation has
one peak.
"""

from __future__ import annotations

from dataclasses import dataclass
from pathlib import Path

import numpy as np

from resus.acquisition.trajectory import Trajectory
from resus.errors import ResusError
from resus.sweep.model import Sweep

MIN_FRAMES = 20
"""Fewest frames the offsets are scored on."""
MIN_CORRELATION = 0.8
"""Below this best correlation the sweep does not determine the offset."""
UPSAMPLE = 20
"""Phase-correlation precision: 1/UPSAMPLE pixel."""


@dataclass(frozen=True)
class TemporalCalibration:
    """The offset found and how it was scored."""

    offset: float
    """Seconds to add to the recorded frame times to put them on the pose clock."""
    correlation: float
    """Correlation of the two signals at `offset` (1 is perfect agreement)."""
    candidates: np.ndarray
    """Offsets tried (s)."""
    scores: np.ndarray
    """Correlation at each candidate."""
    times: np.ndarray
    """Recorded times of the frames scored (s)."""
    image_signal: np.ndarray
    """Probe displacement the images show at those frames (m)."""
    pose_signal: np.ndarray
    """Probe displacement the poses show at the recorded times (m)."""
    pose_signal_aligned: np.ndarray
    """...and at the recorded times plus `offset` (m)."""

    def describe(self) -> str:
        return (
            f"time offset {self.offset:+.4f} s (correlation {self.correlation:.3f} over "
            f"{len(self.times)} frames): frames were taken {abs(self.offset):.4f} s "
            f"{'after' if self.offset > 0 else 'before'} their recorded times; add "
            f"{self.offset:+.4f} to the time offset this sweep was scanned with "
            "(`ScannerSettings.time_offset`, `resus scan --time-offset`)"
        )


def image_shifts(frames: np.ndarray, reference: int = 0) -> np.ndarray:
    """(N, 2) in-plane content shift (col, row) of each frame against `frames[reference]` (px)."""
    from skimage.filters import window
    from skimage.registration import phase_cross_correlation

    taper = window("hann", frames.shape[1:])
    anchor = frames[reference].astype(np.float64) * taper
    shifts = np.empty((len(frames), 2))
    for index, frame in enumerate(frames):
        shift, _, _ = phase_cross_correlation(
            anchor, frame.astype(np.float64) * taper, upsample_factor=UPSAMPLE
        )
        shifts[index] = -shift[1], -shift[0]  # the shift registers back: the content moved -shift
    return shifts


def probe_displacements(poses: np.ndarray) -> np.ndarray:
    """(N, 3) probe positions relative to the first, in the first pose's probe axes (m)."""
    return (poses[:, :3, 3] - poses[0, :3, 3]) @ poses[0, :3, :3]


def motion_direction(displacements: np.ndarray, image_to_probe: np.ndarray) -> np.ndarray:
    """Unit direction (probe frame) of the largest motion within the image plane."""
    plane, _ = np.linalg.qr(image_to_probe[:3, :2])
    in_plane = displacements @ plane
    centred = in_plane - in_plane.mean(axis=0)
    _, _, axes = np.linalg.svd(centred, full_matrices=False)
    return plane @ axes[0]


def _correlation(a: np.ndarray, b: np.ndarray) -> float:
    a, b = a - a.mean(), b - b.mean()
    norm = np.sqrt((a @ a) * (b @ b))
    return float(a @ b / norm) if norm > 0 else 0.0


def calibrate_time(
    sweep: Sweep, search: tuple[float, float] = (-0.5, 0.5), step: float = 0.001
) -> TemporalCalibration:
    """Find the offset that best aligns the sweep's images with its poses (see module doc)."""
    low, high = search
    if not (low < high and step > 0):
        raise ResusError(f"search range must be LOW < HIGH with a positive step, got {search}")
    times = sweep.timestamps
    reach = max(abs(low), abs(high))
    scored = (times >= times[0] + reach) & (times <= times[-1] - reach)
    if scored.sum() < MIN_FRAMES:
        raise ResusError(
            f"the sweep is too short for the search range {low:+g}..{high:+g} s: "
            f"{scored.sum()} frames lie {reach:g} s inside both ends, {MIN_FRAMES} needed"
        )
    displacements = probe_displacements(sweep.probe_to_base)
    direction = motion_direction(displacements, sweep.image_to_probe)
    pose_track = displacements @ direction
    if np.ptp(pose_track) <= 0:
        raise ResusError("the probe did not move in its image plane: nothing to calibrate on")
    reference = int(np.argmin(np.abs(pose_track - np.median(pose_track))))
    shifts = image_shifts(sweep.frames, reference)
    image_track = (shifts @ sweep.image_to_probe[:3, :2].T) @ direction
    image_track = -image_track[scored]  # the probe moves opposite to the image content
    image_track -= image_track.mean()
    candidates = np.arange(low, high + 0.5 * step, step)
    scores = np.array(
        [
            _correlation(image_track, np.interp(times[scored] + d, times, pose_track))
            for d in candidates
        ]
    )
    best = int(np.argmax(scores))
    offset = float(candidates[best])
    if 0 < best < len(scores) - 1:
        left, middle, right = scores[best - 1 : best + 2]
        curvature = left - 2 * middle + right
        if curvature < 0:
            offset += 0.5 * step * (left - right) / curvature
    if scores[best] < MIN_CORRELATION:
        raise ResusError(
            f"no clear match between images and poses (best correlation {scores[best]:.2f} < "
            f"{MIN_CORRELATION}): move the probe back and forth in its image plane over "
            "textured tissue, a few cycles"
        )
    aligned = np.interp(times[scored] + offset, times, pose_track)
    return TemporalCalibration(
        offset=offset,
        correlation=_correlation(image_track, aligned),
        candidates=candidates,
        scores=scores,
        times=times[scored],
        image_signal=image_track,
        pose_signal=np.interp(times[scored], times, pose_track) - aligned.mean(),
        pose_signal_aligned=aligned - aligned.mean(),
    )


def oscillation(
    centre: np.ndarray,
    *,
    amplitude: float = 0.005,
    cycles: int = 3,
    speed: float = 0.01,
    contact_force: float | None = 4.0,
    frame_rate: float = 30.0,
) -> Trajectory:
    """A calibration trajectory: the probe at `centre` (4x4, base frame) moves `amplitude` m
    to either side along its own array (x) axis, `cycles` times, at `speed`."""
    if not amplitude > 0:
        raise ResusError(f"oscillation amplitude must be positive, got {amplitude}")
    if cycles < 1:
        raise ResusError(f"oscillation cycles must be at least 1, got {cycles}")
    sides = [(-1.0) ** k for k in range(2 * cycles + 1)]
    waypoints = np.repeat(np.asarray(centre, dtype=np.float64)[None], len(sides), axis=0)
    waypoints[:, :3, 3] += amplitude * np.outer(sides, centre[:3, 0])
    return Trajectory(
        waypoints=waypoints,
        speed=speed,
        contact_force=contact_force,
        frame_rate=frame_rate,
        name="time-calibration",
        pattern={"pattern": "oscillation", "amplitude": amplitude, "cycles": cycles},
    )


def save_plot(result: TemporalCalibration, path: str | Path) -> None:
    """PNG: the two signals before and after alignment, and the score over the offsets."""
    from matplotlib.figure import Figure

    figure = Figure(figsize=(11, 3.6))
    signals, scores = figure.subplots(1, 2)
    t = result.times - result.times[0]
    signals.plot(t, 1e3 * result.image_signal, label="images", color="black")
    signals.plot(
        t, 1e3 * result.pose_signal, label="poses, recorded times", color="tab:red", alpha=0.6
    )
    signals.plot(
        t,
        1e3 * result.pose_signal_aligned,
        "--",
        label=f"poses, {result.offset:+.3f} s",
        color="tab:blue",
    )
    signals.set(xlabel="time (s)", ylabel="probe displacement (mm)", title="position signals")
    signals.legend(fontsize=8)
    scores.plot(result.candidates, result.scores, color="black")
    scores.axvline(result.offset, color="tab:blue", linestyle="--")
    scores.set(xlabel="time offset (s)", ylabel="correlation", title="agreement")
    figure.tight_layout()
    figure.savefig(path, dpi=120)
