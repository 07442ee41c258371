"""Scanner presets: what makes two machines' images of the same tissue look different.

A `ScannerPreset` names the knobs a sonographer or a vendor sets (centre frequency, depth,
focus, gain, TGC sliders, dynamic range, grey map, speckle reduction, clutter, noise) and
turns them into the simulator's `LinearProbe` and `UltrasoundSettings`. Frequency carries
its physics with it: the pulse shortens (axial resolution ~ c / bandwidth), the beam narrows
(lateral FWHM ~ lambda times the F-number), so speckle grows finer, and attenuation in dB
grows with it.

The named presets are YAML files in `assets/scanners/`, each giving only the knobs that differ
from `ScannerPreset`'s defaults; a file of one's own (`scanner_preset("my-machine.yaml")`)
describes another machine the same way. `random_preset(seed)` draws every knob from the
ranges clinical linear-array presets span, so a training set simulated under many presets
does not teach a network one machine's look.
"""

from __future__ import annotations

import dataclasses
import json
import math
from dataclasses import dataclass
from functools import cache
from pathlib import Path
from typing import Any

import numpy as np

from sim.assets import assets_dir, named_or_path
from sim.ultrasound.probe import LinearProbe
from sim.ultrasound.scatterers import mix_seed
from sim.ultrasound.settings import UltrasoundSettings
from sim.yaml_file import read_yaml_file

LATERAL_FWHM_PER_WAVELENGTH_F_NUMBER = 1.02
"""Lateral -6 dB beam width at the focus of a rectangular aperture, in wavelengths times the
F-number (focal depth / aperture width)."""
TGC_SLIDERS = 8
"""Sliders on a console's TGC panel."""


