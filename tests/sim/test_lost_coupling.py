"""Partial contact: elements without coupling image nothing, and the lines beside them dim by
the coupled share of their aperture, squared (transmit and receive), against that formula and
a frame with full contact; the settings and the random presets that lift an edge."""

from __future__ import annotations

import dataclasses

import numpy as np
import pytest

from sim.phantom import Phantom, load_phantom
from sim.ultrasound.beam import aperture_coupling
from sim.ultrasound.deformation import TissueLoad
from sim.ultrasound.probe import LinearProbe
from sim.ultrasound.scanner import named_presets, random_preset
from sim.ultrasound.settings import UltrasoundSettings
from sim.ultrasound.simulator import UltrasoundSimulator
from sim.ultrasound.skin_pose import probe_pose_on_skin

PROBE = LinearProbe(cols=128, rows=128)
LOST = 0.25
"""Share of the array's width lost at its first column in these frames: 32 of 128 columns."""


def test_aperture_coupling_is_the_coupled_share_squared() -> None:
    contact = np.array([False, False, True, True, True, True])
    np.testing.assert_allclose(
        aperture_coupling(contact, 1), np.array([0, 1 / 3, 2 / 3, 1, 1, 1]) ** 2, rtol=1e-6
    )
    # the array's ends cut the aperture: an end line shares over the elements there are
    np.testing.assert_allclose(
        aperture_coupling(contact[::-1], 2), np.array([1, 1, 4 / 5, 3 / 5, 2 / 4, 1 / 3]) ** 2
    )
    np.testing.assert_array_equal(aperture_coupling(np.ones(6, bool), 2), np.ones(6))


@pytest.fixture(scope="module")
def pressed_frames() -> dict[str, tuple[np.ndarray, np.ndarray, UltrasoundSimulator]]:
    """The femoral phantom pressed 3 mm at 6 N (every element on the skin), imaged with full
    coupling and with the first quarter of the array lost; noise far below the echoes, so a
    grey level is the log of the echo alone."""
    phantom = Phantom(load_phantom("femoral"))
    pose = probe_pose_on_skin(phantom, 0.0, 0.0)
    pose[:3, 3] += 0.003 * pose[:3, 2]
    quiet = UltrasoundSettings(electronic_noise_db=-120.0)
    frames = {}
    for name, lost in (("full", (0.0, 0.0)), ("lost", (LOST, 0.0))):
        settings = dataclasses.replace(quiet, lost_coupling=lost)
        simulator = UltrasoundSimulator(phantom, PROBE, settings)
        image, labels = simulator.render(pose, TissueLoad(6.0, 0.2))
        assert simulator.contact(pose).sum() == PROBE.cols * (1 - lost[0])
        frames[name] = (image, labels, simulator)
    return frames


def test_lost_columns_are_black_and_unlabelled_and_far_lines_unchanged(pressed_frames) -> None:
    full_image, full_labels, simulator = pressed_frames["full"]
    image, labels, _ = pressed_frames["lost"]
    lost = round(LOST * PROBE.cols)
    assert not image[:, :lost].any() and not labels[:, :lost].any()
    assert full_labels[:, :lost].any()  # there was anatomy to hide
    np.testing.assert_array_equal(labels[:, lost:], full_labels[:, lost:])
    beyond = lost + simulator._aperture_half_cols + 4  # + the lateral beam's reach
    np.testing.assert_array_equal(image[:, beyond:], full_image[:, beyond:])


def test_lines_beside_the_lost_edge_dim_by_the_coupled_share_squared(pressed_frames) -> None:
    """Grey = (255 / dynamic range) * 10 log10(power): a line whose amplitude falls by share^2
    falls by (255 / DR) * 40 log10(share) grey levels (grey map linear, unclipped pixels)."""
    full_image, _, simulator = pressed_frames["full"]
    image, _, _ = pressed_frames["lost"]
    settings = simulator.settings
    lost, half = round(LOST * PROBE.cols), simulator._aperture_half_cols
    columns = np.arange(lost + 4, lost + half)  # away from the lateral beam's black neighbours
    share = (columns - lost + half + 1) / (2 * half + 1)
    expected = 255.0 / settings.dynamic_range_db * 40.0 * np.log10(share)
    unclipped = (image > 0) & (full_image < 255) & (image < 255)
    drop = np.array(
        [
            np.median(image[unclipped[:, c], c].astype(float) - full_image[unclipped[:, c], c])
            for c in columns
        ]
    )
    np.testing.assert_allclose(drop, expected, atol=1.5)
    assert expected[0] < -15.0  # a dimming worth testing


@pytest.mark.parametrize("lost", [(0.6, 0.0), (0.1,), (-0.1, 0.0)])
def test_bad_lost_coupling_is_refused_by_name(lost: tuple[float, ...]) -> None:
    with pytest.raises(ValueError, match="lost_coupling must be two shares"):
        UltrasoundSettings(lost_coupling=lost)


def test_named_presets_couple_fully_and_some_random_ones_lift_an_edge() -> None:
    assert all(preset.settings().lost_coupling == (0.0, 0.0) for preset in named_presets().values())
    drawn = [random_preset(seed).settings().lost_coupling for seed in range(40)]
    lifted = [lost for lost in drawn if lost != (0.0, 0.0)]
    assert 2 <= len(lifted) <= 20
    assert {lost[0] > 0 for lost in lifted} == {True, False}  # either edge
    assert all(min(lost) == 0 and 0.05 <= max(lost) <= 0.25 for lost in lifted)
