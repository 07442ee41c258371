"""How close simulated B-mode images come to real ones: grey levels, contrast and speckle.

Each side of the comparison is an `ImageSet`: 8-bit grey images with a vessel mask each, the
labelled frames of simulated sweeps (artery or vein = vessel) or a folder of real images with
masks (`images/NNNN.png`, `masks/NNNN.png`, 255 = lumen). `measure` turns a set into
`RealismStats`, `compare` puts two side by side (`RealismComparison.table()`), and
`write_realism_report` writes realism.json, realism.md and two figures.

Imaged area. Scanners pad the B-mode picture with black margins (above and below a shallow
image, beside a narrow one) and the simulator leaves columns without skin contact black. A
border row or column is margin when at least `blank_fraction` of its pixels are exactly 0 (a
logo or a depth scale's tick marks in the margin do not make it imaged): margins are stripped
from each side inwards (rows first, then columns over the rows left) and the imaged area is
the rectangle that remains. Dark tissue, even a deep shadow, is almost never exactly 0 along a
whole line, so it stays in. Every grey-level figure is pooled over the imaged pixels of the
whole set (each pixel counts once, so larger images weigh more).

Speckle. The envelope's SNR (mean/std of the linear amplitude, 1.91 for fully developed
speckle) cannot be measured on log-compressed grey levels without the scanner's grey map, so
the grey levels' own statistics are measured in tissue windows (`RealismSettings.patch`
pixels square, `vessel_margin` away from every vessel, almost unclipped, locally homogeneous):
the within-window std of the grey levels, compared with the log-compressed Rayleigh reference
`rayleigh_grey_std` where the dynamic range is known (the simulator's), the per-window grey
SNR (mean/std), and the speckle grain: the full widths at half maximum of the windows' 2-D
autocorrelation along the rows (axial) and the columns (lateral), in pixels. In each set's own
pixels the grain says little about what a network sees: a 512 px export and a 256 px frame
of the same speckle differ twofold. So it is measured again with every image resized, as
training and inference resize it (`resus.segmentation.data.resize_images`), to the network's
square input (`RealismSettings.network_size`), in windows of `network_grain_patch` pixels.

Depth. The imaged area's rows are cut into `DEPTH_BANDS` equal bands from the face down, and
the tissue's mean grey in each is the depth profile: real exports mostly darken with depth
(attenuation that the TGC does not wholly undo), and a simulator whose images brighten with
depth teaches a network that vessels are dark holes in a bright floor.

Vessel shapes. Each connected vessel region (8-connected) of at least
`RealismSettings.min_vessel_area` of its image's imaged area is one vessel cross-section. Its
aspect is sqrt(l1 / l2) of its second moments' eigenvalues, each pixel a unit square (so a
uniform ellipse of semi-axes a >= b gives a / b, and a one-pixel line stays finite); its area
and its centre's depth are shares of the imaged area and height, so that 256 px frames and
512 px exports compare alike. A vein pressed flat shows as a region over `ELONGATED_ASPECT`
times longer than wide: common in simulation at a heavy probe force, rare in real scans made
with the light touch of a vascular examination. How far a cross-section is from an ellipse:
the overlap (IoU) of each region that the picture does not cut with the uniform ellipse of its
centroid and second moments, 1 for an exact ellipse (up to its pixels' edges); a vein, whose
thin wall takes the shape its neighbours press into it, is a rounded polygon more often.

Vessel placement. Where the sonographer puts the vessels across the picture: each image's
vessel centroid (the mean column of the pixels of its counted regions, a share of the imaged
width) and its distance from the middle, 0 to 0.5. A simulated probe centred over the vessels
shows them in the middle and little of what lies beside them; real images, aimed at a nerve
or a branch, often show them to one side. An image whose centroid lies `OFF_SIDE_OFFSET` or
more from the middle shows its vessels in an outer quarter. And how many vessel
regions the picture cuts: those touching the imaged area's side or bottom (the face is not an
edge a vessel can cross). Vessels wide apart in a narrow field are cut more often.

Vessel walls. A wall echoes brightly where the beam meets it square (above and below the
lumen: a specular reflection) and hardly at all beside it, where the beam grazes it; a wall
drawn as a bright ring all round is a cue no real image offers. For each vessel region, the
mean grey of a band just outside the lumen (`RealismSettings.wall_band` of the imaged height
wide, other vessels left out) over that of the ring two to four band widths out, beside the
lumen (where the wall's normal, the direction from the nearest lumen pixel, lies within 30
degrees of the rows) and above and below it (within 30 degrees of the columns, the beam): 1
where the wall is no brighter than the tissue beyond it.

The tissue round a vessel. What lies around a lumen, past its wall, decides what a dark
region looks like to a reader: real femoral lumens lie in brighter tissue than the fat beside
it (the connective tissue of the vessels' sheath), a simulator that puts them straight into the
fat draws a dark moat round a thin bright ring. For each region, the mean grey of the ring one
to four wall bands out (other vessels left out) beside the lumen, above it and below it (the
wall figures' sectors), over the mean grey of the tissue in those same pixels' rows (vessels
left out, the whole width of the image): 1 where the vessel's surroundings are as bright as
the rest of their depth, whatever the depth's own brightness.

Bright lines. Fasciae, septa and perimysium echo where the beam meets them square: real images
show them as streaks across the beam, a simulator that draws them alike at every angle as a
honeycomb with a tail of steep lines. The tissue's bright lines (clear of the vessels by the
speckle's margin or three of the line scale's sigmas, whichever is more) and the angle of each
one's normal to the beam, `resus.experiments.line_orientation`: the share within 10 degrees of
across the beam, and the share steeper than 45 degrees.

Vessel lumens. The pooled lumen/tissue ratio weighs every lumen pixel against all the tissue
of the set, at every depth; what a reader (or a network) sees is each lumen against the tissue
around it. So each vessel region also gets its lumen contrast: the mean grey of its interior
(more than one wall band inside its edge, clear of the wall's blur) over that of the same ring
two to four band widths out, all round. Real lumens are seldom black, and seldom nearly as
bright as their surroundings; a simulator that fills them with too much haze teaches a network
to call grey tissue vessel. And a lumen's interior is about as bright in its middle as towards
its sides: each region's middle third of the interior's columns over its outer two thirds (no
figure for a region cut by the image's side, whose middle is not the lumen's). Haze taken from
the tissue beside a lumen alone leaves a dark slit down the middle of a lumen wider than that
reach, a cue no real image offers.

Dark tissue. What a network must learn not to call vessel: tissue as dark as the lumens, at
their depth. Each image that shows a vessel region is smoothed with a Gaussian whose standard
deviation is one wall band (a region's darkness is judged over an area, not a speckle grain);
the lumens' level is the median smoothed grey of the regions' interiors (more than a band
inside the edge), and the figure is the share of the tissue in the rows the regions span, more
than four bands from every vessel (past the lumen contrast's ring), whose smoothed grey is at
most that level. Real groins show muscle bellies and fat lobules as dark as the vessels beside
them; a simulator whose vessels are the darkest thing at their depth teaches a network that
the darkest blob there is the vessel.
"""

from __future__ import annotations

import json
import math
from collections.abc import Callable, Mapping, Sequence
from dataclasses import asdict, dataclass, field
from itertools import pairwise
from pathlib import Path
from typing import TYPE_CHECKING, NamedTuple

import numpy as np

from resus.errors import ResusError
from resus.experiments.line_orientation import (
    ANGLE_BIN_DEGREES,
    EDGE_SIGMAS,
    LINE_SCALE,
    LINE_SHARE,
    bright_line_normals,
    line_angle_counts,
    line_scale_pixels,
    share_between,
)
from resus.indices import evenly_spaced
from sim.labels import VESSEL_CLASSES
from sim.ultrasound.settings import UltrasoundSettings

if TYPE_CHECKING:
    from matplotlib.figure import Figure

