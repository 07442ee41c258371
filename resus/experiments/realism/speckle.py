"""Speckle: the grey levels' spread in tissue windows and the grain's size.

The envelope's SNR (mean/std of the linear amplitude, 1.91 for fully developed
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
"""

from __future__ import annotations

import math

import numpy as np

from resus.experiments.realism.stats import GREY_LEVELS, RealismSettings

RAYLEIGH_LOG_STD_DB = 10.0 / math.log(10.0) * math.pi / math.sqrt(6.0)
"""Standard deviation of log-compressed fully developed speckle: 5.57 dB.

The envelope A of fully developed speckle is Rayleigh distributed, so the intensity I = A^2 is
exponential: I = I0 E with E ~ Exp(1). Log compression shows 20 log10 A = 10 log10 I =
10 log10 I0 + (10 / ln 10) ln E, and Var(ln E) = psi'(1) = pi^2 / 6 (the trigamma function at
1), so the standard deviation is (10 / ln 10) pi / sqrt(6) = 5.57 dB, whatever I0 (the
tissue's echogenicity, the gain, the TGC) is.
"""


def rayleigh_grey_std(dynamic_range_db: float) -> float:
    """Grey-level std of log-compressed fully developed speckle on a display that maps
    `dynamic_range_db` onto 256 grey levels (255 / DR grey levels per dB): 28.4 at 50 dB."""
    return RAYLEIGH_LOG_STD_DB * (GREY_LEVELS - 1) / dynamic_range_db


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


class GrainSums:
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


def full_width_half_maximum(profile: np.ndarray) -> float | None:
    """Twice the lag at which a symmetric profile, given from lag 0 (= 1) on, first falls below
    one half, linearly interpolated; None when it never does."""
    below = np.flatnonzero(profile < 0.5)
    if not below.size:
        return None
    k = int(below[0])
    high, low = profile[k - 1], profile[k]
    return float(2.0 * (k - 1 + (high - 0.5) / (high - low)))