@dataclass(frozen=True)
class ScannerPreset:
    """One scanner and imaging preset. Units SI; dB where named."""

    name: str = "vascular"
    centre_frequency: float = 10.0e6
    """Transmit centre frequency (Hz): 5-14 MHz for linear arrays."""
    depth: float = 0.040
    """Displayed depth (m): 3-8 cm; the pixel spacing follows from it and the image size."""
    focal_depth: float = 0.020
    """Transmit focus (m)."""
    f_number: float = 2.0
    """Focal depth over active aperture; with the wavelength it sets the lateral beam width."""
    fractional_bandwidth: float = 0.7
    gain_db: float = 25.0
    """Display gain (dB; `UltrasoundSettings.gain_db`). 25 dB: the default preset's tissue on
    the `femoral` phantom at about the mean grey of real exports (45-50), its TGC undoing the
    layers (20 dB until that TGC came, 2026-12-04)."""
    dynamic_range_db: float = 60.0
    tgc_sliders_db: tuple[float, ...] = ()
    tgc_attenuation: float | None = None
    """Attenuation the TGC curve undoes (dB/cm/MHz; `UltrasoundSettings.tgc_attenuation`).
    None: the phantom's layers, each undone over its own depths (evenly bright tissue); the
    named presets keep that, `random_preset` draws it from `TGC_ATTENUATION_RANGE`."""
    grey_gamma: float = 1.5
    speckle_smoothing: float = 0.15e-3
    """Gaussian sigma (m) of the speckle-reduction filter across the beam."""
    speckle_smoothing_axial: float | None = None
    """The same along the beam (`UltrasoundSettings.speckle_smoothing_axial`); None: as
    across it (the named presets); 0 in `random_preset`'s (see `RANDOM_RANGES`)."""
    clutter_db: float | None = -6.0
    """Side-lobe haze in lumens (`UltrasoundSettings.clutter_db`); see `RANDOM_RANGES`."""
    clutter_spread: float = 0.1
    """Share of that haze from the whole image width (`UltrasoundSettings.clutter_spread`).
    With the aperture's 10 mm alone, a lumen wider than that darkened towards its middle: in
    seed 0's sim-to-real training sweeps `resus realism`'s lumen middle / outer thirds read
    0.497 / 0.881 (10th percentile / median over the vessels) against 0.644 / 0.934 in
    usgra-seg; 0.1 gives 0.728 / 0.933 (a cruder measure of the same, interior columns in
    thirds: 0.2 and 0.5 made the middle brighter than real at the 10th percentile, 0.82 and
    0.92 against 0.64). The haze from beyond the aperture brightens the lumens as a whole,
    which `RANDOM_RANGES["clutter_db"]` takes back. The simulation-only score did not move
    (five seeds, paired -0.003 +- 0.014; README Sim-to-real): kept because real lumens have
    no slit."""
    electronic_noise_db: float = -12.0
    reverberation: float = 0.3
    """Transducer-face reflection behind the ghosts of strong interfaces
    (`UltrasoundSettings.reverberation`)."""
    persistence: float = 0.3
    """Frame averaging of the live image (`UltrasoundSettings.persistence`)."""
    compound_frames: int = 1
    """Steered frames averaged into each image (`UltrasoundSettings.compound_frames`); 1: off.
    Off in the named presets but `vascular-compound`: each frame costs as much again."""
    compound_angle: float = 0.0
    """The largest steering angle of compounding (rad)."""
    lost_coupling: tuple[float, float] = (0.0, 0.0)
    """Shares of the array's width without coupling at its first and last column
    (`UltrasoundSettings.lost_coupling`): not a machine's setting but how one sweep was held,
    so the named presets keep full contact and `random_preset` sometimes lifts an edge."""

    def __post_init__(self) -> None:
        if not 2.0e6 <= self.centre_frequency <= 20.0e6:
            raise ValueError(
                f"scanner preset {self.name!r}: centre_frequency must be 2-20 MHz, "
                f"got {self.centre_frequency / 1e6:g} MHz"
            )
        if not 0 < self.focal_depth <= self.depth:
            raise ValueError(
                f"scanner preset {self.name!r}: focal_depth must be in (0, depth], "
                f"got {self.focal_depth} for depth {self.depth}"
            )
        if not self.f_number > 0:
            raise ValueError(f"scanner preset {self.name!r}: f_number must be positive")

    @property
    def wavelength(self) -> float:
        """Wavelength at the centre frequency in soft tissue (m)."""
        return UltrasoundSettings.speed_of_sound / self.centre_frequency

    @property
    def lateral_resolution(self) -> float:
        """Lateral FWHM at the focus (m)."""
        return LATERAL_FWHM_PER_WAVELENGTH_F_NUMBER * self.wavelength * self.f_number

    def to_dict(self) -> dict[str, Any]:
        """Every knob as JSON values: what a sweep's provenance and the caches of simulated
        data record, since a preset file edited in place keeps its name."""
        return json.loads(json.dumps(dataclasses.asdict(self)))

    def at_depth(self, depth: float) -> ScannerPreset:
        """This preset with the displayed depth set to `depth` (m), the focus kept at the same
        fraction of it: what a sonographer does to frame the target."""
        scale = depth / self.depth
        return dataclasses.replace(
            self,
            name=f"{self.name}@{depth * 1e3:.1f}mm",
            depth=depth,
            focal_depth=self.focal_depth * scale,
        )

    def probe(self, base: LinearProbe | None = None) -> LinearProbe:
        """`base` (its array width and image size) imaging at this preset's frequency and depth."""
        return dataclasses.replace(
            base or LinearProbe(), centre_frequency=self.centre_frequency, depth=self.depth
        )

    def settings(self, base: UltrasoundSettings | None = None) -> UltrasoundSettings:
        """`base` with this preset's beam, display and noise knobs."""
        return dataclasses.replace(
            base or UltrasoundSettings(),
            fractional_bandwidth=self.fractional_bandwidth,
            lateral_resolution=self.lateral_resolution,
            focal_depth=self.focal_depth,
            gain_db=self.gain_db,
            dynamic_range_db=self.dynamic_range_db,
            tgc_sliders_db=self.tgc_sliders_db,
            tgc_attenuation=self.tgc_attenuation,
            grey_gamma=self.grey_gamma,
            speckle_smoothing=self.speckle_smoothing,
            speckle_smoothing_axial=self.speckle_smoothing_axial,
            clutter_db=self.clutter_db,
            clutter_spread=self.clutter_spread,
            electronic_noise_db=self.electronic_noise_db,
            reverberation=self.reverberation,
            persistence=self.persistence,
            compound_frames=self.compound_frames,
            compound_angle=self.compound_angle,
            lost_coupling=self.lost_coupling,
        )


def scanners_dir() -> Path:
    """Where the named presets live, one YAML file each: `vascular` (the default, a modern
    vascular preset), `vascular-compound` (the same with spatial compounding, three frames,
    +-10 degrees), `vascular-deep`, `nerve`, and `classic` (the simulator's look before
    presets existed: bright, high contrast, black lumens)."""
    return assets_dir() / "scanners"


