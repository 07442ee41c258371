"""Artery or vein by pressing: the vessel that collapses under the probe is the vein; the one
that stays open and round, and pulses with the heart, is the artery.

The frames of a compression scan (`resus plan --pattern compression`) are cut into vessel
cross-sections and followed through the sweep (`resus.vessels.sections`). Each track's area is
fitted against the contact force of its frames (the wrench along the probe axis, as the sweep
recorded it) with a hinge, A(F) = A0 max(0, 1 - F / Fc): a vessel that shuts at Fc, or a line
where it does not shut within the forces pressed. Its collapse ratio is the fitted area at the
track's press force (95th percentile of its frames' forces) over that at its light contact (5th
percentile). Its pulsation is the area's residual from the fit, with the running mean over
`trend_window` removed (the press and the transit change the area slowly), fitted by a sinusoid
at each frequency (least squares, so uneven frame times and gaps do not matter): the best fit's
frequency is the area spectrum's peak, its amplitude over the light-contact area the pulsation,
its amplitude over the spectrum's median amplitude its prominence. A track pulses when its peak
lies in the heart band (1-1.7 Hz, 60-100 beats/min) with a prominence of `min_prominence`: a
pulse is a sharp line (the femoral arteries of the simulated subjects stand 13-28 times above
their spectrum's median), white noise spreads over every frequency (about 3 times).

The call: a collapse ratio under `collapse_ratio` is a vein, with a confidence from 0.5 there
to 1 at `shut_ratio`. A track that pulses is an artery, with a confidence from 0.5 to 1 by the
mean of three pieces of evidence, each 0 to 1: it pulses, it stays open (ratio from
`collapse_ratio` up to `open_ratio`), it stays round at the press (roundness up to
`round_ratio`). A track that does neither is judged by the tracks seen at the same time: beside
one that pulses it is a vein the press did not shut (confidence 0.5 to 0.75 as its ratio falls
from `open_ratio` to `collapse_ratio`), beside a collapsing vein an artery whose pulse did not
show (the mean evidence as above, its pulse 0), alone unknown (tissue that does not deform, a
press that did not reach it). A track seen in too few frames or pressed over too small a force
range is unknown too; unknown tracks keep their labels.
"""

from __future__ import annotations

import dataclasses
from dataclasses import dataclass, field

import numpy as np

from resus.errors import ResusError
from resus.sweep.model import Sweep
from resus.vessels.sections import (
    SectionSettings,
    SectionTrack,
    follow_sections,
    frame_sections,
)
from sim.labels import LABEL_NAMES, VESSEL_CLASSES

UNKNOWN = "unknown"
FIT_STEPS = 400
"""Candidate shut-off forces of the hinge fit (its slope 1/Fc on a grid from 0 to 1/F_min)."""
FREQUENCY_STEP = 0.01
"""Spacing of the area spectrum's frequencies (Hz)."""
LIGHT_QUANTILE, PRESS_QUANTILE = 0.05, 0.95
"""Quantiles of a track's forces taken as its light contact and its press."""


@dataclass(frozen=True)
class CompressionSettings:
    """Every knob of the compression classification, with its default."""

    sections: SectionSettings = field(default_factory=SectionSettings)
    min_frames: int = 15
    """Fewest frames a track must be seen in to be called."""
    min_force_span: float = 3.0
    """Least difference between a track's press and light-contact forces (N)."""
    collapse_ratio: float = 0.5
    """Press area over light-contact area below which a vessel collapses: a vein."""
    shut_ratio: float = 0.2
    """Ratio at or below which a vein is called with full confidence."""
    open_ratio: float = 0.8
    """Ratio at or above which an artery counts as fully open."""
    round_ratio: float = 0.8
    """Roundness (minor over major axis) at the press at which an artery counts as round."""
    heart_band: tuple[float, float] = (1.0, 1.7)
    """Frequencies (Hz) of the heart: 60-100 beats/min."""
    min_prominence: float = 5.0
    """Least ratio of the spectrum peak's amplitude to the spectrum's median amplitude of a
    pulse (white noise gives about 3; a sine sampled at random times 10)."""
    spectrum_band: tuple[float, float] = (0.5, 4.0)
    """Frequencies (Hz) searched for the area spectrum's peak (capped below Nyquist)."""
    trend_window: float = 2.0
    """Width (s) of the running mean taken off the area before its spectrum."""

    def __post_init__(self) -> None:
        kind = type(self).__name__
        if self.min_frames < 3:
            raise ResusError(f"{kind}.min_frames must be at least 3, got {self.min_frames}")
        for name in ("min_force_span", "trend_window", "min_prominence"):
            if not getattr(self, name) > 0:
                raise ResusError(f"{kind}.{name} must be positive, got {getattr(self, name)}")
        if not 0 < self.shut_ratio < self.collapse_ratio < self.open_ratio <= 1:
            raise ResusError(
                f"{kind} needs 0 < shut_ratio < collapse_ratio < open_ratio <= 1, got "
                f"{self.shut_ratio}, {self.collapse_ratio}, {self.open_ratio}"
            )
        if not 0 < self.round_ratio <= 1:
            raise ResusError(f"{kind}.round_ratio must lie in (0, 1], got {self.round_ratio}")
        for name in ("heart_band", "spectrum_band"):
            low, high = getattr(self, name)
            if not 0 < low < high:
                raise ResusError(f"{kind}.{name} must be (low, high) Hz with 0 < low < high")