GREY_LEVELS = 256
REAL_CREDIT = "real: tmkand/usgra-seg (CC BY 4.0)"
"""The real images' licence asks for this credit wherever they or figures of them are shown."""
SIMULATOR_DYNAMIC_RANGE_DB = UltrasoundSettings().dynamic_range_db
"""The simulator's default display dynamic range, for sweeps whose provenance lacks theirs."""
RAYLEIGH_LOG_STD_DB = 10.0 / math.log(10.0) * math.pi / math.sqrt(6.0)
"""Standard deviation of log-compressed fully developed speckle: 5.57 dB.

The envelope A of fully developed speckle is Rayleigh distributed, so the intensity I = A^2 is
exponential: I = I0 E with E ~ Exp(1). Log compression shows 20 log10 A = 10 log10 I =
10 log10 I0 + (10 / ln 10) ln E, and Var(ln E) = psi'(1) = pi^2 / 6 (the trigamma function at
1), so the standard deviation is (10 / ln 10) pi / sqrt(6) = 5.57 dB, whatever I0 (the
tissue's echogenicity, the gain, the TGC) is.
"""
DEPTH_BANDS = 5
"""Equal bands of the imaged area's depth in the depth profile (fifths)."""
QUANTILES = (0.1, 0.25, 0.5, 0.75, 0.9)
"""Which quantiles of the per-window grey SNR and of the vessel shapes are reported."""
TENTH, MEDIAN, NINETIETH = (QUANTILES.index(q) for q in (0.1, 0.5, 0.9))
REALISM_JSON = "realism.json"
REALISM_MD = "realism.md"
SIM_VS_REAL_PNG = "sim_vs_real.png"
HISTOGRAMS_PNG = "histograms.png"
OUTLINE_COLOUR = "yellow"
"""Vessel outline in the figures (the real masks do not tell artery from vein)."""
SET_COLOURS = {"simulated": "tab:orange", "real": "tab:blue"}
WALL_SECTOR = math.pi / 6
"""Largest angle of a wall's normal from the rows (beside a lumen) or from the columns
(above or below it) in the wall figures."""
MIN_CONTRAST_PIXELS = 10
"""Fewest pixels a lumen's interior, a wall band (in a sector) or its reference ring needs to
give a figure."""
ELONGATED_ASPECT = 3.0
"""A vessel region longer than this many times its width counts as flattened."""
OFF_SIDE_OFFSET = 0.25
"""An image's vessel centroid this far (a share of the imaged width) or further from the
middle lies in an outer quarter: the vessels shown to one side."""
PIXEL_SECOND_MOMENT = 1.0 / 12.0
"""Second moment of a unit square about its centre along either axis: what each pixel adds to
a region's covariance when the region is the union of its pixels' squares."""


def rayleigh_grey_std(dynamic_range_db: float) -> float:
    """Grey-level std of log-compressed fully developed speckle on a display that maps
    `dynamic_range_db` onto 256 grey levels (255 / DR grey levels per dB): 28.4 at 50 dB."""
    return RAYLEIGH_LOG_STD_DB * (GREY_LEVELS - 1) / dynamic_range_db


@dataclass(frozen=True)
class RealismSettings:
    """How the imaged area and the speckle windows are chosen (pixels)."""

    patch: int = 16
    """Side of the windows in which the speckle's grey std and SNR are measured."""
    grain_patch: int = 32
    """Side of the windows whose autocorrelation gives the grain size. Each window's own mean
    is removed, which narrows a 5-7 px wide autocorrelation by about 4 % at 32 px (by 10 % and
    more at 16 px); a grain near the window's size cannot be measured."""
    network_size: int = 128
    """Side of the square network input (the `cpu128` training preset's) that every image is
    resized to for the grain as a network sees it."""
    network_grain_patch: int = 16
    """Side of the windows of that grain (at `network_size`)."""
    vessel_margin: float = 8.0
    """Least distance of a speckle window's pixels from any vessel pixel."""
    blank_fraction: float = 0.95
    """Share of exactly-black pixels that makes a border row or column margin."""
    max_clipped: float = 0.05
    """Largest share of a window's pixels at grey 0 or 255 (clipping narrows the spread)."""
    homogeneity: float = 1.0
    """A window is homogeneous when its four quadrants' means span at most this many of its
    grey std: fine fully developed speckle spans a quarter to a half of it, an edge or a
    fascia across the window far more."""
    min_vessel_area: float = 0.0005
    """Smallest vessel region in the shape figures, as a share of its image's imaged area:
    0.05 % is a lumen 1.3 mm across in a 5 cm square image, smaller than any femoral vessel
    or great saphenous vein, larger than a label's stray corner at the image's edge."""
    wall_band: float = 0.015
    """Width of the band outside a lumen whose grey is its wall's, as a share of the imaged
    height (0.6 mm of a 4 cm image: a femoral wall and its blur); the reference ring lies two
    to four such widths out, and the lumen's interior starts one width inside its edge."""

    def __post_init__(self) -> None:
        for name in ("patch", "grain_patch", "network_grain_patch"):
            size = getattr(self, name)
            if size < 4 or size % 2:
                raise ResusError(f"RealismSettings.{name} must be even and >= 4, got {size}")
        if not self.vessel_margin >= 0:
            raise ResusError(
                f"RealismSettings.vessel_margin must be >= 0, got {self.vessel_margin}"
            )
        for name in ("blank_fraction", "max_clipped"):
            if not 0 < getattr(self, name) <= 1:
                raise ResusError(
                    f"RealismSettings.{name} must be in (0, 1], got {getattr(self, name)}"
                )
        if not self.homogeneity > 0:
            raise ResusError(
                f"RealismSettings.homogeneity must be positive, got {self.homogeneity}"
            )
        if not 0 <= self.min_vessel_area < 1:
            raise ResusError(
                f"RealismSettings.min_vessel_area must be in [0, 1), got {self.min_vessel_area}"
            )
        if not 0 < self.wall_band < 0.25:
            raise ResusError(
                f"RealismSettings.wall_band must be in (0, 0.25), got {self.wall_band}"
            )


@dataclass(frozen=True)
class ImageSet:
    """One side of the comparison: grey images, their vessel masks and where each came from."""

    name: str
    images: tuple[np.ndarray, ...]
    """2-D uint8 grey images, any sizes."""
    vessels: tuple[np.ndarray, ...]
    """Bool masks of the vessel lumens, one per image, same shape."""
    sources: tuple[str, ...]
    """Where each image came from ("sweep.h5 #12", "0003.png")."""
    dynamic_range_db: float | None = None
    """The display dynamic range when it is known (simulated images), for the Rayleigh
    reference; real images do not record it."""

    def __post_init__(self) -> None:
        if not self.images:
            raise ResusError(f"the {self.name} image set is empty")
        if not len(self.images) == len(self.vessels) == len(self.sources):
            raise ResusError(
                f"the {self.name} image set has {len(self.images)} images, "
                f"{len(self.vessels)} masks and {len(self.sources)} sources"
            )
        for image, vessel, source in zip(self.images, self.vessels, self.sources, strict=True):
            if image.dtype != np.uint8 or image.ndim != 2:
                raise ResusError(f"{source}: expected a 2-D uint8 grey image, got {image.shape}")
            if vessel.dtype != np.bool_ or vessel.shape != image.shape:
                raise ResusError(f"{source}: expected a bool mask of shape {image.shape}")

    def __len__(self) -> int:
        return len(self.images)


@dataclass(frozen=True)
class SpeckleStats:
    """Grey-level speckle statistics over a set's tissue windows."""

    patches: int
    """Windows measured (`RealismSettings.patch` square)."""
    std: float
    """Grey-level std within a window, root mean square over the windows."""
    snr_quantiles: tuple[float, ...]
    """Quantiles `QUANTILES` of the windows' grey SNR (mean / std)."""
    dynamic_range_db: float | None
    """The set's display dynamic range (`ImageSet.dynamic_range_db`; None: not known)."""
    rayleigh_std: float | None
    """The log-compressed Rayleigh std at that dynamic range (`rayleigh_grey_std`)."""
    std_to_rayleigh: float | None
    """`std / rayleigh_std`: 1 for fully developed speckle, below 1 for smoothed speckle."""
    implied_dynamic_range_db: float
    """The dynamic range at which fully developed speckle would show this std."""
    grain_patches: int
    """Windows (`RealismSettings.grain_patch` square) in the autocorrelation."""
    grain_axial: float | None
    """Full width at half maximum of the autocorrelation along the rows (px)."""
    grain_lateral: float | None
    """The same along the columns (px)."""
    network_grain_patches: int
    """Windows (`RealismSettings.network_grain_patch` square) of the images resized to the
    network's input."""
    network_grain_axial: float | None
    """The grain along the rows of the images resized to the network's input (px there)."""
    network_grain_lateral: float | None
    """The same along the columns."""