@cache
def named_presets() -> dict[str, ScannerPreset]:
    """The named presets (`scanners_dir`), by name."""
    paths = sorted(scanners_dir().glob("*.yaml"), key=lambda path: path.stem)
    return {path.stem: load_scanner_preset(path) for path in paths}


def load_scanner_preset(path: str | Path) -> ScannerPreset:
    """A preset from a YAML file: a mapping of `ScannerPreset`'s knobs, each optional (its
    default where absent), named by the file's stem. Every problem is one ValueError naming
    the file."""
    path = Path(path)
    data = read_yaml_file(path, "scanner preset")  # an empty file: the defaults
    knobs = {field.name: field for field in dataclasses.fields(ScannerPreset)}
    del knobs["name"]
    unknown = sorted(set(data) - set(knobs), key=str)
    if unknown:
        raise ValueError(
            f"{path}: unknown knob(s) {', '.join(map(str, unknown))}; known: {', '.join(knobs)}"
        )
    values = {}
    for key, value in data.items():
        try:
            values[key] = _knob(knobs[key].type, value)
        except ValueError as error:
            raise ValueError(f"{path}: {key}: {error}") from None
    try:
        return ScannerPreset(name=path.stem, **values)
    except ValueError as error:  # a knob out of its range
        raise ValueError(f"{path}: {error}") from None


def _knob(kind: object, value: object) -> Any:
    """A YAML value as a knob of the annotated `kind` (`ScannerPreset`'s field types, which
    are strings under postponed annotations): a number, a list of numbers, or null."""
    if value is None and "None" in str(kind):
        return None
    if str(kind).startswith("tuple"):
        if not isinstance(value, list):
            raise ValueError(f"expected a list of numbers, got {value!r}")
        return tuple(_number(item) for item in value)
    if kind == "int":
        if not (isinstance(value, int) and not isinstance(value, bool)):
            raise ValueError(f"expected a whole number, got {value!r}")
        return value
    return _number(value)


def _number(value: object) -> float:
    """A finite number; text such as `7.5e6` too, which YAML 1.1 (PyYAML) reads as a string
    (its floats need a dot and a signed exponent: `7.5e+6`)."""
    try:
        number = float(value) if isinstance(value, int | float | str) else math.nan
    except ValueError:
        number = math.nan
    if isinstance(value, bool) or not math.isfinite(number):
        raise ValueError(f"expected a finite number, got {value!r}")
    return number


