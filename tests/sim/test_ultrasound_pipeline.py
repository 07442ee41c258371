"""The simulator's pieces on synthetic input, against known answers: scatterer field, beam
kernels, fast log, settings, speckle statistics, attenuation with time-gain compensation and
the specular echo of an interface."""

from __future__ import annotations

import math

import numpy as np
import pytest

from sim.ultrasound.beam import (
    FWHM_PER_SIGMA,
    axial_pulse,
    elevation_profile,
    lateral_beam,
    lateral_beam_width,
    lattice_correlation,
)
from sim.ultrasound.echo import fast_log2, form_image, lateral_clutter, scan_lines
from sim.ultrasound.probe import LinearProbe
from sim.ultrasound.scatterers import FIELD_COMPONENT_VARIANCE, accumulate_line, mix_seed
from sim.ultrasound.settings import UltrasoundSettings

PROBE = LinearProbe(cols=128, rows=256)
SETTINGS = UltrasoundSettings()
EULER_GAMMA = 0.5772156649
RAYLEIGH_LOG_STD_DB = 10.0 / math.log(10.0) * math.pi / math.sqrt(6.0)  # 5.57 dB
"""Fully developed speckle: 10 log10 of an exponential intensity has mean 10 log10(mean) -
2.51 dB and standard deviation 5.57 dB."""


def field_line(start, step, count: int, seed: int = 1) -> np.ndarray:
    """The complex field at `count` points along a line (lattice units)."""
    real = np.zeros(count, np.float32)
    imag = np.zeros(count, np.float32)
    accumulate_line(
        np.asarray(start, float), np.asarray(step, float), 1.0, mix_seed(seed), real, imag
    )
    return real + 1j * imag


def test_field_depends_only_on_the_point() -> None:
    start, step = np.array([3.3, -7.1, 12.6]), np.array([0.37, 0.11, -0.52])
    line = field_line(start, step, 50)
    for n in (0, 17, 49):  # the same points reached as the start of another line
        assert field_line(start + n * step, -step, 1)[0] == pytest.approx(line[n], abs=1e-5)
    # Continuous: a tiny move changes the value a little; at lattice nodes it is the node value.
    nearby = field_line(start + 1e-3, step, 50)
    assert np.abs(nearby - line).max() < 0.01


def test_field_statistics_and_seeds() -> None:
    values = field_line([0.25, 0.5, 0.75], [0.731, 0.219, 0.417], 200_000)
    assert values.real.var() == pytest.approx(FIELD_COMPONENT_VARIANCE, rel=0.03)
    assert values.imag.var() == pytest.approx(FIELD_COMPONENT_VARIANCE, rel=0.03)
    assert abs(np.mean(values.real * values.imag)) < 0.003
    other = field_line([0.25, 0.5, 0.75], [0.731, 0.219, 0.417], 200_000, seed=2)
    assert abs(np.corrcoef(values.real, other.real)[0, 1]) < 0.01


def test_lateral_beam_has_the_set_width_at_focus_and_widens() -> None:
    sigmas = lateral_beam_width(PROBE, SETTINGS)
    depths = (np.arange(PROBE.rows) + 0.5) * PROBE.pixel_height
    focus_row = int(np.argmin(np.abs(depths - SETTINGS.focal_depth)))
    assert sigmas[focus_row] * FWHM_PER_SIGMA == pytest.approx(
        SETTINGS.lateral_resolution, rel=0.01
    )
    row_at_dof = int(np.argmin(np.abs(depths - SETTINGS.focal_depth - SETTINGS.depth_of_field)))
    assert sigmas[row_at_dof] / sigmas[focus_row] == pytest.approx(math.sqrt(2.0), rel=0.02)
    kernels = lateral_beam(PROBE, SETTINGS)
    half = kernels.shape[0] // 2
    offsets = (np.arange(kernels.shape[0]) - half) * PROBE.pixel_width
    profile = kernels[:, focus_row] / kernels[half, focus_row]
    np.testing.assert_allclose(
        profile, np.exp(-0.5 * (offsets / sigmas[focus_row]) ** 2), atol=1e-6
    )