@dataclass(frozen=True)
class VesselShapeStats:
    """The vessel cross-sections of a set: how many, how elongated, how large, how deep."""

    regions: int
    """Vessel regions counted (at least `RealismSettings.min_vessel_area`)."""
    showing_share: float
    """Share of the images that show at least one such region."""
    aspect_quantiles: tuple[float, ...]
    """Quantiles `QUANTILES` of the regions' aspect (length over width, >= 1)."""
    elongated_share: float
    """Share of the regions more than `ELONGATED_ASPECT` times longer than wide."""
    area_quantiles: tuple[float, ...]
    """Quantiles `QUANTILES` of the regions' areas, as shares of their images' imaged area."""
    depth_quantiles: tuple[float, ...]
    """Quantiles `QUANTILES` of the regions' centre depths, as shares of the imaged height
    (0: the face, 1: the bottom)."""
    centroid_offset_quantiles: tuple[float, ...]
    """Quantiles `QUANTILES`, over the images that show a vessel region, of the distance of
    their vessel centroid from the middle, as a share of the imaged width (0 to 0.5)."""
    off_side_share: float
    """Share of those images whose centroid lies `OFF_SIDE_OFFSET` or more from the middle."""
    cut_share: float
    """Share of the regions that touch the imaged area's side or bottom (cut by the picture)."""
    aspects: tuple[float, ...]
    """Every region's aspect, for the figure's distribution."""
    ellipse_fit_quantiles: tuple[float, ...] | None
    """Quantiles `QUANTILES` of the uncut regions' overlap (IoU) with their moment ellipse
    (`ellipse_fit`; None when the picture cuts every region)."""
    wall_lateral_quantiles: tuple[float, ...] | None
    """Quantiles `QUANTILES` of the regions' wall grey over the tissue's beyond it, beside the
    lumen (module docstring; None when no region has enough pixels there)."""
    wall_axial_quantiles: tuple[float, ...] | None
    """The same above and below the lumen."""
    lumen_quantiles: tuple[float, ...] | None
    """Quantiles `QUANTILES` of the regions' lumen contrast: interior grey over the tissue's
    around it (module docstring; None when no region has an interior that wide)."""
    lumen_middle_quantiles: tuple[float, ...] | None
    """Quantiles `QUANTILES` of the regions' interior grey in the middle third of its columns
    over the outer thirds' (module docstring; None when no region gives one)."""
    round_beside_quantiles: tuple[float, ...] | None
    """Quantiles `QUANTILES` of the tissue round the regions, beside them, over their rows'
    (module docstring)."""
    round_above_quantiles: tuple[float, ...] | None
    """The same above them."""
    round_below_quantiles: tuple[float, ...] | None
    """The same below them."""
    dark_tissue_quantiles: tuple[float, ...] | None
    """Quantiles `QUANTILES`, over the images that show a vessel region, of the share of the
    tissue at the vessels' depth that is as dark as their lumens (`dark_tissue_share`; None
    when no image gives one)."""


@dataclass(frozen=True)
class RealismStats:
    """Grey levels, contrast and speckle of one image set, pooled over its imaged area."""

    name: str
    images: int
    pixels: int
    """Imaged pixels (the margins stripped)."""
    histogram: tuple[float, ...]
    """Share of the imaged pixels at each grey level 0..255 (sums to 1)."""
    mean: float
    median: float
    p5: float
    p95: float
    tissue_mean: float
    """Mean grey of the imaged pixels outside the vessels."""
    lumen_mean: float | None
    """Mean grey of the vessel pixels (None when no image shows a vessel)."""
    lumen_tissue: float | None
    """`lumen_mean / tissue_mean`."""
    contrast_db: float | None
    """20 log10(lumen_tissue): a contrast of grey levels, that is, after log compression."""
    cnr: float | None
    """Contrast-to-noise ratio |tissue - lumen| / sqrt(var tissue + var lumen)."""
    depth_profile: tuple[float | None, ...]
    """Mean tissue grey of each of the `DEPTH_BANDS` depth bands, face first (None for a
    band without tissue)."""
    depth_falloff: float | None
    """The deepest band's tissue grey over the second's: below 1, the image darkens with
    depth. The second band, not the first, because the first holds the skin and the probe's
    near field."""
    depth_falloff_quantiles: tuple[float, ...] | None
    """Quantiles `QUANTILES` of the same ratio image by image (None when no image has tissue
    in both bands): the pooled ratio hides how often a frame goes dark at depth."""
    speckle: SpeckleStats | None
    """None when no window qualifies."""
    vessel_shapes: VesselShapeStats | None
    """None when no image shows a vessel region."""
    line_angle_shares: tuple[float, ...] | None
    """Share of the tissue's bright-line pixels in each `ANGLE_BIN_DEGREES` bin of their
    normal's angle to the beam, 0 to 90 degrees (module docstring; None without any)."""

    def to_dict(self) -> dict:
        return asdict(self)


TableRow = tuple[str, Callable[[RealismStats], float | None], int]


def _speckle(get: Callable[[SpeckleStats], float | None]) -> Callable[[RealismStats], float | None]:
    """A table row's getter of a speckle figure: None for a set without tissue windows."""
    return lambda stats: None if stats.speckle is None else get(stats.speckle)


def _shapes(
    get: Callable[[VesselShapeStats], float | None],
) -> Callable[[RealismStats], float | None]:
    """A table row's getter of a vessel-shape figure: None for a set without vessel regions."""
    return lambda stats: None if stats.vessel_shapes is None else get(stats.vessel_shapes)


def _per_vessel(figure: str, quantile: int) -> Callable[[RealismStats], float | None]:
    """A table row's getter of one quantile of a per-region figure: `figure` a contrast
    ("lumen", "lumen_middle", "wall_lateral", "wall_axial" or "round_beside", "_above",
    "_below"), "ellipse_fit" or the per-image "dark_tissue"."""

    def get(shapes: VesselShapeStats) -> float | None:
        quantiles = getattr(shapes, f"{figure}_quantiles")
        return None if quantiles is None else quantiles[quantile]

    return _shapes(get)


def _falloffs(quantile: int) -> Callable[[RealismStats], float | None]:
    """A table row's getter of one quantile of the per-image depth falloff."""
    return lambda s: (
        None if s.depth_falloff_quantiles is None else s.depth_falloff_quantiles[quantile]
    )


def _lines(low: float, high: float) -> Callable[[RealismStats], float | None]:
    """A table row's getter of the share of bright lines `low` to `high` degrees steep."""
    return lambda s: (
        None if s.line_angle_shares is None else share_between(s.line_angle_shares, low, high)
    )


def _band(band: int) -> Callable[[RealismStats], float | None]:
    """A table row's getter of one depth band's tissue grey."""
    return lambda stats: stats.depth_profile[band]