RANDOM_RANGES: dict[str, tuple[float, float]] = {
    "centre_frequency": (6.0e6, 14.0e6),
    "depth": (0.020, 0.060),
    "focal_fraction": (0.3, 0.7),
    "f_number": (1.5, 3.0),
    "fractional_bandwidth": (0.5, 0.9),
    "gain_db": (30.0, 44.0),
    "dynamic_range_db": (48.0, 72.0),
    "tgc_slider_db": (-4.0, 4.0),
    "grey_gamma": (1.1, 2.2),
    "speckle_smoothing": (0.0, 0.4e-3),
    "clutter_db": (-7.0, 1.0),
    "electronic_noise_db": (-24.0, -10.0),
    "reverberation": (0.0, 0.5),
    "persistence": (0.0, 0.6),
}
"""Uniform ranges `random_preset` draws from (focus as a fraction of the depth; each TGC
slider independently). Clutter: lumens in real linear-array exports are a few dB darker than
the tissue around them, not black: haze from side lobes, reverberation, the noise floor and the
grey map's lift, all of which this one knob stands for (so it reaches above 0 dB, the mean
scatter power of the tissue beside the lumen, where it lifts that tissue too). Calibrated per
vessel, the mean grey of the lumen's interior over that of the tissue around it: until
2026-12-05 the interior 3 px inside the edge and a ring 4-12 px outside it, in usgra-seg
0.19 / 0.39 / 0.59 (10th / 50th / 90th percentile over its vessels). The 18 `femoral` subjects
of the sim-to-real experiment's seed 0 gave 0.10 / 0.20 / 0.50 with clutter -12 to -1 dB (low
gain or a steep grey map pushed lumens to black) and 0.22 / 0.42 / 0.63 with -4 to +4 dB; once
the TGC compensated less (`TGC_ATTENUATION_RANGE`), which darkens the deep image and with it,
through the grey map, the lumens more than the tissue, -4 to +4 dB gave 0.13 / 0.33 / 0.58,
and -2 to +6 dB 0.17 / 0.40 / 0.66 (0 to +8: 0.22 / 0.48 / 0.73). Gain: 10 dB above the
range first chosen (14-28 dB) for the same reason, which keeps the upper image as bright as
before, and 6 dB more since the TGC compensates less again (30-44 dB; see
`TGC_ATTENUATION_RANGE`). The changes since (that gain, the sonographer's framing, the
saphenous wall) left the lumens brighter against their surroundings: on `resus realism`'s
per-vessel rows (interior and ring scaled with the image; usgra-seg 0.167 / 0.405 / 0.631)
the same subjects read 0.263 / 0.515 / 0.765 at -2 to +6 dB (2026-12-05), and -6 to +2 dB
gives 0.175 / 0.401 / 0.650, at the cost of darker tissue (mean grey 47.6 -> 42.5, real
45.2; window grey SNR 3.7 -> 3.0, real 4.4), which the haze had lifted too. A tenth of the
haze from the whole row (`ScannerPreset.clutter_spread`) lifted them to 0.207 / 0.442 / 0.678;
-7 to +1 dB brings them back to 0.183 / 0.408 / 0.641.

Speckle reduction: 0-0.4 mm across the beam only (`speckle_smoothing_axial` 0; until
2026-12-06 0-0.3 mm alike along and across it). Measured as the network sees the images,
both sets resized to its 128 x 128 input (`resus realism`'s grain at the network's input), the
real exports' grain is 1.55 px along the beam and 8.38 across, seed 0's training
sweeps' 1.93 and 8.15: coarser along the beam, where a scanner's pulse resolves finely.
Smoothing across the beam only (`speckle_smoothing_axial` 0) at 0-0.6 mm made them 1.58 and
9.28, but also laid the tissue's bright lines flatter than the real ones (within 10 degrees of
across the beam 0.569 -> 0.664, real 0.578) and scored no better: paired over four seeds
-0.006 +- 0.022 (p = 0.62), ensembles 0.480 -> 0.477, larger vessels found more often and
small ones less (README Sim-to-real, "Speckle smoothed across the beam only"). Not kept then.
At 0-0.4 mm the grain is 1.55 / 8.00 (real 1.55 / 8.38) and the lines within 10 degrees 0.625,
steeper than 45 degrees 0.023 (real 0.578 / 0.032; alike along and across: 0.569 / 0.061), and
all four seeds scored higher than with the isotropic range, +0.008 +- 0.004 (p = 0.03),
ensembles 0.480 -> 0.493 (README Sim-to-real, "Speckle across the beam, 0-0.4 mm")."""


DRAWN_LAST = ("reverberation", "persistence")
"""Knobs added after the others, drawn after the TGC sliders so that every earlier knob of a
seed's preset stayed as it was."""
COMPOUND_FRAMES = (1, 3, 5)
"""What `random_preset` draws compounding's frame count from, each as likely (a third of the
presets do not compound); drawn after `DRAWN_LAST`, then its angle from
`COMPOUND_ANGLE_RANGE`."""
COMPOUND_ANGLE_RANGE = (0.15, 0.35)
"""Largest steering angle (rad) of a compounding random preset: 9-20 degrees, what compound
presets of linear arrays use."""
LOST_COUPLING_P = 0.25
"""Chance that a random preset's sweep has lost coupling at one edge (drawn after
compounding: whether, which edge, how much)."""
LOST_COUPLING_RANGE = (0.05, 0.25)
"""Share of the array's width that edge loses: a few millimetres to a quarter of the
image, as a probe rocked onto one edge or short of gel leaves it."""


