"""Layer boundaries that wave: fasciae and fat-muscle borders are not parallel to the skin.

In a transverse image of the groin the fascia lata and the fascia iliaca run as bright lines
that rise and fall by a millimetre or two across the probe's width, each in its own way,
because they wrap the muscles and fat lobules beneath them; a phantom whose boundaries lie at
fixed depths under the skin draws them as straight lines that all run parallel to the skin.

Here the boundary between layers i and i + 1, nominally at depth b_i below the skin, lies at

    b_i + taper(b_i) * sum_w a_w sin(kx_w x + ky_w y + kz_w b_i + phase_w)

(x across the leg, y along it, phantom frame), a sum of `WAVE_COUNT` plane waves of equal
amplitude a_w = `wave_amplitude` / `WAVE_COUNT`. The kz term makes boundaries at different
depths wave differently (two boundaries `wave_depth_length` / 2 apart are out of phase) while
the two faces of a thin fascia wave together (it keeps its thickness); `taper` = min(1, b /
`wave_taper_depth`) leaves the skin flat under a pressed probe. The layers keep their order:
the boundary's depth is an increasing function of b_i when wave_amplitude * (1 /
wave_taper_depth + 2 pi / wave_depth_length) < 1, which `LayerWaves` checks.

Only the layers move: vessels, nerve, nodes, muscle bellies and bone are where their
geometry puts them, and the texture fields stay as they were. The specular echo of a
boundary keeps its strength at any slope (the echo kernel does not see the boundary's tilt).
"""

from __future__ import annotations

import math
from dataclasses import dataclass, fields

import numpy as np
from numba import njit

WAVE_COUNT = 3
"""Plane waves summed per boundary field."""
WAVELENGTH_SPREAD = (0.7, 1.4)
"""Each wave's length across the leg is `wave_length` times a factor drawn in this range."""
WAVE_ANGLE = math.pi / 4
"""Each wave's crests run within this angle (rad) of the leg's axis, so that a transverse
image crosses them (before `wave_elongation` stretches them along the leg)."""


@dataclass(frozen=True)
class LayerWaves:
    """How a subject's layer boundaries wave (lengths in metres)."""

    wave_amplitude: float = 0.0
    """The most a boundary moves from its nominal depth (the sum of the waves' amplitudes)."""
    wave_length: float = 0.020
    """Typical wavelength across the leg (x)."""
    wave_elongation: float = 3.0
    """How many times longer the waves are along the leg (y) than across it: fasciae and
    muscles run along the thigh."""
    wave_depth_length: float = 0.040
    """Depth over which the boundaries' waving goes through a full cycle."""
    wave_taper_depth: float = 0.008
    """Boundaries shallower than this wave proportionally less: the skin stays flat."""
    wave_seed: float = 0.0
    """Seed of the waves' directions, lengths and phases (a float so subjects can draw it)."""

    def __post_init__(self) -> None:
        where = "layer_waves"
        if not self.wave_amplitude >= 0:
            raise ValueError(f"{where}.wave_amplitude must be >= 0, got {self.wave_amplitude}")
        for name in ("wave_length", "wave_elongation", "wave_depth_length", "wave_taper_depth"):
            if not getattr(self, name) > 0:
                raise ValueError(f"{where}.{name} must be positive, got {getattr(self, name)}")
        steepness = self.wave_amplitude * (
            1.0 / self.wave_taper_depth + 2.0 * math.pi / self.wave_depth_length
        )
        if not steepness < 1.0:
            raise ValueError(
                f"{where}: wave_amplitude {self.wave_amplitude} is too large for "
                f"wave_taper_depth {self.wave_taper_depth} and wave_depth_length "
                f"{self.wave_depth_length} (the layers could cross; amplitude * (1 / taper + "
                f"2 pi / depth length) = {steepness:.2f}, must be < 1)"
            )

    @classmethod
    def keys(cls) -> tuple[str, ...]:
        """The parameter names (the keys of a spec's `layer_waves:` and of its variation)."""
        return tuple(f.name for f in fields(cls))

    def taper(self, bottoms: np.ndarray) -> np.ndarray:
        """The factor each boundary nominally at `bottoms` (m) waves by: min(1, b / taper)."""
        return np.minimum(1.0, np.asarray(bottoms) / self.wave_taper_depth)

    def reach(self, bottoms: np.ndarray) -> np.ndarray:
        """The most each boundary nominally at `bottoms` (m) can move: the amplitude, tapered."""
        return self.wave_amplitude * self.taper(bottoms)

    def waves(self) -> np.ndarray:
        """(WAVE_COUNT, 5) rows of amplitude, kx, ky, kz (rad/m) and phase: the kernels' form.
        Zero rows when the amplitude is 0 (no boundary moves)."""
        if self.wave_amplitude == 0:
            return np.zeros((0, 5))
        rng = np.random.default_rng(int(self.wave_seed))
        angle = rng.uniform(-WAVE_ANGLE, WAVE_ANGLE, WAVE_COUNT)
        across = 2.0 * math.pi / (self.wave_length * rng.uniform(*WAVELENGTH_SPREAD, WAVE_COUNT))
        kz = 2.0 * math.pi / self.wave_depth_length * rng.choice((-1.0, 1.0), WAVE_COUNT)
        phase = rng.uniform(0.0, 2.0 * math.pi, WAVE_COUNT)
        amplitude = np.full(WAVE_COUNT, self.wave_amplitude / WAVE_COUNT)
        kx = across * np.cos(angle)
        ky = across * np.sin(angle) / self.wave_elongation
        return np.stack([amplitude, kx, ky, kz, phase], axis=1)


@njit(cache=True, inline="always")
def boundary_shift(x, y, bottom, waves, taper):
    """How far (m, positive deeper) the boundary nominally at depth `bottom`, waving by the
    factor `taper` (`LayerWaves.taper`), lies from it below the phantom-frame point (x, y)."""
    shift = 0.0
    for w in range(waves.shape[0]):
        shift += waves[w, 0] * math.sin(
            waves[w, 1] * x + waves[w, 2] * y + waves[w, 3] * bottom + waves[w, 4]
        )
    return shift * taper


@njit(cache=True, inline="always")
def layer_at(depth, x, y, bottoms, waves, taper, reach):
    """Index of the layer at `depth` below the skin above (x, y): boundary i (nominally at
    `bottoms[i]`, waving by `taper[i]`) moved by `boundary_shift`, which is evaluated only
    within `reach[i]` (the most it can move, `LayerWaves.reach`) of it, so most points cost
    what flat layers did."""
    layer = 0
    while layer < bottoms.shape[0]:
        bottom = bottoms[layer]
        if depth <= bottom - reach[layer]:
            break
        if depth <= bottom + reach[layer] and depth <= bottom + boundary_shift(
            x, y, bottom, waves, taper[layer]
        ):
            break
        layer += 1
    return layer
