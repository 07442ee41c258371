"""How tissue answers the probe and the heart: the laws behind `sim.ultrasound.deformation`.

Four small laws, each a textbook model with its parameters in `TissueMechanics`:

- **Pressure under the probe.** The contact force spread evenly over the transducer face (a
  rectangle) loads an elastic half-space; the vertical stress at a point below is Boussinesq's,
  integrated over the rectangle in closed form (Newmark 1935), by superposing four rectangles
  that share a corner above the point (`face_stress_fraction`).
- **Vein flattening.** A vein stays round while the probe's stress at its centre is below the
  venous pressure (5-15 mmHg, varying with breathing); beyond, its minor axis (along the beam)
  shrinks linearly with the excess pressure, down to `collapsed_fraction` of its radius at
  `vein_collapse_pressure_mmhg` above venous pressure, more for a thick wall (its bending
  stiffness, the tube law's (h / R)^3); its perimeter is kept, so it widens as it flattens
  (`vein_semi_axes`). Nor is its edge an exact circle or ellipse: at that low transmural
  pressure its thin wall takes the shape its neighbours press into it, drawn per vein as
  harmonics 2-4 of the angle round its axis that bend the edge in and out
  (`vein_shape_harmonics`).
- **Arterial pulsation.** Arteries stay round (arterial pressure, about 90 mmHg, far above what
  a probe exerts) and their diameter follows a systolic waveform at the heart rate: a fast
  rise over the first 15 % of the cycle, then an exponential run-off (`cardiac_waveform`).
- **Bulk compression.** The skin follows the indented face, and the tissue under it is
  compressed along the beam: a point at undeformed depth D moves by `indentation * exp(-D /
  compression_length)` (`tissue_shift`; `bulk_row_shifts` inverts that map). A negative
  indentation (the skin below the face, drawn up to it) moves the tissue towards the face
  by the same law. A vessel moves with the tissue at its centre and keeps the shape its own
  law gives it.
"""

from __future__ import annotations

import math
from dataclasses import dataclass, fields

import numba
import numpy as np

PASCAL_PER_MMHG = 133.322
SYSTOLE_FRACTION = 0.15
"""Share of the cardiac cycle taken by the systolic rise of the arterial diameter."""
RUNOFF_TIME_FRACTION = 0.25
"""Time constant of the diastolic run-off, as a share of the cycle."""
VEIN_HARMONICS = (2, 3, 4)
"""The harmonics of the angle round its axis that shape a vein's cross-section."""
MAX_VEIN_IRREGULARITY = 0.25
"""Above this the harmonics could together cut a cross-section's radius to nothing."""
VEIN_SHAPE_STREAM = 0x5EA9
"""Mixed into the seed of each vein's harmonics (`vein_shape_harmonics`)."""
MAX_COMPRESSION_STRAIN = 0.8
"""Indentation is capped at this fraction of `compression_length`, so the map stays one to one."""