TABLE: tuple[TableRow, ...] = (
    ("mean grey", lambda s: s.mean, 1),
    ("median grey", lambda s: s.median, 1),
    ("tissue mean", lambda s: s.tissue_mean, 1),
    ("lumen mean", lambda s: s.lumen_mean, 1),
    ("lumen/tissue", lambda s: s.lumen_tissue, 3),
    ("5th percentile", lambda s: s.p5, 1),
    ("95th percentile", lambda s: s.p95, 1),
    ("contrast (dB)", lambda s: s.contrast_db, 2),
    ("CNR", lambda s: s.cnr, 3),
    *((f"tissue grey, depth fifth {band + 1}", _band(band), 1) for band in range(DEPTH_BANDS)),
    ("deepest / second fifth", lambda s: s.depth_falloff, 3),
    ("deepest / second fifth, per image median", _falloffs(MEDIAN), 3),
    ("deepest / second fifth, per image 90th percentile", _falloffs(NINETIETH), 3),
    ("speckle std (grey)", _speckle(lambda s: s.std), 2),
    ("speckle std / Rayleigh", _speckle(lambda s: s.std_to_rayleigh), 3),
    ("implied dynamic range (dB)", _speckle(lambda s: s.implied_dynamic_range_db), 1),
    ("window grey SNR, median", _speckle(lambda s: s.snr_quantiles[MEDIAN]), 2),
    ("grain axial FWHM (px)", _speckle(lambda s: s.grain_axial), 2),
    ("grain lateral FWHM (px)", _speckle(lambda s: s.grain_lateral), 2),
    ("grain axial FWHM at the network's input (px)", _speckle(lambda s: s.network_grain_axial), 2),
    (
        "grain lateral FWHM at the network's input (px)",
        _speckle(lambda s: s.network_grain_lateral),
        2,
    ),
    ("bright lines within 10 degrees of across the beam (share)", _lines(0, 10), 3),
    ("bright lines steeper than 45 degrees (share)", _lines(45, 90), 3),
    ("vessel regions", _shapes(lambda s: s.regions), 0),
    ("images showing a vessel (share)", _shapes(lambda s: s.showing_share), 3),
    ("vessel aspect, median", _shapes(lambda s: s.aspect_quantiles[MEDIAN]), 2),
    ("vessel aspect, 90th percentile", _shapes(lambda s: s.aspect_quantiles[NINETIETH]), 2),
    (
        f"vessels over {ELONGATED_ASPECT:g}x longer than wide (share)",
        _shapes(lambda s: s.elongated_share),
        3,
    ),
    (
        "vessel outline / its moment ellipse (IoU), uncut, 10th percentile",
        _per_vessel("ellipse_fit", TENTH),
        3,
    ),
    (
        "vessel outline / its moment ellipse (IoU), uncut, median",
        _per_vessel("ellipse_fit", MEDIAN),
        3,
    ),
    ("vessel area, median (% of image)", _shapes(lambda s: 100 * s.area_quantiles[MEDIAN]), 2),
    ("vessel centre depth, median (share)", _shapes(lambda s: s.depth_quantiles[MEDIAN]), 3),
    (
        "vessel centroid off the middle, per image, median (share of the width)",
        _shapes(lambda s: s.centroid_offset_quantiles[MEDIAN]),
        3,
    ),
    (
        f"images with their vessels {OFF_SIDE_OFFSET:g} or more off the middle (share)",
        _shapes(lambda s: s.off_side_share),
        3,
    ),
    ("vessels cut by the picture's side or bottom (share)", _shapes(lambda s: s.cut_share), 3),
    ("lumen / tissue around it, per vessel, 10th percentile", _per_vessel("lumen", TENTH), 3),
    ("lumen / tissue around it, per vessel, median", _per_vessel("lumen", MEDIAN), 3),
    ("lumen / tissue around it, per vessel, 90th percentile", _per_vessel("lumen", NINETIETH), 3),
    (
        "lumen middle / outer thirds, per vessel, 10th percentile",
        _per_vessel("lumen_middle", TENTH),
        3,
    ),
    ("lumen middle / outer thirds, per vessel, median", _per_vessel("lumen_middle", MEDIAN), 3),
    ("wall / tissue beyond, beside the lumen, median", _per_vessel("wall_lateral", MEDIAN), 2),
    ("wall / tissue beyond, above and below, median", _per_vessel("wall_axial", MEDIAN), 2),
    (
        "wall / tissue beyond, above and below, 90th percentile",
        _per_vessel("wall_axial", NINETIETH),
        2,
    ),
    ("tissue round the lumen / its rows', beside, median", _per_vessel("round_beside", MEDIAN), 2),
    ("tissue round the lumen / its rows', above, median", _per_vessel("round_above", MEDIAN), 2),
    ("tissue round the lumen / its rows', below, median", _per_vessel("round_below", MEDIAN), 2),
    (
        "tissue at the vessels' depth as dark as their lumens, per image, median (share)",
        _per_vessel("dark_tissue", MEDIAN),
        3,
    ),
    (
        "tissue at the vessels' depth as dark as their lumens, per image, 90th percentile",
        _per_vessel("dark_tissue", NINETIETH),
        3,
    ),
)
"""The comparison's rows: label, the figure of a set, decimals shown. The first five are the
issue's table; speckle rows are None for a set without tissue windows."""


@dataclass(frozen=True)
class RealismComparison:
    """A simulated and a real set measured alike."""

    simulated: RealismStats
    real: RealismStats
    settings: RealismSettings = field(default_factory=RealismSettings)

    def table(self) -> list[tuple[str, float | None, float | None]]:
        """(figure, simulated, real) for each row of `TABLE`."""
        return [(label, get(self.simulated), get(self.real)) for label, get, _ in TABLE]

    def to_dict(self) -> dict:
        return {
            "credit": REAL_CREDIT,
            "settings": asdict(self.settings),
            "table": [
                {"figure": label, "simulated": sim, "real": real}
                for label, sim, real in self.table()
            ],
            "simulated": self.simulated.to_dict(),
            "real": self.real.to_dict(),
        }

    def to_markdown(self) -> list[str]:
        """The table as Markdown lines."""
        lines = ["| figure | simulated | real |", "| --- | ---: | ---: |"]
        for (label, sim, real), (_, _, digits) in zip(self.table(), TABLE, strict=True):
            lines.append(f"| {label} | {_shown(sim, digits)} | {_shown(real, digits)} |")
        return lines


def _shown(value: float | None, digits: int) -> str:
    return "n/a" if value is None else f"{value:.{digits}f}"


# ---- reading the two sides -------------------------------------------------------------


def read_sweep_set(
    paths: Sequence[str | Path],
    frames: int | None = None,
    dynamic_range_db: float | None = None,
    name: str = "simulated",
) -> ImageSet:
    """`frames` evenly spaced labelled frames of each sweep (all of them when None); the
    vessel mask is every class of the sweep's vocabulary that is a vessel (artery, vein).
    `dynamic_range_db` (None: the sweeps' own, from their provenance, or the simulator's
    default for sweeps without one; unknown when the sweeps differ) sets the Rayleigh
    reference."""
    from resus.sweep.io import SweepReader

    images: list[np.ndarray] = []
    vessels: list[np.ndarray] = []
    sources: list[str] = []
    ranges: set[object] = set()
    for path in map(Path, paths):
        with SweepReader(path) as reader:
            if not reader.has_labels:
                raise ResusError("the sweep has no labels (realism needs its vessels)", path)
            if len(reader) == 0:
                raise ResusError("the sweep holds no frames", path)
            ranges.add(reader.provenance.get("dynamic_range_db", SIMULATOR_DYNAMIC_RANGE_DB))
            values = [v for v, label in enumerate(reader.label_names) if label in VESSEL_CLASSES]
            for index in evenly_spaced(len(reader), frames or len(reader)):
                frame = reader.frame(index)
                assert frame.label is not None  # the reader has labels (checked above)
                images.append(frame.image)
                vessels.append(np.isin(frame.label, values))
                sources.append(f"{path.name} #{index}")
    if dynamic_range_db is None and len(ranges) == 1:
        only = ranges.pop()
        dynamic_range_db = float(only) if isinstance(only, int | float) else None
    return ImageSet(name, tuple(images), tuple(vessels), tuple(sources), dynamic_range_db)


def read_image_folder(folder: str | Path, name: str = "real") -> ImageSet:
    """Every image of `folder/images` with its `folder/masks` namesake (nonzero = vessel),
    read by `resus.segmentation.folders.read_data_set` like a training set."""
    from resus.segmentation.folders import read_data_set

    data = read_data_set(Path(folder))
    vessels = tuple(labels > 0 for labels in data.labels)
    return ImageSet(name, data.images, vessels, data.names)


# ---- measuring ----------------------------------------------------------------------------


def imaged_region(image: np.ndarray, blank_fraction: float = 0.95) -> tuple[slice, slice]:
    """(rows, cols) slices of the imaged rectangle: border rows, then border columns, with at
    least `blank_fraction` of their pixels exactly 0 stripped from each side inwards."""
    black = np.asarray(image) == 0
    rows = _inner_span(black.mean(axis=1) >= blank_fraction)
    if rows.stop == rows.start:
        return rows, rows
    return rows, _inner_span(black[rows].mean(axis=0) >= blank_fraction)


def _inner_span(blank: np.ndarray) -> slice:
    """The lines from the first to the last that is not blank (empty when all are)."""
    kept = np.flatnonzero(~blank)
    return slice(int(kept[0]), int(kept[-1]) + 1) if kept.size else slice(0, 0)


def _blocks(array: np.ndarray, size: int) -> np.ndarray:
    """(n, size, size) non-overlapping tiles of a 2-D array, row by row from its corner."""
    rows, cols = array.shape[0] // size, array.shape[1] // size
    tiles = array[: rows * size, : cols * size].reshape(rows, size, cols, size)
    return tiles.swapaxes(1, 2).reshape(-1, size, size)


def tissue_windows(
    image: np.ndarray, usable: np.ndarray, size: int, settings: RealismSettings
) -> np.ndarray:
    """(n, size, size) float tiles of `image` that lie wholly in `usable`, have at most
    `max_clipped` of their pixels at 0 or 255 and are homogeneous (`homogeneity`)."""
    keep = _blocks(usable, size).all(axis=(1, 2))
    tiles = _blocks(image, size)[keep].astype(np.float64)
    clipped = ((tiles == 0) | (tiles == GREY_LEVELS - 1)).mean(axis=(1, 2))
    half = size // 2
    quadrants = tiles.reshape(-1, 2, half, 2, half).mean(axis=(2, 4)).reshape(-1, 4)
    spread = quadrants.max(axis=1) - quadrants.min(axis=1)
    std = tiles.std(axis=(1, 2), ddof=1)
    good = (clipped <= settings.max_clipped) & (std > 0) & (spread <= settings.homogeneity * std)
    return tiles[good]