@pytest.mark.parametrize("row", [0, 100, 255])
def test_kernels_pass_unit_variance(row: int) -> None:
    """sum_ij w_i conj(w_j) rho(x_i - x_j) = 1 for every kernel, rho the field correlation."""
    spacing = SETTINGS.scatterer_spacing
    kernels = lateral_beam(PROBE, SETTINGS)
    offsets, weights = elevation_profile(PROBE, SETTINGS)
    pulse = axial_pulse(PROBE, SETTINGS)
    lateral_x = (np.arange(kernels.shape[0]) - kernels.shape[0] // 2) * PROBE.pixel_width
    axial_z = (np.arange(pulse.size) - pulse.size // 2) * PROBE.pixel_height
    for w, x in ((kernels[:, row], lateral_x), (weights, offsets), (pulse, axial_z)):
        rho = lattice_correlation((x[:, None] - x[None, :]) / spacing)
        assert np.real(np.conj(w) @ rho @ w) == pytest.approx(1.0, rel=1e-5)


def test_axial_pulse_and_elevation_profile_shapes() -> None:
    pulse = axial_pulse(PROBE, SETTINGS)
    centre = pulse.size // 2
    frequency_sigma = SETTINGS.fractional_bandwidth * PROBE.centre_frequency / FWHM_PER_SIGMA
    depth_sigma = SETTINGS.speed_of_sound / (4 * np.pi * frequency_sigma)
    ratio = abs(pulse[centre + 1]) / abs(pulse[centre])
    assert ratio == pytest.approx(math.exp(-0.5 * (PROBE.pixel_height / depth_sigma) ** 2))
    wavenumber = 4 * np.pi * PROBE.centre_frequency / SETTINGS.speed_of_sound
    phase = np.angle(pulse[centre + 1] / pulse[centre])
    assert np.exp(1j * phase) == pytest.approx(np.exp(1j * wavenumber * PROBE.pixel_height))
    offsets, weights = elevation_profile(PROBE, SETTINGS)
    assert offsets.size == SETTINGS.elevation_samples
    sigma = PROBE.elevation_thickness / FWHM_PER_SIGMA
    np.testing.assert_allclose(
        weights / weights.max(),
        np.exp(-0.5 * (offsets / sigma) ** 2) / np.exp(-0.5 * (offsets / sigma) ** 2).max(),
        rtol=1e-6,
    )


def test_fast_log2_matches_numpy() -> None:
    values = np.geomspace(1e-25, 1e25, 10_001).astype(np.float32)
    np.testing.assert_allclose(fast_log2(values), np.log2(values.astype(np.float64)), atol=2e-3)


@pytest.mark.parametrize(
    "change",
    [
        {"lateral_resolution": 0.0},
        {"elevation_samples": 0},
        {"tgc_attenuation": -0.1},
        {"specular_angle": 2.0},
        {"dynamic_range_db": -5.0},
        {"clutter_spread": 1.5},
    ],
)
def test_bad_settings_are_refused(change: dict) -> None:
    name = next(iter(change))
    with pytest.raises(ValueError, match=name):
        UltrasoundSettings(**change)


@pytest.mark.parametrize("spread", [0.0, 0.1, 1.0])
def test_lateral_clutter_is_the_aperture_mean_plus_a_share_of_the_row_mean(spread: float) -> None:
    """Clutter at (col, row) against numpy: power x ((1 - spread) x the mean squared
    echogenicity within half_cols columns, clipped at the image's sides, + spread x the whole
    row's); air (-1) counts as 0. In the middle of a lumen wider than the aperture only the
    row's share is left."""
    rng = np.random.default_rng(3)
    cols, rows, half_cols, power = 40, 6, 4, 0.5
    echogenicity = np.array([1.0, 0.03, 2.0], dtype=np.float32)
    material = rng.integers(-1, 3, size=(cols, rows)).astype(np.int8)
    material[10:30, 0] = 1  # a lumen 20 columns wide in the first row
    out = np.empty(cols * rows, dtype=np.float32)
    work = np.empty((cols + 1, rows), dtype=np.float32)
    lateral_clutter(material.ravel(), echogenicity, rows, power, half_cols, spread, work, out)
    squared = np.where(material >= 0, echogenicity[material], 0.0) ** 2
    expected = np.empty((cols, rows))
    for col in range(cols):
        near = squared[max(0, col - half_cols) : col + half_cols + 1].mean(axis=0)
        expected[col] = power * ((1 - spread) * near + spread * squared.mean(axis=0))
    np.testing.assert_allclose(out.reshape(cols, rows), expected, rtol=1e-5, atol=1e-6)
    middle = power * ((1 - spread) * 0.03**2 + spread * squared[:, 0].mean())
    assert out[20 * rows] == pytest.approx(middle, rel=1e-5, abs=1e-6)


def render_layers(attenuation: np.ndarray, impedance: np.ndarray | None = None) -> np.ndarray:
    """B-mode image of a flat medium, seen straight down: row r has the material r of the
    tables, echogenicity 1, `attenuation[r]` dB/cm/MHz. TGC undoes 0.5 dB/cm/MHz; no noise."""
    cols, rows = PROBE.cols, PROBE.rows
    materials = rows + 1  # one per row, plus the (unused) wall entry the kernel expects
    frequency_mhz = PROBE.centre_frequency / 1e6
    row_cm = PROBE.pixel_height * 100
    round_trip = 10 ** (-2 * np.append(attenuation, 0.5) * frequency_mhz * row_cm / 20)
    impedance = np.full(materials, 1.6) if impedance is None else np.append(impedance, 1.6)
    echogenicity = np.full(materials, 1 / math.sqrt(2 * FIELD_COMPONENT_VARIANCE))
    material = np.tile(np.arange(rows, dtype=np.int8 if rows < 128 else np.int16), cols)
    count = cols * rows
    origin = np.array([-0.019, 0.003, -PROBE.pixel_height / 2])
    col_step = np.array([PROBE.pixel_width, 0.0, 0.0])
    row_step = np.array([0.0, 0.0, -PROBE.pixel_height])
    offsets, weights = elevation_profile(PROBE, SETTINGS)
    echo_real = np.empty((cols, rows), np.float32)
    echo_imag = np.empty((cols, rows), np.float32)
    contact = np.ones(cols, bool)
    scan_lines(
        origin,
        col_step,
        row_step,
        False,
        np.zeros((count, 3)),
        np.array([0.0, -1.0, 0.0]),
        offsets,
        weights.astype(np.float32),
        material,
        np.full(count, np.inf),
        np.zeros((count, 3)),
        np.full(count, -1, np.int16),
        np.zeros(1),
        echogenicity.astype(np.float32),
        round_trip.astype(np.float32),
        impedance.astype(np.float32),
        contact,
        axial_pulse(PROBE, SETTINGS).astype(np.complex64),
        1 / SETTINGS.scatterer_spacing,
        mix_seed(9),
        SETTINGS.specular_gain,
        1.0,
        0.0,  # no reverberation
        False,  # no clutter
        np.zeros(count, np.float32),
        False,  # no texture
        np.ones(3),
        np.uint32(0),
        np.zeros(materials, np.float32),
        np.zeros(materials, np.float32),
        echo_real,
        echo_imag,
    )
    depth_cm = (np.arange(rows) + 0.5) * row_cm
    tgc = (10 ** (2 * 0.5 * frequency_mhz * depth_cm / 20)).astype(np.float32)
    image = np.empty((cols, rows), np.uint8)
    labels = np.empty((cols, rows), np.uint8)
    grey_per_log2 = 255 / SETTINGS.dynamic_range_db * 10 * math.log10(2)
    grey_offset = 255 * SETTINGS.gain_db / SETTINGS.dynamic_range_db
    form_image(
        echo_real,
        echo_imag,
        lateral_beam(PROBE, SETTINGS),
        tgc,
        0.0,
        np.uint32(0),
        grey_per_log2,
        grey_offset,
        np.arange(256).astype(np.uint8),  # identity grey map
        np.zeros(count, np.int8),
        np.zeros(count, np.uint8),
        contact,
        np.ones(cols, np.float32),  # every line fully coupled
        image,
        labels,
    )
    return image.T.astype(float)


GREY_PER_DB = 255 / SETTINGS.dynamic_range_db


def test_uniform_tissue_shows_fully_developed_speckle_at_the_set_gain() -> None:
    """Echogenicity 1 means unit mean intensity: mean grey = (gain - 2.51 dB) in grey units
    (within 1.5 dB: the kernel normalisation takes the lattice as aligned with the beam axes),
    spread 5.57 dB, flat with depth when the TGC matches the attenuation."""
    image = render_layers(np.full(PROBE.rows, 0.5))[:, 15:-15]
    expected = GREY_PER_DB * (SETTINGS.gain_db - 2.507)
    assert image.mean() == pytest.approx(expected, abs=GREY_PER_DB * 1.5)
    assert image.std() == pytest.approx(GREY_PER_DB * RAYLEIGH_LOG_STD_DB, rel=0.1)
    top, bottom = image[20:80].mean(), image[-80:-20].mean()
    assert abs(top - bottom) < 3.0


def test_a_less_attenuating_layer_brightens_everything_below_it() -> None:
    """Posterior enhancement from the physics: a 'blood' layer (0.18 dB/cm/MHz) of L cm
    raises all echoes below it by 2 (0.5 - 0.18) f L dB -- the same speckle, just brighter."""
    tissue = np.full(PROBE.rows, 0.5)
    layered = tissue.copy()
    layered[60:100] = 0.18
    reference = render_layers(tissue)
    enhanced = render_layers(layered)
    gain_db = 2 * (0.5 - 0.18) * PROBE.centre_frequency / 1e6 * 40 * PROBE.pixel_height * 100
    below = (slice(120, 250), slice(15, -15))
    unclipped = (reference[below] > 5) & (enhanced[below] < 250)
    shift = (enhanced[below] - reference[below])[unclipped].mean()
    assert shift == pytest.approx(GREY_PER_DB * gain_db, abs=0.6)
    np.testing.assert_array_equal(enhanced[:58], reference[:58])  # the pulse reaches 1 row up


def test_an_impedance_step_echoes_and_costs_transmission() -> None:
    tissue = np.full(PROBE.rows, 0.5)
    impedance = np.full(PROBE.rows, 1.6)
    impedance[128:] = 4.0  # a strong reflector from row 128 down
    plain = render_layers(tissue)
    stepped = render_layers(tissue, impedance)
    r = (4.0 - 1.6) / (4.0 + 1.6)
    assert stepped[126:131, 15:-15].max(axis=0).mean() > plain[126:131, 15:-15].mean() + 60
    below = (slice(140, 250), slice(15, -15))
    loss_db = -20 * math.log10(1 - r * r)
    assert (plain[below] - stepped[below]).mean() == pytest.approx(GREY_PER_DB * loss_db, abs=1.0)