@dataclass(frozen=True)
class TissueMechanics:
    """Mechanical parameters of one subject (pressures in mmHg, lengths in metres)."""

    venous_pressure_mmhg: float = 10.0
    """Pressure inside the veins at rest (supine femoral vein: 5-15 mmHg)."""
    vein_collapse_pressure_mmhg: float = 50.0
    """Probe stress above venous pressure at which a thin-walled vein is fully flattened: the
    support of the tissue around it (a thick wall adds `vein_wall_stiffness_mmhg`'s part)."""
    vein_wall_stiffness_mmhg: float = 0.0
    """What a vein's own wall adds to its collapse pressure, per (wall thickness / radius)^3
    (mmHg). A ring resists flattening with the cube of its wall's thickness over its radius:
    the tube law's scale is K = E / (12 (1 - nu^2)) (h / R)^3, a ring buckles at 3 K and its
    opposite walls meet at about 5.2 K (Flaherty et al. 1972), so this is about 5.2 E / 9 for
    an incompressible wall. 1000 mmHg is E of about 0.23 MPa, a vein wall's at low strain: a
    great saphenous vein (h / R about 0.3) gains about 27 mmHg and stays oval under a light
    probe, the common femoral vein (h / R under 0.1) under 1 mmHg. 0: walls without stiffness."""
    collapsed_fraction: float = 0.08
    """Minor semi-axis of a fully collapsed vein, as a fraction of its round radius."""
    vein_irregularity: float = 0.0
    """Largest amplitude, over the round radius, of each of harmonics 2-4 of a vein's
    cross-section (`vein_shape_harmonics`). At its low transmural pressure a vein's thin wall
    takes the shape its neighbours press into it, so a real vein's cross-section is a rounded
    polygon more than an ellipse; an artery's pressure keeps it round. 0: elliptical veins."""
    heart_rate_bpm: float = 72.0
    arterial_pulsation: float = 0.07
    """Systolic increase of the arterial diameter over its diastolic value (5-10 %)."""
    cardiac_phase: float = 0.0
    """Phase of the cardiac cycle at time 0, in [0, 1)."""
    respiratory_rate_bpm: float = 15.0
    respiratory_swing_mmhg: float = 0.0
    """Amplitude of the venous pressure's variation with breathing (0: none)."""
    compression_length: float = 0.020
    """Depth over which the face's indentation decays (m)."""

    def __post_init__(self) -> None:
        for name in (
            "venous_pressure_mmhg",
            "vein_collapse_pressure_mmhg",
            "heart_rate_bpm",
            "respiratory_rate_bpm",
            "compression_length",
        ):
            if not getattr(self, name) > 0:
                raise ValueError(f"mechanics.{name} must be positive, got {getattr(self, name)}")
        if not self.vein_wall_stiffness_mmhg >= 0:
            raise ValueError(
                "mechanics.vein_wall_stiffness_mmhg must be >= 0, got "
                f"{self.vein_wall_stiffness_mmhg}"
            )
        if not 0 < self.collapsed_fraction < 1:
            raise ValueError(
                f"mechanics.collapsed_fraction must be in (0, 1), got {self.collapsed_fraction}"
            )
        if not 0 <= self.vein_irregularity <= MAX_VEIN_IRREGULARITY:
            raise ValueError(
                f"mechanics.vein_irregularity must be in [0, {MAX_VEIN_IRREGULARITY}], got "
                f"{self.vein_irregularity}"
            )
        if not 0 <= self.arterial_pulsation < 0.5:
            raise ValueError(
                f"mechanics.arterial_pulsation must be in [0, 0.5), got {self.arterial_pulsation}"
            )
        if not 0 <= self.cardiac_phase < 1:
            raise ValueError(f"mechanics.cardiac_phase must be in [0, 1), got {self.cardiac_phase}")
        if not 0 <= self.respiratory_swing_mmhg < self.venous_pressure_mmhg:
            raise ValueError(
                "mechanics.respiratory_swing_mmhg must be in [0, venous_pressure_mmhg), got "
                f"{self.respiratory_swing_mmhg}"
            )

    @classmethod
    def keys(cls) -> tuple[str, ...]:
        """The parameter names (the keys of a spec's `mechanics:` and of its variation)."""
        return tuple(f.name for f in fields(cls))

    def venous_pressure(self, time: float) -> float:
        """Venous pressure (mmHg) at `time` (s), with its respiratory swing."""
        breath = math.sin(2.0 * math.pi * self.respiratory_rate_bpm / 60.0 * time)
        return self.venous_pressure_mmhg + self.respiratory_swing_mmhg * breath

    def cardiac_phase_at(self, time: float) -> float:
        """Phase of the cardiac cycle, in [0, 1), at `time` (s)."""
        return (self.cardiac_phase + self.heart_rate_bpm / 60.0 * time) % 1.0

    def artery_scale(self, time: float) -> float:
        """Arterial radius at `time` over its diastolic radius."""
        return 1.0 + self.arterial_pulsation * cardiac_waveform(self.cardiac_phase_at(time))

    def vein_semi_axes(
        self, stress_mmhg: float, time: float, wall_ratio: float = 0.0
    ) -> tuple[float, float]:
        """(minor, major) semi-axes of a vein over its round radius, under the probe's stress
        at its centre (mmHg): minor along the beam, major across it. `wall_ratio`: its wall's
        thickness over its radius."""
        excess = max(0.0, stress_mmhg - self.venous_pressure(time))
        collapse = self.vein_collapse_pressure_mmhg + self.vein_wall_stiffness_mmhg * wall_ratio**3
        minor = max(self.collapsed_fraction, 1.0 - excess / collapse)
        return minor, perimeter_keeping_major(minor)