TGC_ATTENUATION_RANGE = (0.2, 0.7)
"""Attenuation (dB/cm/MHz) a random preset's TGC undoes, the same at every depth; drawn
last. Soft tissue attenuates 0.5-1 dB/cm/MHz and a sonographer sets the sliders by eye, so
real exports mostly darken with depth: in usgra-seg the deepest fifth of the imaged area
(vessels left out) has 0.38 times the grey of the second fifth (median; 0.08 / 0.85 at the
10th / 90th percentile). Compensating the deepest layer over the whole depth, as every preset
did until 2026-12-04 (the `femoral` iliopsoas, 1 dB/cm/MHz, under 2-3 cm of fat at 0.6-0.7),
over-compensated the fat: one pressed view of each of 24 `femoral` subjects under its random
preset brightened with depth (ratio 1.12 / 1.67 / 2.45); with 0.3-0.8 the same views gave
0.09 / 0.58 / 1.16 (`resus.experiments.realism` measures the ratio of any set). Per frame in
seed 0's 18 `sim2real` training sweeps, framed as sonographers frame them
(`Sim2RealSettings.target_depth_fraction` 0.25-0.60), 0.3-0.8 gave 0.07 / 0.46 / 1.15 against
0.06 / 0.37 / 0.84 real, and a simulation-only model trained at 0.3-0.8 (framed at 0.35-0.75)
called the real images' dark deep fields vessel, in blobs of up to 30 % of an image; 0.2-0.7
with 6 dB more gain (framed at 0.25-0.65) gives 0.07 / 0.40 / 0.90 (tissue grey by depth
fifth 73 58 47 36 30, real 67 61 47 32 24)."""


def random_preset(seed: int) -> ScannerPreset:
    """A preset with every knob drawn from `RANDOM_RANGES`, deterministic in `seed`."""
    rng = np.random.default_rng([seed, 0x5CA7])
    names = [name for name in RANDOM_RANGES if name not in DRAWN_LAST]
    draw = {name: float(rng.uniform(*RANDOM_RANGES[name])) for name in names}
    sliders = rng.uniform(*RANDOM_RANGES["tgc_slider_db"], TGC_SLIDERS)
    draw |= {name: float(rng.uniform(*RANDOM_RANGES[name])) for name in DRAWN_LAST}
    compound_frames = int(rng.choice(COMPOUND_FRAMES))
    compound_angle = float(rng.uniform(*COMPOUND_ANGLE_RANGE))  # drawn always: one stream
    loses_coupling, last_edge = rng.uniform() < LOST_COUPLING_P, rng.uniform() < 0.5
    lost_share = float(rng.uniform(*LOST_COUPLING_RANGE))  # drawn always: one stream
    lost = lost_share if loses_coupling else 0.0
    tgc_attenuation = float(rng.uniform(*TGC_ATTENUATION_RANGE))
    return ScannerPreset(
        name=f"random-{seed}",
        centre_frequency=draw["centre_frequency"],
        depth=draw["depth"],
        focal_depth=draw["focal_fraction"] * draw["depth"],
        f_number=draw["f_number"],
        fractional_bandwidth=draw["fractional_bandwidth"],
        gain_db=draw["gain_db"],
        dynamic_range_db=draw["dynamic_range_db"],
        tgc_sliders_db=tuple(float(value) for value in sliders),
        tgc_attenuation=tgc_attenuation,
        grey_gamma=draw["grey_gamma"],
        speckle_smoothing=draw["speckle_smoothing"],
        speckle_smoothing_axial=0.0,
        clutter_db=draw["clutter_db"],
        electronic_noise_db=draw["electronic_noise_db"],
        reverberation=draw["reverberation"],
        persistence=draw["persistence"],
        compound_frames=compound_frames,
        compound_angle=compound_angle if compound_frames > 1 else 0.0,
        lost_coupling=(0.0, lost) if last_edge else (lost, 0.0),
    )


def scanner_preset(name: str | Path) -> ScannerPreset:
    """A named preset (`scanners_dir`), `random-N` for `random_preset(N)`, or a YAML file
    (`load_scanner_preset`; a path has a suffix or a folder)."""
    path, named = named_or_path("scanners", name)
    if not named:
        return load_scanner_preset(path)
    presets = named_presets()
    if name in presets:
        return presets[str(name)]
    prefix, _, number = str(name).partition("-")
    if prefix == "random" and number.isdigit():
        return random_preset(int(number))
    raise ValueError(
        f"unknown scanner preset {name!r}; choose one of {', '.join(presets)}, random-N "
        "or a YAML file"
    )


def sweep_preset(name: str | None, seed: int | None, subject: int | None) -> ScannerPreset | None:
    """The scanner preset of one sweep: None for the simulator's own settings, a named
    preset, `random-N`, or `random`: one drawn from the phantom seed and the subject, so each
    subject of a data set is imaged by its own scanner and always by the same one."""
    if name is None:
        return None
    if name == "random":
        return random_preset(int(mix_seed(seed or 0, -1 if subject is None else subject)))
    return scanner_preset(name)