class _Accumulator:
    """Running sums over a set's images: histograms of tissue and lumen grey levels, the
    speckle windows' means and variances, and the sum of their autocorrelations (each
    scaled to 1 at lag 0, so that every window weighs the same)."""

    def __init__(self, settings: RealismSettings) -> None:
        self.settings = settings
        self.tissue = np.zeros(GREY_LEVELS, np.int64)
        self.lumen = np.zeros(GREY_LEVELS, np.int64)
        self.band_sums = np.zeros(DEPTH_BANDS)
        self.band_pixels = np.zeros(DEPTH_BANDS, np.int64)
        self.falloffs: list[float] = []
        """Each image's own deepest / second band ratio."""
        self.window_means: list[np.ndarray] = []
        self.window_variances: list[np.ndarray] = []
        self.grain = _GrainSums(settings.grain_patch)
        self.network_grain = _GrainSums(settings.network_grain_patch)
        self.regions: list[tuple[float, float, float]] = []
        """(aspect, area share, depth share) of each vessel region."""
        self.centroid_offsets: list[float] = []
        """Each image's vessel centroid's distance from the middle (share of the width), one
        per image that shows a vessel region."""
        self.cut = 0
        """Vessel regions that touch the imaged area's side or bottom."""
        self.ellipse_fits: list[float] = []
        """Each uncut vessel region's overlap with its moment ellipse (`ellipse_fit`)."""
        self.contrasts: list[VesselContrast] = []
        """Lumen and wall contrasts of each vessel region."""
        self.dark_tissue: list[float | None] = []
        """Each image's share of the tissue at its vessels' depth as dark as their lumens."""
        self.line_angles = np.zeros(round(90 / ANGLE_BIN_DEGREES), np.int64)
        """Bright-line pixels per bin of their normal's angle to the beam."""

    def add(self, image: np.ndarray, vessel: np.ndarray) -> None:
        self._add_network_grain(image, vessel)
        region = imaged_region(image, self.settings.blank_fraction)
        image, vessel = image[region], vessel[region]
        self.tissue += np.bincount(image[~vessel], minlength=GREY_LEVELS)
        self.lumen += np.bincount(image[vessel], minlength=GREY_LEVELS)
        edges = np.arange(DEPTH_BANDS + 1) * image.shape[0] // DEPTH_BANDS
        sums, pixels = np.zeros(DEPTH_BANDS), np.zeros(DEPTH_BANDS, np.int64)
        for band, (top, bottom) in enumerate(pairwise(edges)):
            tissue = image[top:bottom][~vessel[top:bottom]]
            sums[band], pixels[band] = tissue.sum(dtype=np.float64), tissue.size
        self.band_sums += sums
        self.band_pixels += pixels
        falloff = depth_falloff(_band_means(sums, pixels))
        if falloff is not None:
            self.falloffs.append(falloff)
        clearance = _vessel_clearance(vessel)
        usable = ~vessel & (clearance >= self.settings.vessel_margin)
        line_margin = max(self.settings.vessel_margin, EDGE_SIGMAS * line_scale_pixels(len(image)))
        self.line_angles += line_angle_counts(
            bright_line_normals(image, ~vessel & (clearance >= line_margin))
        )
        windows = tissue_windows(image, usable, self.settings.patch, self.settings)
        self.window_means.append(windows.mean(axis=(1, 2)))
        self.window_variances.append(windows.var(axis=(1, 2), ddof=1))
        self.grain.add(tissue_windows(image, usable, self.settings.grain_patch, self.settings))
        regions = _regions(vessel, self.settings.min_vessel_area)  # labelled once for both
        self.regions.extend(_region_shape(vessel, region) for region in regions)
        settings = self.settings
        self.contrasts.extend(
            vessel_contrasts(image, vessel, settings.min_vessel_area, settings.wall_band, regions)
        )
        uncut = [region for region in regions if not is_cut(vessel.shape, region)]
        self.cut += len(regions) - len(uncut)
        self.ellipse_fits.extend(map(ellipse_fit, uncut))
        if regions:
            self.centroid_offsets.append(centroid_offset(vessel, regions))
            self.dark_tissue.append(
                dark_tissue_share(
                    image, vessel, settings.min_vessel_area, settings.wall_band, regions, clearance
                )
            )

    def _add_network_grain(self, image: np.ndarray, vessel: np.ndarray) -> None:
        """The grain's windows of the whole image resized to the network's input (margins
        and all, as the network is given it), then cut to its imaged area; the vessel margin
        shrinks with the image."""
        from resus.segmentation.data import resize_images, resize_labels

        settings, size = self.settings, self.settings.network_size
        small = resize_images(image[None], size)[0]
        small_vessel = resize_labels(vessel[None].astype(np.uint8), size)[0] > 0
        region = imaged_region(small, settings.blank_fraction)
        small, small_vessel = small[region], small_vessel[region]
        margin = settings.vessel_margin * size / image.shape[0]
        usable = ~small_vessel & (_vessel_clearance(small_vessel) >= margin)
        self.network_grain.add(
            tissue_windows(small, usable, settings.network_grain_patch, settings)
        )

    def depth_profile(self) -> tuple[float | None, ...]:
        """Mean tissue grey of each depth band (None where a band had no tissue)."""
        return _band_means(self.band_sums, self.band_pixels)

    def speckle(self, dynamic_range_db: float | None) -> SpeckleStats | None:
        means = np.concatenate(self.window_means)
        variances = np.concatenate(self.window_variances)
        if not len(means):
            return None
        std = float(np.sqrt(variances.mean()))
        rayleigh = None if dynamic_range_db is None else rayleigh_grey_std(dynamic_range_db)
        axial, lateral = self.grain.widths()
        network_axial, network_lateral = self.network_grain.widths()
        return SpeckleStats(
            patches=len(means),
            std=std,
            snr_quantiles=_quantiles(means / np.sqrt(variances)),
            dynamic_range_db=dynamic_range_db,
            rayleigh_std=rayleigh,
            std_to_rayleigh=None if rayleigh is None else std / rayleigh,
            implied_dynamic_range_db=RAYLEIGH_LOG_STD_DB * (GREY_LEVELS - 1) / std,
            grain_patches=self.grain.patches,
            grain_axial=axial,
            grain_lateral=lateral,
            network_grain_patches=self.network_grain.patches,
            network_grain_axial=network_axial,
            network_grain_lateral=network_lateral,
        )

    def vessel_shapes(self, images: int) -> VesselShapeStats | None:
        if not self.regions:
            return None
        aspects, areas, depths = (np.array(column) for column in zip(*self.regions, strict=True))
        offsets = np.array(self.centroid_offsets)
        return VesselShapeStats(
            regions=len(aspects),
            showing_share=len(self.centroid_offsets) / images,
            aspect_quantiles=_quantiles(aspects),
            elongated_share=float((aspects > ELONGATED_ASPECT).mean()),
            area_quantiles=_quantiles(areas),
            depth_quantiles=_quantiles(depths),
            centroid_offset_quantiles=_quantiles(offsets),
            off_side_share=float((offsets >= OFF_SIDE_OFFSET).mean()),
            cut_share=self.cut / len(aspects),
            aspects=tuple(float(a) for a in aspects),
            ellipse_fit_quantiles=_present_quantiles(self.ellipse_fits),
            wall_lateral_quantiles=_present_quantiles([c.beside for c in self.contrasts]),
            wall_axial_quantiles=_present_quantiles([c.above_below for c in self.contrasts]),
            lumen_quantiles=_present_quantiles([c.lumen for c in self.contrasts]),
            lumen_middle_quantiles=_present_quantiles([c.lumen_middle for c in self.contrasts]),
            round_beside_quantiles=_present_quantiles([c.round_beside for c in self.contrasts]),
            round_above_quantiles=_present_quantiles([c.round_above for c in self.contrasts]),
            round_below_quantiles=_present_quantiles([c.round_below for c in self.contrasts]),
            dark_tissue_quantiles=_present_quantiles(self.dark_tissue),
        )


def _vessel_clearance(vessel: np.ndarray) -> np.ndarray:
    """Each pixel's distance (px) from the nearest vessel pixel; inf in an image without."""
    from scipy import ndimage

    if not vessel.any():
        return np.full(vessel.shape, np.inf)
    return ndimage.distance_transform_edt(~vessel)


