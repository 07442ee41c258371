"""The point-spread function, split into the three directions of the beam.

- axial: a complex Gabor pulse (Gaussian envelope from the bandwidth, carrier at the
  round-trip wavenumber 2k) sampled at the pixel rows -- the analytic signal of the RF pulse;
- lateral: a Gaussian beam whose width grows away from the focus, one kernel per row;
- elevation: a Gaussian slice profile, sampled at a few planes either side of the image plane.

Each kernel is normalised so that a scatterer field of unit variance comes out with unit
variance, given the field's own correlation (the cubic B-spline that trilinear interpolation of
independent lattice values produces), so echogenicity 1 means unit root-mean-square speckle at
every depth, whatever the beam width there.
"""

from __future__ import annotations

import numpy as np

from sim.ultrasound.probe import LinearProbe
from sim.ultrasound.settings import UltrasoundSettings

FWHM_PER_SIGMA = 2.0 * np.sqrt(2.0 * np.log(2.0))
KERNEL_HALF_WIDTH_SIGMAS = 3.0
ELEVATION_HALF_SPAN_SIGMAS = 1.5


def lattice_correlation(separation: np.ndarray) -> np.ndarray:
    """Correlation of a trilinearly interpolated white lattice field along one lattice axis,
    at `separation` in lattice spacings: the cubic B-spline (the hat function's autocorrelation),
    divided by its value at 0 so that it is 1 there."""
    x = np.abs(np.asarray(separation, dtype=np.float64))
    inner = 2.0 / 3.0 - x**2 + 0.5 * x**3
    outer = (2.0 - np.minimum(x, 2.0)) ** 3 / 6.0
    return np.where(x < 1.0, inner, outer) / (2.0 / 3.0)


def _normalised(weights: np.ndarray, positions: np.ndarray, spacing: float) -> np.ndarray:
    """Scale `weights` at `positions` (m) so that they pass a unit-variance lattice field with
    unit variance: sum_ij w_i conj(w_j) rho(x_i - x_j) = 1."""
    correlation = lattice_correlation((positions[:, None] - positions[None, :]) / spacing)
    power = np.real(np.conj(weights) @ correlation @ weights)
    return weights / np.sqrt(power)


def axial_pulse(probe: LinearProbe, settings: UltrasoundSettings) -> np.ndarray:
    """Complex Gabor pulse sampled at the row spacing, shape (taps,), odd length, centred."""
    frequency_sigma = settings.fractional_bandwidth * probe.centre_frequency / FWHM_PER_SIGMA
    depth_sigma = settings.speed_of_sound / (4.0 * np.pi * frequency_sigma)
    half = max(1, int(np.ceil(KERNEL_HALF_WIDTH_SIGMAS * depth_sigma / probe.pixel_height)))
    depths = np.arange(-half, half + 1) * probe.pixel_height
    round_trip_wavenumber = 4.0 * np.pi * probe.centre_frequency / settings.speed_of_sound
    pulse = np.exp(-0.5 * (depths / depth_sigma) ** 2) * np.exp(1j * round_trip_wavenumber * depths)
    return _normalised(pulse, depths, settings.scatterer_spacing)


def lateral_beam_width(probe: LinearProbe, settings: UltrasoundSettings) -> np.ndarray:
    """Gaussian sigma of the lateral beam at each row's depth (m), shape (rows,)."""
    depths = (np.arange(probe.rows) + 0.5) * probe.pixel_height
    focal_sigma = settings.lateral_resolution / FWHM_PER_SIGMA
    defocus = (depths - settings.focal_depth) / settings.depth_of_field
    return focal_sigma * np.sqrt(1.0 + defocus**2)


def lateral_beam(probe: LinearProbe, settings: UltrasoundSettings) -> np.ndarray:
    """Lateral kernels, one per row, shape (taps, rows) float32, odd number of taps, centred."""
    sigmas = lateral_beam_width(probe, settings)
    half = max(1, int(np.ceil(KERNEL_HALF_WIDTH_SIGMAS * sigmas.max() / probe.pixel_width)))
    offsets = np.arange(-half, half + 1) * probe.pixel_width
    kernels = np.empty((offsets.size, probe.rows), dtype=np.float32)
    for row, sigma in enumerate(sigmas):
        profile = np.exp(-0.5 * (offsets / sigma) ** 2)
        kernels[:, row] = _normalised(profile, offsets, settings.scatterer_spacing)
    return kernels


def elevation_profile(
    probe: LinearProbe, settings: UltrasoundSettings
) -> tuple[np.ndarray, np.ndarray]:
    """Elevational offsets (m) of the summed planes and their weights, each shape (samples,).

    The slice profile is a Gaussian whose full width at half maximum is the probe's
    `elevation_thickness`; the planes span +-1.5 sigma of it, evenly spaced."""
    sigma = probe.elevation_thickness / FWHM_PER_SIGMA
    half_span = ELEVATION_HALF_SPAN_SIGMAS * sigma if settings.elevation_samples > 1 else 0.0
    offsets = np.linspace(-half_span, half_span, settings.elevation_samples)
    weights = np.exp(-0.5 * (offsets / sigma) ** 2)
    return offsets, _normalised(weights, offsets, settings.scatterer_spacing)


def aperture_coupling(contact: np.ndarray, half_cols: int) -> np.ndarray:
    """(cols,) float32 amplitude factor of each scan line: the coupled share of its active
    aperture (its column +- `half_cols`, cut at the array's ends) squared, since the transmitted
    pressure and the receive sensitivity each scale with it to first order (1 everywhere when
    every element is coupled)."""
    contact = np.asarray(contact, dtype=bool)
    cols = len(contact)
    coupled = np.concatenate(([0], np.cumsum(contact)))
    centre = np.arange(cols)
    low = np.maximum(centre - half_cols, 0)
    high = np.minimum(centre + half_cols + 1, cols)
    share = (coupled[high] - coupled[low]) / (high - low)
    return (share**2).astype(np.float32)