@dataclass(frozen=True)
class HingeFit:
    """Area against force: A(F) = full_area * max(0, 1 - F / shut_force)."""

    full_area: float
    """A0 (m^2): the area at no force."""
    shut_force: float
    """Fc (N): the force that shuts the vessel; inf for a constant area."""

    def __call__(self, force: np.ndarray | float) -> np.ndarray:
        return self.full_area * np.maximum(0.0, 1.0 - np.asarray(force) / self.shut_force)


def fit_hinge(forces: np.ndarray, areas: np.ndarray) -> HingeFit:
    """The least-squares hinge through (force, area) points, forces positive."""
    slopes = np.linspace(0.0, 1.0 / float(forces.min()), FIT_STEPS + 1)
    shapes = np.maximum(0.0, 1.0 - slopes[:, None] * forces[None])
    full = shapes @ areas / np.maximum((shapes * shapes).sum(axis=1), 1e-300)
    errors = ((areas[None] - full[:, None] * shapes) ** 2).sum(axis=1)
    best = int(np.argmin(errors))
    return HingeFit(float(full[best]), 1.0 / slopes[best] if slopes[best] > 0 else np.inf)


def running_mean(times: np.ndarray, values: np.ndarray, width: float) -> np.ndarray:
    """Mean of `values` over the `width` seconds centred on each time (times increasing)."""
    sums = np.concatenate([[0.0], np.cumsum(values)])
    low = np.searchsorted(times, times - 0.5 * width, side="left")
    high = np.searchsorted(times, times + 0.5 * width, side="right")
    return (sums[high] - sums[low]) / (high - low)


@dataclass(frozen=True)
class SpectrumPeak:
    """The strongest sinusoid in a signal."""

    frequency: float
    """Hz (NaN when no frequency could be searched)."""
    amplitude: float
    prominence: float
    """Its amplitude over the median amplitude of every frequency searched."""


def spectrum_peak(times: np.ndarray, values: np.ndarray, band: tuple[float, float]) -> SpectrumPeak:
    """The sinusoid that best fits `values` at `times`: least squares at every FREQUENCY_STEP in
    `band`, capped below the Nyquist frequency of the median frame interval."""
    nyquist = 0.5 / float(np.median(np.diff(times))) if len(times) > 1 else 0.0
    frequencies = np.arange(band[0], min(band[1], 0.9 * nyquist) + 1e-9, FREQUENCY_STEP)
    if len(frequencies) < 2:
        return SpectrumPeak(float("nan"), 0.0, 0.0)
    phase = 2 * np.pi * frequencies[:, None] * (times - times[0])[None]
    cos, sin = np.cos(phase), np.sin(phase)
    cc, ss, cs = (cos * cos).sum(1), (sin * sin).sum(1), (cos * sin).sum(1)
    cy, sy = cos @ values, sin @ values
    determinant = np.maximum(cc * ss - cs * cs, 1e-300)
    a, b = (ss * cy - cs * sy) / determinant, (cc * sy - cs * cy) / determinant
    amplitude = np.hypot(a, b)
    best = int(np.argmax(amplitude))
    median = float(np.median(amplitude))
    prominence = float(amplitude[best]) / median if median > 0 else 0.0
    return SpectrumPeak(float(frequencies[best]), float(amplitude[best]), prominence)