class _GrainSums:
    """The sum of square tissue windows' autocorrelations, each scaled to 1 at lag 0 (so that
    every window weighs the same), and what it says about the speckle's grain."""

    def __init__(self, size: int) -> None:
        self.size = size
        self.correlation = np.zeros((2 * size, 2 * size))
        self.patches = 0

    def add(self, windows: np.ndarray) -> None:
        """Add (n, size, size) windows, each less its own mean."""
        if not len(windows):
            return
        centred = windows - windows.mean(axis=(1, 2), keepdims=True)
        spectrum = np.fft.rfft2(centred, s=self.correlation.shape)
        correlations = np.fft.irfft2(np.abs(spectrum) ** 2, s=self.correlation.shape)
        self.correlation += (correlations / correlations[:, :1, :1]).sum(axis=0)
        self.patches += len(windows)

    def widths(self) -> tuple[float | None, float | None]:
        """Axial and lateral FWHM (px) of the windows' mean autocorrelation, each lag's sum
        divided by the pixel pairs at that lag (the unbiased estimate); None without windows."""
        if not self.patches:
            return None, None
        overlap = self.size - np.arange(self.size)
        axial = self.correlation[: self.size, 0] / overlap
        lateral = self.correlation[0, : self.size] / overlap
        return (
            full_width_half_maximum(axial / axial[0]),
            full_width_half_maximum(lateral / lateral[0]),
        )


def _band_means(sums: np.ndarray, pixels: np.ndarray) -> tuple[float | None, ...]:
    """Mean grey of each band from its sum and pixel count (None for a band without any)."""
    return tuple(
        float(total / count) if count else None for total, count in zip(sums, pixels, strict=True)
    )


def depth_falloff(profile: Sequence[float | None]) -> float | None:
    """The deepest band's grey over the second's (None when either has no tissue, or the
    second is black)."""
    second, deepest = profile[1], profile[-1]
    return deepest / second if second and deepest is not None else None


Region = tuple[tuple[slice, slice], np.ndarray, np.ndarray]
"""A vessel region: its bounding box, and its pixels' rows and columns within it."""


def _regions(vessel: np.ndarray, min_area: float) -> list[Region]:
    """(bounding box, rows, columns within it) of each 8-connected region of the imaged
    area's vessel mask `vessel` that covers at least `min_area` of it."""
    from scipy import ndimage

    if not vessel.any():
        return []
    labelled, _ = ndimage.label(vessel, structure=np.ones((3, 3), bool))
    found = []
    for label, region in enumerate(ndimage.find_objects(labelled), start=1):
        assert region is not None  # the labels run from 1 without gaps
        rows, cols = np.nonzero(labelled[region] == label)
        if rows.size >= max(1.0, min_area * vessel.size):
            found.append((region, rows, cols))
    return found


def vessel_regions(vessel: np.ndarray, min_area: float) -> list[tuple[float, float, float]]:
    """(aspect, area share, centre depth share) of each 8-connected region of the imaged
    area's vessel mask `vessel` that covers at least `min_area` of it (module docstring)."""
    return [_region_shape(vessel, region) for region in _regions(vessel, min_area)]


def centroid_offset(vessel: np.ndarray, regions: Sequence[Region]) -> float:
    """Distance of the mean column of `regions`' pixels from the middle of the imaged area
    `vessel`, as a share of its width (module docstring, "Vessel placement")."""
    columns = np.concatenate([box[1].start + cols for box, _, cols in regions])
    return abs((columns.mean() + 0.5) / vessel.shape[1] - 0.5)  # pixel centres at col + 0.5


def is_cut(shape: tuple[int, ...], region: Region) -> bool:
    """Whether `region` of an imaged area of `shape` touches its side or bottom."""
    rows, columns = region[0]
    return columns.start == 0 or columns.stop == shape[1] or rows.stop == shape[0]


def _region_moments(region: Region) -> tuple[np.ndarray, np.ndarray]:
    """(its pixels' (rows, cols) within the box, their second moments): each pixel a unit
    square, so the covariance of their centres plus a square's own `PIXEL_SECOND_MOMENT`."""
    _, rows, cols = region
    points = np.stack([rows, cols]).astype(np.float64)
    return points, np.cov(points, bias=True) + PIXEL_SECOND_MOMENT * np.eye(2)


def _region_shape(vessel: np.ndarray, region: Region) -> tuple[float, float, float]:
    """(aspect, area share, centre depth share) of one region of `vessel`."""
    box, rows, _ = region
    _, covariance = _region_moments(region)
    smallest, largest = np.linalg.eigvalsh(covariance)
    centre_row = box[0].start + rows.mean() + 0.5  # pixel centres lie at row + 0.5
    return math.sqrt(largest / smallest), rows.size / vessel.size, centre_row / vessel.shape[0]


def ellipse_fit(region: Region) -> float:
    """IoU of `region` with the uniform ellipse of its centroid and second moments (each pixel
    a unit square, as for the aspect: a uniform ellipse's second moment along an axis is a
    quarter of its semi-axis squared), counted over pixel centres: 1 for an exact ellipse up
    to its pixels' edges, less the more its outline bends in and out of one."""
    _, rows, cols = region
    points, covariance = _region_moments(region)
    centre = points.mean(axis=1)
    reach = 2.0 * math.sqrt(float(np.linalg.eigvalsh(covariance)[-1]))  # its semi-major axis
    low = np.floor(np.minimum(points.min(axis=1), centre - reach)).astype(int)
    high = np.ceil(np.maximum(points.max(axis=1), centre + reach)).astype(int) + 1
    grid_rows, grid_cols = np.mgrid[low[0] : high[0], low[1] : high[1]]
    offsets = np.stack([grid_rows - centre[0], grid_cols - centre[1]], axis=-1)
    inside = np.einsum("...i,ij,...j->...", offsets, np.linalg.inv(covariance), offsets) <= 4.0
    member = np.zeros(inside.shape, bool)
    member[rows - low[0], cols - low[1]] = True
    return float((inside & member).sum() / (inside | member).sum())


class VesselContrast(NamedTuple):
    """One vessel region's contrasts (module docstring), each None where too few pixels
    (`MIN_CONTRAST_PIXELS`) give it."""

    lumen: float | None
    """Interior grey over the tissue's around the lumen."""
    beside: float | None
    """Wall grey over the tissue's beyond it, beside the lumen."""
    above_below: float | None
    """The same above and below the lumen."""
    lumen_middle: float | None
    """Interior grey in the middle third of the region's columns over the outer thirds'
    (None for a region that touches the image's side)."""
    round_beside: float | None
    """The ring 1-4 bands outside the lumen, beside it, over its rows' tissue."""
    round_above: float | None
    """The same above the lumen."""
    round_below: float | None
    """The same below the lumen."""


def vessel_contrasts(
    image: np.ndarray,
    vessel: np.ndarray,
    min_area: float,
    band: float,
    regions: list[Region] | None = None,
) -> list[VesselContrast]:
    """The lumen and wall contrasts of each vessel region of the imaged area `image` (module
    docstring): against the mean grey of the ring 2-4 `band`s of the imaged height outside the
    lumen (other vessels left out), the lumen's pixels more than a band inside its edge, and
    the wall's at most a band outside it, each wall pixel beside the lumen or above or below
    it by the direction from the nearest lumen pixel (the wall's normal), within `WALL_SECTOR`
    of the rows or of the columns; the interior's middle third of columns over its outer
    thirds; and the ring 1-4 bands out over its rows' tissue. `regions`: the regions of at
    least `min_area` (`_regions`), when they are already found."""
    if regions is None:
        regions = _regions(vessel, min_area)
    if not regions:
        return []
    tissue = ~vessel
    row_tissue = (image * tissue).sum(axis=1) / np.maximum(tissue.sum(axis=1), 1)
    return [_region_contrasts(image, vessel, region, band, row_tissue) for region in regions]


def _region_contrasts(
    image: np.ndarray, vessel: np.ndarray, region: Region, band: float, row_tissue: np.ndarray
) -> VesselContrast:
    """The lumen and wall contrasts of one region of `vessel` (`vessel_contrasts`)."""
    from scipy import ndimage

    box, rows, cols = region
    width = max(1.0, band * vessel.shape[0])
    reach = math.ceil(4 * width) + 1
    top, left = max(0, box[0].start - reach), max(0, box[1].start - reach)
    window = (
        slice(top, min(vessel.shape[0], box[0].stop + reach)),
        slice(left, min(vessel.shape[1], box[1].stop + reach)),
    )
    lumen = np.zeros(vessel[window].shape, bool)
    lumen[rows + box[0].start - top, cols + box[1].start - left] = True
    distance, (nearest_row, nearest_col) = ndimage.distance_transform_edt(
        ~lumen, return_indices=True
    )
    outside = ~vessel[window]
    near = outside & (distance <= width)
    far = outside & (distance > 2 * width) & (distance <= 4 * width)
    interior = ndimage.distance_transform_edt(lumen) > width
    row, col = np.indices(lumen.shape)
    # the wall's normal, from the nearest lumen pixel: 0 beside the lumen, pi / 2 above or
    # below it (along the beam)
    angle = np.arctan2(np.abs(row - nearest_row), np.abs(col - nearest_col))
    grey = image[window].astype(np.float64)
    beside, above_below = angle <= WALL_SECTOR, angle >= math.pi / 2 - WALL_SECTOR
    above, below = above_below & (row < nearest_row), above_below & (row > nearest_row)
    ring = outside & (distance > width) & (distance <= 4 * width)
    rows_tissue = np.broadcast_to(row_tissue[window[0]][:, None], ring.shape)
    first, stop = box[1].start - left, box[1].stop - left
    third = (stop - first) / 3
    middle = (col >= first + third) & (col < stop - third)
    cut = box[1].start == 0 or box[1].stop == vessel.shape[1]
    sides = (beside, above, below)
    return VesselContrast(
        _mean_ratio(grey[interior], grey[far]),
        _mean_ratio(grey[near & beside], grey[far & beside]),
        _mean_ratio(grey[near & above_below], grey[far & above_below]),
        None if cut else _mean_ratio(grey[interior & middle], grey[interior & ~middle]),
        *(_mean_ratio(grey[ring & side], rows_tissue[ring & side]) for side in sides),
    )