def vein_shape_harmonics(
    irregularity: float, seed: int, subject: int | None, vessel: int
) -> np.ndarray:
    """(len(VEIN_HARMONICS), 2) amplitude and phase (rad) of each harmonic of vessel
    `vessel`'s cross-section: amplitudes uniform in [0, irregularity], phases uniform, from a
    generator seeded by (seed, subject, vessel) alone (subject None: the nominal phantom), so
    that every subject's veins keep their shape from frame to frame and drawing them moves no
    other draw. The cross-section's edge lies at (1 + sum_k a_k cos(k (theta - phi_k))) times
    the ellipse's radius in direction theta, measured round the vessel's axis from the
    phantom's up (`sim.ultrasound.deformation`)."""
    nominal_or_subject = 0 if subject is None else subject + 1
    rng = np.random.default_rng([seed, nominal_or_subject, vessel, VEIN_SHAPE_STREAM])
    amplitudes = rng.uniform(0.0, irregularity, len(VEIN_HARMONICS))
    phases = rng.uniform(0.0, 2.0 * math.pi, len(VEIN_HARMONICS))
    return np.stack([amplitudes, phases], axis=1)


def cardiac_waveform(phase: float) -> float:
    """Arterial distension over one cycle, 0 at end-diastole and 1 at peak systole: a sine
    squared rise over `SYSTOLE_FRACTION`, then an exponential run-off that reaches 0 at the
    cycle's end."""
    if phase < SYSTOLE_FRACTION:
        return math.sin(0.5 * math.pi * phase / SYSTOLE_FRACTION) ** 2
    end = math.exp(-(1.0 - SYSTOLE_FRACTION) / RUNOFF_TIME_FRACTION)
    decay = math.exp(-(phase - SYSTOLE_FRACTION) / RUNOFF_TIME_FRACTION)
    return (decay - end) / (1.0 - end)


@numba.njit(cache=True)
def ellipse_perimeter(a: float, b: float) -> float:
    """Perimeter of an ellipse of semi-axes a, b (Ramanujan's second formula: relative error
    under 1e-4 down to b / a = 0.05, measured against the exact integral)."""
    h = ((a - b) / (a + b)) ** 2
    return math.pi * (a + b) * (1.0 + 3.0 * h / (10.0 + math.sqrt(4.0 - 3.0 * h)))


@numba.njit(cache=True)
def perimeter_keeping_major(minor: float) -> float:
    """The major semi-axis that keeps a unit circle's perimeter (2 pi) when the minor one is
    `minor` (in (0, 1]): a flattening vein's wall does not stretch. Compiled: every deformed
    frame solves it for each vein in view, and 60 bisection steps cost 0.05 ms in Python."""
    low, high = 1.0, math.pi / 2.0  # a flat slit of half-length pi / 2 has perimeter 2 pi
    for _ in range(60):
        middle = 0.5 * (low + high)
        if ellipse_perimeter(middle, minor) < 2.0 * math.pi:
            low = middle
        else:
            high = middle
    return 0.5 * (low + high)


@numba.njit(cache=True)
def _corner_stress(a: float, b: float, z: float) -> float:
    """Vertical stress per unit surface pressure at depth z under the corner of an a x b
    rectangle (Newmark's closed form of Boussinesq's integral); signed by a and b so that
    rectangles can be superposed."""
    m, n = abs(a) / z, abs(b) / z
    m2, n2 = m * m, n * n
    root = math.sqrt(m2 + n2 + 1.0)
    first = 2.0 * m * n * root / (m2 + n2 + m2 * n2 + 1.0) * (m2 + n2 + 2.0) / (m2 + n2 + 1.0)
    second = math.atan2(2.0 * m * n * root, m2 + n2 + 1.0 - m2 * n2)
    return np.sign(a) * np.sign(b) * (first + second) / (4.0 * math.pi)