@dataclass(frozen=True)
class VesselCall:
    """One track's measurements and what it was called."""

    track: int
    frames: int
    """Frames it was seen in."""
    times: tuple[float, float]
    """First and last sighting (s, the sweep's clock)."""
    centre: np.ndarray
    """Mean world position (m)."""
    labelled: int
    """The labels' majority class in its sections before the call."""
    forces: tuple[float, float]
    """Its light-contact and press forces (N)."""
    fit: HingeFit
    collapse_ratio: float
    """Fitted area at the press over that at light contact."""
    roundness: float
    """Median roundness of its sections at the press (0 when shut)."""
    peak_frequency: float
    """Area spectrum peak (Hz)."""
    pulsation: float
    """Amplitude at the peak over the light-contact area."""
    prominence: float
    """Amplitude at the peak over the spectrum's median amplitude."""
    pulsatile: bool
    call: str
    """'artery', 'vein' or 'unknown'."""
    confidence: float
    """0.5-1 for a call (how clearly the evidence makes it), 0 for unknown."""
    reason: str

    def to_dict(self) -> dict:
        """JSON-able form in millimetres, as vessels.json lists the tracks."""
        light, press = self.forces
        finite = np.isfinite(self.fit.shut_force)
        return {
            "track": self.track,
            "frames": self.frames,
            "times_s": [round(t, 3) for t in self.times],
            "centre_mm": [round(float(c) * 1e3, 2) for c in self.centre],
            "labelled": LABEL_NAMES[self.labelled],
            "force_n": {"light": round(light, 2), "press": round(press, 2)},
            "area_vs_force": {
                "model": "area = full_area * max(0, 1 - force / shut_force)",
                "full_area_mm2": round(self.fit.full_area * 1e6, 3),
                "shut_force_n": round(self.fit.shut_force, 2) if finite else None,
                "area_light_mm2": round(float(self.fit(light)) * 1e6, 3),
                "area_press_mm2": round(float(self.fit(press)) * 1e6, 3),
                "collapse_ratio": round(self.collapse_ratio, 3),
            },
            "roundness_at_press": round(self.roundness, 3),
            "spectrum_peak_hz": (
                round(self.peak_frequency, 3) if np.isfinite(self.peak_frequency) else None
            ),
            "heart_rate_bpm": round(60 * self.peak_frequency, 1) if self.pulsatile else None,
            "pulsation": round(self.pulsation, 4),
            "prominence": round(self.prominence, 1),
            "call": self.call,
            "confidence": round(self.confidence, 3),
            "reason": self.reason,
        }


@dataclass(frozen=True)
class CompressionResult:
    """Every track's call and the label images relabelled by them."""

    calls: tuple[VesselCall, ...]
    labels: np.ndarray
    """(N, H, W) uint8: each called track's pixels set to its class, the rest as given."""
    settings: CompressionSettings

    @property
    def summary(self) -> str:
        """One line: how many tracks got which call."""
        names = [call.call for call in self.calls]
        counts = ", ".join(f"{names.count(name)} {name}" for name in (*VESSEL_CLASSES, UNKNOWN))
        return f"{len(self.calls)} vessel tracks by compression: {counts}"

    def to_dict(self) -> dict:
        """vessels.json's "compression"."""
        return {
            "summary": self.summary,
            "merge_classes": self.settings.sections.merge_classes,
            "tracks": [call.to_dict() for call in self.calls],
        }


def classify_by_compression(
    sweep: Sweep, labels: np.ndarray, settings: CompressionSettings | None = None
) -> CompressionResult:
    """Call every vessel track of `sweep` (with its (N, H, W) `labels`) artery or vein by how
    it answers the probe's press, and relabel the frames by the calls."""
    settings = settings or CompressionSettings()
    forces = sweep.axial_force
    if forces is None:
        raise ResusError("compression classification needs the sweep's wrench (force per frame)")
    labels = np.asarray(labels)
    if labels.shape != sweep.frames.shape:
        raise ResusError(
            f"labels must have the frames' shape {sweep.frames.shape}, got {labels.shape}"
        )
    per_frame = [
        frame_sections(label, k, pose, sweep.image_to_probe, settings.sections)
        for k, (label, pose) in enumerate(zip(labels, sweep.probe_to_base, strict=True))
    ]
    tracks = follow_sections(per_frame, sweep.timestamps, settings.sections)
    calls = [
        call_track(k, track, sweep.timestamps, forces, settings) for k, track in enumerate(tracks)
    ]
    calls = [_in_company(call, calls, settings) for call in calls]
    relabelled = labels.astype(np.uint8, copy=True)
    for call, track in zip(calls, tracks, strict=True):
        if call.call == UNKNOWN:
            continue
        for section in track.sections:
            relabelled[section.frame].flat[section.pixels] = VESSEL_CLASSES[call.call]
    return CompressionResult(tuple(calls), relabelled, settings)


