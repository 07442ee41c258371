"""What `resus realism` measures: its settings and the figures of one image set, typed.

The figures are defined where they are measured: `speckle` (grey-level speckle and its grain),
`vessels` (the vessel cross-sections, their walls, lumens and surroundings, the dark tissue
beside them), `line_orientation` (the tissue's bright lines) and `measurement` (grey levels and
their depth profile).
"""

from __future__ import annotations

from dataclasses import asdict, dataclass

from resus.errors import ResusError

GREY_LEVELS = 256
DEPTH_BANDS = 5
"""Equal bands of the imaged area's depth in the depth profile (fifths)."""
QUANTILES = (0.1, 0.25, 0.5, 0.75, 0.9)
"""Which quantiles of the per-window grey SNR and of the vessel shapes are reported."""
TENTH, MEDIAN, NINETIETH = (QUANTILES.index(q) for q in (0.1, 0.5, 0.9))


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
class SpeckleStats:
    """Grey-level speckle statistics over a set's tissue windows."""

    patches: int
    """Windows measured (`RealismSettings.patch` square)."""
    std: float
    """Grey-level std within a window, root mean square over the windows."""
    snr_quantiles: tuple[float, ...]
    """Quantiles `QUANTILES` of the windows' grey SNR (mean / std)."""
    dynamic_range_db: float | None
    """The set's display dynamic range (`images.ImageSet.dynamic_range_db`; None: not known)."""
    rayleigh_std: float | None
    """The log-compressed Rayleigh std at that dynamic range (`speckle.rayleigh_grey_std`)."""
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
    """Share of the regions more than `vessels.ELONGATED_ASPECT` times longer than wide."""
    area_quantiles: tuple[float, ...]
    """Quantiles `QUANTILES` of the regions' areas, as shares of their images' imaged area."""
    depth_quantiles: tuple[float, ...]
    """Quantiles `QUANTILES` of the regions' centre depths, as shares of the imaged height
    (0: the face, 1: the bottom)."""
    centroid_offset_quantiles: tuple[float, ...]
    """Quantiles `QUANTILES`, over the images that show a vessel region, of the distance of
    their vessel centroid from the middle, as a share of the imaged width (0 to 0.5)."""
    off_side_share: float
    """Share of those images whose centroid lies `vessels.OFF_SIDE_OFFSET` or more from the
    middle."""
    cut_share: float
    """Share of the regions that touch the imaged area's side or bottom (cut by the picture)."""
    aspects: tuple[float, ...]
    """Every region's aspect, for the figure's distribution."""
    ellipse_fit_quantiles: tuple[float, ...] | None
    """Quantiles `QUANTILES` of the uncut regions' overlap (IoU) with their moment ellipse
    (`vessels.ellipse_fit`; None when the picture cuts every region)."""
    wall_lateral_quantiles: tuple[float, ...] | None
    """Quantiles `QUANTILES` of the regions' wall grey over the tissue's beyond it, beside the
    lumen (`vessels`, "Vessel walls"; None when no region has enough pixels there)."""
    wall_axial_quantiles: tuple[float, ...] | None
    """The same above and below the lumen."""
    lumen_quantiles: tuple[float, ...] | None
    """Quantiles `QUANTILES` of the regions' lumen contrast: interior grey over the tissue's
    around it (`vessels`, "Vessel lumens"; None when no region has an interior that wide)."""
    lumen_middle_quantiles: tuple[float, ...] | None
    """Quantiles `QUANTILES` of the regions' interior grey in the middle third of its columns
    over the outer thirds' (`vessels`, "Vessel lumens"; None when no region gives one)."""
    round_beside_quantiles: tuple[float, ...] | None
    """Quantiles `QUANTILES` of the tissue round the regions, beside them, over their rows'
    (`vessels`, "The tissue round a vessel")."""
    round_above_quantiles: tuple[float, ...] | None
    """The same above them."""
    round_below_quantiles: tuple[float, ...] | None
    """The same below them."""
    dark_tissue_quantiles: tuple[float, ...] | None
    """Quantiles `QUANTILES`, over the images that show a vessel region, of the share of the
    tissue at the vessels' depth that is as dark as their lumens (`vessels.dark_tissue_share`;
    None when no image gives one)."""


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
    """Share of the tissue's bright-line pixels in each `line_orientation.ANGLE_BIN_DEGREES`
    bin of their normal's angle to the beam, 0 to 90 degrees (None without any)."""

    def to_dict(self) -> dict:
        return asdict(self)