@numba.njit(cache=True)
def _face_stress(x: np.ndarray, y: np.ndarray, z: np.ndarray, half_w: float, half_l: float):
    """`face_stress_fraction` on flat arrays: the four corner rectangles' sum per point."""
    out = np.empty(x.shape[0])
    for p in range(x.shape[0]):
        total = 0.0
        for sx in (-1.0, 1.0):
            for sy in (-1.0, 1.0):
                total += _corner_stress(half_w + sx * x[p], half_l + sy * y[p], z[p])
        out[p] = total
    return out


def face_stress_fraction(
    x: np.ndarray | float,
    y: np.ndarray | float,
    z: np.ndarray | float,
    width: float,
    length: float,
) -> np.ndarray:
    """Vertical stress at (x, y, depth z) under a `width` x `length` face centred at the
    origin, as a fraction of the mean contact pressure on the face: 1 just under the face,
    falling with depth and outside its footprint."""
    x, y, z = np.broadcast_arrays(*(np.asarray(v, dtype=np.float64) for v in (x, y, z)))
    if not (z > 0).all():
        raise ValueError(f"depths must be positive, got {z}")
    flat_x, flat_y, flat_z = (np.ascontiguousarray(v).ravel() for v in (x, y, z))
    stress: np.ndarray = _face_stress(flat_x, flat_y, flat_z, width / 2.0, length / 2.0)
    return stress.reshape(x.shape)


def tissue_shift(
    undeformed_depth: np.ndarray | float, indentation: float, length: float
) -> np.ndarray:
    """How far (m) the tissue at `undeformed_depth` below the skin moved along the beam from
    where it lay before the face sank `indentation` in: all of it at the skin, decaying over
    `length` (an indentation beyond `MAX_COMPRESSION_STRAIN * length`, either way, moves the
    tissue rigidly by the excess; a negative one moves it towards the face). It then lies
    `depth - indentation + shift` below the face."""
    limit = MAX_COMPRESSION_STRAIN * length
    compressed = min(max(indentation, -limit), limit)
    depth = np.asarray(undeformed_depth, dtype=np.float64)
    return (indentation - compressed) + compressed * np.exp(-depth / length)


NEWTON_TOLERANCE = 1e-13
"""Newton's method in `bulk_row_shifts` stops at a step shorter than this (m)."""


@numba.njit(cache=True)
def bulk_row_shifts(depths: np.ndarray, indentation: float, length: float) -> np.ndarray:
    """How far (m) along the beam the tissue seen at each of `depths` (1-D, ascending, m
    below the face) moved when the face sank `indentation` in: `tissue_shift` at the
    tissue's undeformed depth D, where D - indentation + indentation * exp(-D / length) is
    the depth seen (the skin, D = 0, on the face; deep tissue shifted by the indentation,
    towards the face when it is negative: the skin drawn up to the face).

    Newton's method on that strictly increasing map, each depth started from the previous
    one's answer moved by the step between them (two or three steps for neighbouring
    pixels; at most eight). An indentation beyond `MAX_COMPRESSION_STRAIN * length`, either
    way, compresses as that much (the map would fold), the rest shifting the tissue rigidly.
    """
    limit = MAX_COMPRESSION_STRAIN * length
    compressed = min(max(indentation, -limit), limit)
    shifts = np.empty(depths.shape[0])
    undeformed = 0.0
    for p in range(depths.shape[0]):
        undeformed = depths[p] if p == 0 else max(undeformed + depths[p] - depths[p - 1], 0.0)
        for _ in range(8):
            decay = compressed * math.exp(-undeformed / length)
            step = (undeformed - compressed + decay - depths[p]) / (1.0 - decay / length)
            undeformed -= step
            if abs(step) < NEWTON_TOLERANCE:
                break
        shifts[p] = depths[p] - (undeformed - indentation)
    return shifts
