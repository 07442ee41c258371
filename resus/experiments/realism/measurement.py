"""One image set measured: its grey levels pooled, every figure of `RealismStats`.

Every grey-level figure is pooled over the imaged pixels of the whole set (each pixel counts
once, so larger images weigh more); the per-image and per-vessel figures are given as
quantiles over the images or the vessel regions.

Depth. The imaged area's rows are cut into `DEPTH_BANDS` equal bands from the face down, and
the tissue's mean grey in each is the depth profile: real exports mostly darken with depth
(attenuation that the TGC does not wholly undo), and a simulator whose images brighten with
depth teaches a network that vessels are dark holes in a bright floor.


The tissue's bright lines (`line_orientation`) are looked for clear of the vessels by the
speckle's margin or three of the line scale's sigmas, whichever is more.
"""

from __future__ import annotations

import math
from collections.abc import Sequence
from itertools import pairwise

import numpy as np

from resus.errors import ResusError
from resus.experiments.realism.comparison import RealismComparison
from resus.experiments.realism.images import ImageSet, imaged_region
from resus.experiments.realism.line_orientation import (
    ANGLE_BIN_DEGREES,
    EDGE_SIGMAS,
    bright_line_normals,
    line_angle_counts,
    line_scale_pixels,
)
from resus.experiments.realism.speckle import (
    RAYLEIGH_LOG_STD_DB,
    GrainSums,
    rayleigh_grey_std,
    tissue_windows,
)
from resus.experiments.realism.stats import (
    DEPTH_BANDS,
    GREY_LEVELS,
    QUANTILES,
    RealismSettings,
    RealismStats,
    SpeckleStats,
    VesselShapeStats,
)
from resus.experiments.realism.vessels import (
    ELONGATED_ASPECT,
    OFF_SIDE_OFFSET,
    VesselContrast,
    centroid_offset,
    dark_tissue_share,
    ellipse_fit,
    find_regions,
    is_cut,
    region_shape,
    vessel_clearance,
    vessel_contrasts,
)


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
        self.grain = GrainSums(settings.grain_patch)
        self.network_grain = GrainSums(settings.network_grain_patch)
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
        clearance = vessel_clearance(vessel)
        usable = ~vessel & (clearance >= self.settings.vessel_margin)
        line_margin = max(self.settings.vessel_margin, EDGE_SIGMAS * line_scale_pixels(len(image)))
        self.line_angles += line_angle_counts(
            bright_line_normals(image, ~vessel & (clearance >= line_margin))
        )
        windows = tissue_windows(image, usable, self.settings.patch, self.settings)
        self.window_means.append(windows.mean(axis=(1, 2)))
        self.window_variances.append(windows.var(axis=(1, 2), ddof=1))
        self.grain.add(tissue_windows(image, usable, self.settings.grain_patch, self.settings))
        regions = find_regions(vessel, self.settings.min_vessel_area)  # labelled once for both
        self.regions.extend(region_shape(vessel, region) for region in regions)
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
        usable = ~small_vessel & (vessel_clearance(small_vessel) >= margin)
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


def _present_quantiles(values: Sequence[float | None]) -> tuple[float, ...] | None:
    """`_quantiles` of the values that are not None (None when none is)."""
    present = np.array([value for value in values if value is not None])
    return _quantiles(present) if present.size else None


def _quantiles(values: np.ndarray) -> tuple[float, ...]:
    return tuple(float(q) for q in np.quantile(values, QUANTILES))


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