def dark_tissue_share(
    image: np.ndarray,
    vessel: np.ndarray,
    min_area: float,
    band: float,
    regions: Sequence[Region] | None = None,
    clearance: np.ndarray | None = None,
) -> float | None:
    """Share of the imaged area `image`'s tissue in the rows that the regions of at least
    `min_area` of the mask `vessel` span, more than four `band`s of the imaged height from
    every vessel, whose grey smoothed over a band is at most the regions' interiors' median
    (module docstring, "Dark tissue"). None without regions, or with fewer than
    `MIN_CONTRAST_PIXELS` interior or tissue pixels. `regions` (`_regions`) and `clearance`
    (`_vessel_clearance(vessel)`): when they are already found."""
    from scipy import ndimage

    if regions is None:
        regions = _regions(vessel, min_area)
    if not regions:
        return None
    width = max(1.0, band * vessel.shape[0])
    lumens = np.zeros(vessel.shape, bool)
    for box, rows, cols in regions:
        lumens[rows + box[0].start, cols + box[1].start] = True
    interior = ndimage.distance_transform_edt(lumens) > width
    if clearance is None:
        clearance = _vessel_clearance(vessel)
    top = min(box[0].start for box, _, _ in regions)
    bottom = max(box[0].stop for box, _, _ in regions)
    tissue = np.zeros(vessel.shape, bool)
    tissue[top:bottom] = clearance[top:bottom] > 4 * width
    if min(interior.sum(), tissue.sum()) < MIN_CONTRAST_PIXELS:
        return None
    smoothed = ndimage.gaussian_filter(image.astype(np.float64), width)
    return float((smoothed[tissue] <= np.median(smoothed[interior])).mean())


def _mean_ratio(part: np.ndarray, reference: np.ndarray) -> float | None:
    """`part`'s mean grey over `reference`'s; None when either has fewer than
    `MIN_CONTRAST_PIXELS` pixels or the reference is black."""
    enough = min(part.size, reference.size) >= MIN_CONTRAST_PIXELS and reference.mean() > 0
    return float(part.mean() / reference.mean()) if enough else None


def _present_quantiles(values: Sequence[float | None]) -> tuple[float, ...] | None:
    """`_quantiles` of the values that are not None (None when none is)."""
    present = np.array([value for value in values if value is not None])
    return _quantiles(present) if present.size else None


def _quantiles(values: np.ndarray) -> tuple[float, ...]:
    return tuple(float(q) for q in np.quantile(values, QUANTILES))


def full_width_half_maximum(profile: np.ndarray) -> float | None:
    """Twice the lag at which a symmetric profile, given from lag 0 (= 1) on, first falls below
    one half, linearly interpolated; None when it never does."""
    below = np.flatnonzero(profile < 0.5)
    if not below.size:
        return None
    k = int(below[0])
    high, low = profile[k - 1], profile[k]
    return float(2.0 * (k - 1 + (high - 0.5) / (high - low)))


def _quantile(counts: np.ndarray, q: float) -> float:
    """The lowest grey level at which the cumulative share of `counts` reaches `q`."""
    return float(np.searchsorted(np.cumsum(counts), q * counts.sum()))


def _moments(counts: np.ndarray) -> tuple[float, float]:
    """Mean and variance of the grey levels counted in `counts`."""
    levels = np.arange(GREY_LEVELS)
    mean = float((counts * levels).sum() / counts.sum())
    return mean, float((counts * (levels - mean) ** 2).sum() / counts.sum())


def measure(images: ImageSet, settings: RealismSettings | None = None) -> RealismStats:
    """Grey levels, contrast and speckle of `images` (see the module's docstring)."""
    settings = settings or RealismSettings()
    sums = _Accumulator(settings)
    for image, vessel in zip(images.images, images.vessels, strict=True):
        sums.add(image, vessel)
    counts = sums.tissue + sums.lumen
    if not counts.sum() or not sums.tissue.sum():
        raise ResusError(f"the {images.name} images show no imaged tissue (all black?)")
    mean, _ = _moments(counts)
    tissue_mean, tissue_variance = _moments(sums.tissue)
    lumen_mean = ratio = contrast = cnr = None
    if sums.lumen.sum():
        lumen_mean, lumen_variance = _moments(sums.lumen)
        ratio = lumen_mean / tissue_mean
        contrast = 20.0 * math.log10(ratio) if ratio > 0 else None
        noise = math.sqrt(tissue_variance + lumen_variance)
        cnr = abs(tissue_mean - lumen_mean) / noise if noise > 0 else None
    profile = sums.depth_profile()
    return RealismStats(
        name=images.name,
        images=len(images),
        pixels=int(counts.sum()),
        histogram=tuple(float(c) for c in counts / counts.sum()),
        mean=mean,
        median=_quantile(counts, 0.5),
        p5=_quantile(counts, 0.05),
        p95=_quantile(counts, 0.95),
        tissue_mean=tissue_mean,
        lumen_mean=lumen_mean,
        lumen_tissue=ratio,
        contrast_db=contrast,
        cnr=cnr,
        depth_profile=profile,
        depth_falloff=depth_falloff(profile),
        depth_falloff_quantiles=_quantiles(np.array(sums.falloffs)) if sums.falloffs else None,
        speckle=sums.speckle(images.dynamic_range_db),
        vessel_shapes=sums.vessel_shapes(len(images)),
        line_angle_shares=(
            tuple(float(c) for c in sums.line_angles / sums.line_angles.sum())
            if sums.line_angles.any()
            else None
        ),
    )


def compare(
    simulated: ImageSet, real: ImageSet, settings: RealismSettings | None = None
) -> RealismComparison:
    """Both sets measured with the same settings."""
    settings = settings or RealismSettings()
    return RealismComparison(measure(simulated, settings), measure(real, settings), settings)


# ---- figures and the report ----------------------------------------------------------------


def save_sim_vs_real_png(
    path: str | Path,
    simulated: ImageSet,
    real: ImageSet,
    count: int = 4,
    settings: RealismSettings | None = None,
) -> Path:
    """`count` simulated images (top row) over `count` real ones with a vessel (bottom row),
    evenly chosen, each cut to its imaged area with its vessels outlined; credited."""
    from matplotlib.figure import Figure

    blank_fraction = (settings or RealismSettings()).blank_fraction
    rows = [(simulated, _with_vessels(simulated, count)), (real, _with_vessels(real, count))]
    columns = max(len(indices) for _, indices in rows)
    figure = Figure(figsize=(3.0 * columns, 5.9))
    panels = figure.subplots(2, columns, squeeze=False)
    for row, (images, indices) in zip(panels, rows, strict=True):
        for panel in row:
            panel.set_axis_off()
        for panel, index in zip(row, indices, strict=False):
            region = imaged_region(images.images[index], blank_fraction)
            panel.imshow(images.images[index][region], cmap="gray", vmin=0, vmax=255)
            vessel = images.vessels[index][region]
            if vessel.any():
                panel.contour(vessel, levels=[0.5], colors=OUTLINE_COLOUR, linewidths=0.8)
            panel.set_title(f"{images.name}: {images.sources[index]}", fontsize=8)
    figure.suptitle("simulated (top) and real (bottom) B-mode images, vessel lumens outlined")
    figure.text(0.5, 0.01, REAL_CREDIT, ha="center", fontsize=9)
    figure.tight_layout(rect=(0, 0.03, 1, 1))
    return _save(figure, Path(path), 90)