def _in_company(
    call: VesselCall, calls: list[VesselCall], settings: CompressionSettings
) -> VesselCall:
    """A track that neither collapses nor pulses (called 'artery' so far), judged by the tracks
    seen at the same time (see the module doc); any other call as it is."""
    if call.call != "artery" or call.pulsatile:
        return call
    start, end = call.times
    beside = [other for other in calls if other.times[0] <= end and start <= other.times[1]]
    if any(other.call == "artery" and other.pulsatile for other in beside):
        opened = (settings.open_ratio - call.collapse_ratio) / (
            settings.open_ratio - settings.collapse_ratio
        )
        confidence = 0.5 + 0.25 * float(np.clip(opened, 0.0, 1.0))
        reason = f"{call.reason}, beside one that pulses: a vein the press did not shut"
        return dataclasses.replace(call, call="vein", confidence=confidence, reason=reason)
    if any(other.call == "vein" for other in beside):
        return dataclasses.replace(call, reason=f"{call.reason}, beside a collapsing vein")
    reason = f"{call.reason}; neither it nor any vessel beside it collapses or pulses"
    return dataclasses.replace(call, call=UNKNOWN, confidence=0.0, reason=reason)


def call_track(
    index: int,
    track: SectionTrack,
    timestamps: np.ndarray,
    forces: np.ndarray,
    settings: CompressionSettings,
) -> VesselCall:
    """Measure one track (fit, roundness, spectrum) and call it (see the module doc)."""
    span = track.span
    areas, times, pressed = track.areas(), timestamps[span], np.maximum(forces[span], 1e-3)
    light, press = (float(np.quantile(pressed, q)) for q in (LIGHT_QUANTILE, PRESS_QUANTILE))
    fit = fit_hinge(pressed, areas)
    light_area = float(fit(light))
    ratio = float(fit(press)) / light_area if light_area > 0 else 0.0
    at_press = [
        s.roundness for s in track.sections if forces[s.frame] >= light + 0.75 * (press - light)
    ]
    roundness = float(np.median(at_press)) if at_press else 0.0
    seen = areas > 0
    residual = areas[seen] - fit(pressed[seen])
    residual -= running_mean(times[seen], residual, settings.trend_window)
    spectrum = spectrum_peak(times[seen], residual, settings.spectrum_band)
    peak = spectrum.frequency
    pulsation = spectrum.amplitude / light_area if light_area > 0 else 0.0
    low, high = settings.heart_band
    pulsatile = bool(low <= peak <= high and spectrum.prominence >= settings.min_prominence)
    labelled = int(np.bincount([s.label for s in track.sections]).argmax())
    measured = VesselCall(
        track=index, frames=len(track.sections), times=(float(times[0]), float(times[-1])),
        centre=track.centre, labelled=labelled, forces=(light, press), fit=fit,
        collapse_ratio=ratio, roundness=roundness, peak_frequency=peak, pulsation=pulsation,
        prominence=spectrum.prominence, pulsatile=pulsatile, call=UNKNOWN, confidence=0.0,
        reason="",
    )  # fmt: skip
    if len(track.sections) < settings.min_frames:
        reason = f"seen in {len(track.sections)} frames (fewer than {settings.min_frames})"
        return dataclasses.replace(measured, reason=reason)
    if press - light < settings.min_force_span:
        reason = (
            f"pressed over {press - light:.1f} N only (less than {settings.min_force_span:g} N)"
        )
        return dataclasses.replace(measured, reason=reason)
    pressing = (
        f"area {light_area * 1e6:.1f} -> {fit(press) * 1e6:.1f} mm^2 from {light:.1f} to "
        f"{press:.1f} N (ratio {ratio:.2f})"
    )
    if ratio < settings.collapse_ratio:
        flat = (settings.collapse_ratio - ratio) / (settings.collapse_ratio - settings.shut_ratio)
        confidence = 0.5 + 0.5 * float(np.clip(flat, 0.0, 1.0))
        reason = f"{pressing}: collapses"
        return dataclasses.replace(measured, call="vein", confidence=confidence, reason=reason)
    evidence = [
        float(pulsatile),
        (ratio - settings.collapse_ratio) / (settings.open_ratio - settings.collapse_ratio),
        roundness / settings.round_ratio,
    ]
    confidence = 0.5 + 0.5 * float(np.mean(np.clip(evidence, 0.0, 1.0)))
    pulse = (
        f"pulses at {60 * peak:.0f} beats/min ({pulsation:.1%} of its area)"
        if pulsatile
        else f"no pulse in {low:g}-{high:g} Hz (peak {peak:.2f} Hz, {spectrum.prominence:.1f}x "
        "its spectrum's median)"
    )
    reason = f"{pressing}: stays open, roundness {roundness:.2f}, {pulse}"
    return dataclasses.replace(measured, call="artery", confidence=confidence, reason=reason)