def _with_vessels(images: ImageSet, count: int) -> list[int]:
    """`count` evenly spaced indices of the images that show a vessel (of all, if none do)."""
    showing = [i for i, vessel in enumerate(images.vessels) if vessel.any()] or list(
        range(len(images))
    )
    return [showing[i] for i in evenly_spaced(len(showing), count)]


def save_histograms_png(path: str | Path, comparison: RealismComparison) -> Path:
    """Both sets' grey-level histograms overlaid, bars of the table's grey figures and of the
    lumen/tissue ratio, their depth profiles, their vessels' aspect distributions and the
    angles of their tissue's bright lines; credited."""
    from matplotlib.figure import Figure

    sets = (comparison.simulated, comparison.real)
    figure = Figure(figsize=(27, 4.4))
    histogram, greys, ratios, depths, aspects, lines = figure.subplots(
        1, 6, width_ratios=(2.2, 2.0, 0.9, 1.4, 1.6, 1.6)
    )
    for stats in sets:
        colour = SET_COLOURS.get(stats.name)
        label = f"{stats.name} ({stats.images} images)"
        histogram.step(
            np.arange(GREY_LEVELS), stats.histogram, where="mid", color=colour, label=label
        )
        histogram.axvline(stats.mean, color=colour, linestyle="--", linewidth=0.8)
    histogram.set_xlim(0, GREY_LEVELS - 1)
    histogram.set_xlabel("grey level (imaged area)")
    histogram.set_ylabel("share of pixels")
    histogram.set_title("grey-level histograms (dashed: means)")
    histogram.legend()
    figures = [(label, get) for label, get, _ in TABLE[:4]]
    width = 0.38
    for offset, stats in zip((-width / 2, width / 2), sets, strict=True):
        values = [get(stats) or 0.0 for _, get in figures]
        colour = SET_COLOURS.get(stats.name)
        greys.bar(np.arange(len(figures)) + offset, values, width, color=colour, label=stats.name)
        ratios.bar(offset, stats.lumen_tissue or 0.0, width, color=colour, label=stats.name)
        profile = [np.nan if grey is None else grey for grey in stats.depth_profile]
        depths.plot(profile, np.arange(DEPTH_BANDS) + 1, "o-", color=colour, label=stats.name)
        if stats.vessel_shapes is not None:
            ordered = np.sort(stats.vessel_shapes.aspects)
            shares = np.arange(1, len(ordered) + 1) / len(ordered)
            label = f"{stats.name} ({len(ordered)} vessels)"
            aspects.step(ordered, shares, where="post", color=colour, label=label)
        if stats.line_angle_shares is not None:
            edges = np.arange(len(stats.line_angle_shares) + 1) * ANGLE_BIN_DEGREES
            density = np.array(stats.line_angle_shares) / ANGLE_BIN_DEGREES
            lines.stairs(density, edges, color=colour, label=stats.name)
    greys.set_xticks(np.arange(len(figures)), [label for label, _ in figures])
    greys.set_ylim(0, GREY_LEVELS - 1)
    greys.set_ylabel("grey level")
    greys.set_title("grey levels")
    greys.legend()
    ratios.set_xticks([0], ["lumen/tissue"])
    ratios.set_ylim(0, 1)
    ratios.set_title("lumen/tissue mean")
    depths.set_ylim(DEPTH_BANDS + 0.5, 0.5)  # the face at the top, as in the image
    depths.set_yticks(np.arange(DEPTH_BANDS) + 1)
    depths.set_xlim(0, GREY_LEVELS - 1)
    depths.set_xlabel("tissue mean grey")
    depths.set_ylabel("depth fifth of the imaged area")
    depths.set_title("grey by depth")
    depths.legend()
    aspects.axvline(ELONGATED_ASPECT, color="grey", linestyle=":", linewidth=0.8)
    aspects.set_xscale("log")
    aspects.set_xlim(1, 20)
    aspects.set_ylim(0, 1)
    aspects.set_xlabel("vessel aspect (length / width)")
    aspects.set_ylabel("share of vessel regions at or below")
    aspects.set_title("vessel shapes (dotted: flattened)")
    aspects.legend()
    lines.set_yscale("log")
    lines.set_xlim(0, 90)
    lines.set_xlabel("normal to the beam (degrees; 0: a line across it)")
    lines.set_ylabel("share of bright-line pixels per degree")
    lines.set_title("which way the tissue's bright lines run")
    lines.legend()
    figure.suptitle(f"simulated vs real grey levels   ({REAL_CREDIT})")
    figure.tight_layout()
    return _save(figure, Path(path), 90)


def _save(figure: Figure, path: Path, dpi: int) -> Path:
    path.parent.mkdir(parents=True, exist_ok=True)
    figure.savefig(path, dpi=dpi)
    return path


def write_realism_report(
    out: str | Path,
    simulated: ImageSet,
    real: ImageSet,
    settings: RealismSettings | None = None,
    sources: Mapping[str, object] | None = None,
) -> RealismComparison:
    """Measure both sets and write realism.json, realism.md, sim_vs_real.png and
    histograms.png into `out`; `sources` (what was read) goes into both texts."""
    out = Path(out)
    comparison = compare(simulated, real, settings)
    summary = {"sources": dict(sources or {}), **comparison.to_dict()}
    try:
        out.mkdir(parents=True, exist_ok=True)
        (out / REALISM_JSON).write_text(json.dumps(summary, indent=2) + "\n")
        save_sim_vs_real_png(out / SIM_VS_REAL_PNG, simulated, real, settings=comparison.settings)
        save_histograms_png(out / HISTOGRAMS_PNG, comparison)
        lines = _report_lines(comparison, summary["sources"])
        (out / REALISM_MD).write_text("\n".join(lines) + "\n")
    except OSError as error:
        raise ResusError(
            f"cannot write the report there ({error.strerror or error})", out
        ) from None
    return comparison


def _dynamic_range(stats: RealismStats) -> str:
    """The set's display dynamic range as the report words it."""
    speckle = stats.speckle
    if speckle is None or speckle.dynamic_range_db is None:
        return "unknown"
    return f"{speckle.dynamic_range_db:g} dB"


def _report_lines(comparison: RealismComparison, sources: Mapping[str, object]) -> list[str]:
    settings = comparison.settings
    sim, real = comparison.simulated, comparison.real
    return [
        "# Realism: simulated against real B-mode images",
        "",
        f"Simulated: {sim.images} frames ({sim.pixels:,} imaged pixels); real: {real.images} "
        f"images ({real.pixels:,} imaged pixels).",
        "",
        f"Credit: {REAL_CREDIT}.",
        "",
        *comparison.to_markdown(),
        "",
        "Grey levels are pooled over the imaged area of every image (border rows and columns "
        f"with at least {settings.blank_fraction:.0%} black pixels stripped); lumen = vessel "
        "pixels, tissue = the rest of the imaged area. Speckle: grey levels in "
        f"{settings.patch} px tissue windows at least {settings.vessel_margin:g} px from a "
        "vessel, homogeneous and unclipped (the Rayleigh reference is the 5.57 dB std of "
        f"log-compressed speckle at the simulated display's {_dynamic_range(sim)} dynamic "
        "range; real images do not record theirs); grain: autocorrelation FWHM over "
        f"{settings.grain_patch} px windows, in each set's own pixels, and again with every "
        f"image resized to the network's {settings.network_size} x {settings.network_size} px "
        f"input, over {settings.network_grain_patch} px windows. Bright lines: ridges "
        f"of the Hessian at a sigma of {LINE_SCALE:.1%} of the imaged height, the strongest "
        f"{LINE_SHARE:.0%} of each image's tissue clear of the vessels, by the angle of their "
        "normal to the beam (a line across the beam: 0 degrees). Vessel shapes: each "
        f"connected vessel region of at least {settings.min_vessel_area:.2%} of its image's "
        "imaged area; aspect = sqrt of its second moments' eigenvalue ratio (length over "
        "width), area and centre depth as shares of the imaged area and height; outline: "
        "each uncut region's IoU with the uniform ellipse of its second moments; placement: "
        "each image's vessel centroid (mean column of its regions' pixels) off the middle, as "
        "a share of the width; cut: regions touching the imaged area's side or bottom. Per "
        "vessel: "
        f"the lumen's interior (more than {settings.wall_band:.1%} of the imaged height inside "
        "its edge) and the wall band (that wide, outside it; beside the lumen or above and "
        "below it by the wall's normal) over the tissue two to four such bands out; the "
        "interior's middle third of columns over its outer thirds.",
        "",
        f"![simulated and real images]({SIM_VS_REAL_PNG})",
        f"![grey-level histograms]({HISTOGRAMS_PNG})",
        "",
        "## Sources",
        "",
        *(f"- {key}: {value}" for key, value in sources.items()),
    ]
