"""Spatial compounding: the steered frames' resampling geometry against a known answer, the
speckle's fall with the number of frames against 1 / sqrt(N), lumens still where the labels put
them (rigid and pressed), labels unchanged, and the settings and presets that switch it on."""

from __future__ import annotations

import dataclasses

import numpy as np
import pytest

from sim.phantom import Phantom, load_phantom
from sim.ultrasound.compounding import accumulate_steered, compound_lines, steering_angles
from sim.ultrasound.deformation import TissueLoad
from sim.ultrasound.probe import LinearProbe
from sim.ultrasound.scanner import COMPOUND_FRAMES, random_preset, scanner_preset
from sim.ultrasound.settings import UltrasoundSettings
from sim.ultrasound.simulator import UltrasoundSimulator
from sim.ultrasound.skin_pose import probe_pose_on_skin

PROBE = LinearProbe(cols=128, rows=128)


def compounded(frames: int, angle: float) -> UltrasoundSettings:
    return UltrasoundSettings(compound_frames=frames, compound_angle=angle)


def test_steering_angles_are_evenly_spread_with_the_unsteered_frame_last() -> None:
    np.testing.assert_allclose(steering_angles(5, 0.2), [-0.2, -0.1, 0.1, 0.2, 0.0])
    np.testing.assert_array_equal(steering_angles(1, 0.0), [0.0])


def test_a_steered_frame_lands_on_the_grid_where_its_lines_pass() -> None:
    """Line e, row r of a frame steered by s columns a row lies at image column e + r * s: a
    frame whose grey is a linear function of the line reads back, at grid pixel (c, r), that
    function at the line through it, c - r * s (linear interpolation is exact for it), and
    nothing where no line reaches."""
    cols, rows, shift = 40, 30, 0.37
    lines = np.repeat((2 + 3 * np.arange(cols))[:, None], rows, axis=1).astype(np.uint8)
    material = np.zeros(cols * rows, dtype=np.int16)
    contact = np.ones(cols, dtype=np.bool_)
    total = np.zeros((cols, rows), dtype=np.float32)
    count = np.zeros_like(total)
    accumulate_steered(lines, material, contact, shift, total, count)
    line = np.arange(cols)[:, None] - shift * np.arange(rows)[None, :]
    reached = line >= 0
    np.testing.assert_array_equal(count > 0, reached)
    np.testing.assert_allclose(total[reached], (2.0 + 3.0 * line)[reached], atol=1e-4)


def test_lines_without_contact_or_in_air_add_nothing_and_the_mean_is_rounded() -> None:
    cols, rows = 6, 4
    lines = np.full((cols, rows), 100, dtype=np.uint8)
    material = np.zeros(cols * rows, dtype=np.int16)
    material[2 * rows + 1] = -1  # line 2, row 1 in air
    contact = np.ones(cols, dtype=np.bool_)
    contact[4] = False
    total = np.zeros((cols, rows), dtype=np.float32)
    count = np.zeros_like(total)
    accumulate_steered(lines, material, contact, 0.0, total, count)
    assert count[4].sum() == 0 and count[2, 1] == 0 and count[2, 0] == 1
    total += 51.0  # a second frame of grey 51 everywhere: mean 75.5 rounds to 76
    count += 1.0
    out = np.empty((cols, rows), dtype=np.uint8)
    compound_lines(total, count, material, contact, out)
    assert out[0, 0] == 76 and out[4].max() == 0 and out[2, 1] == 0


def test_compounding_averages_the_speckle_down_by_about_the_root_of_the_frames() -> None:
    """Steered frames' speckle is independent: in a homogeneous region (the default phantom's
    gel, below its vessels) the grey level's spread falls near 1 / sqrt(N), its mean stays."""
    phantom = Phantom(load_phantom("default"))
    pose = probe_pose_on_skin(phantom, 0.0, 0.0)

    def gel(settings: UltrasoundSettings) -> np.ndarray:
        image, labels = UltrasoundSimulator(phantom, PROBE, settings).render(pose)
        region = image[85:125, 10:118].astype(np.float64)
        assert not labels[85:125, 10:118].any()
        return region

    single = gel(UltrasoundSettings())
    for frames, angle in ((3, 0.2), (5, 0.3)):
        region = gel(compounded(frames, angle))
        ratio = region.std() / single.std()
        assert 0.9 / np.sqrt(frames) < ratio < 1.15 / np.sqrt(frames), (frames, ratio)
        assert abs(region.mean() - single.mean()) < 2.0


@pytest.mark.parametrize("pressed", [False, True], ids=["rigid", "pressed"])
def test_lumens_stay_where_the_labels_are_and_the_labels_do_not_change(pressed: bool) -> None:
    """Every steered frame is registered onto the image: the lumens (black in the plain
    settings) stay black inside their labels, the tissue around them as bright as unsteered.
    Labels are the unsteered frame's, identical to the uncompounded image's."""
    phantom = Phantom(load_phantom("femoral"))
    pose = probe_pose_on_skin(phantom, 0.0, 0.0)
    load = None
    if pressed:
        pose[:3, 3] += 0.003 * pose[:3, 2]
        load = TissueLoad(6.0, 0.2)
    # the resting probe couples only its middle; a one-column aperture keeps the lines beside
    # its lifted edges undimmed, since steered lines from coupled elements light them again
    plain = UltrasoundSettings(clutter_db=None, active_aperture=PROBE.pixel_width)
    image, labels = UltrasoundSimulator(phantom, PROBE, plain).render(pose, load)
    steered = dataclasses.replace(plain, compound_frames=5, compound_angle=0.3)
    compound, compound_labels = UltrasoundSimulator(phantom, PROBE, steered).render(pose, load)
    np.testing.assert_array_equal(compound_labels, labels)
    vessel = labels > 0
    inner = vessel.copy()
    for axis in (0, 1):
        for step in (-2, 2):
            inner &= np.roll(vessel, step, axis=axis)
    assert inner.sum() > 200
    assert compound[inner].mean() < image[inner].mean() + 3.0
    tissue = (labels == 0) & (image > 0)
    assert abs(compound[tissue].mean() - image[tissue].mean()) < 0.1 * image[tissue].mean()


@pytest.mark.parametrize(
    ("changes", "message"),
    [
        ({"compound_frames": 2, "compound_angle": 0.1}, "compound_frames must be odd and 1..9"),
        ({"compound_frames": 11, "compound_angle": 0.1}, "compound_frames must be odd and 1..9"),
        ({"compound_frames": 3, "compound_angle": 0.5}, r"compound_angle must be in \[0, 0.35\]"),
        ({"compound_frames": 3}, "compound_angle must be > 0 to compound 3 frames"),
    ],
)
def test_bad_compounding_settings_are_refused_by_name(changes: dict, message: str) -> None:
    with pytest.raises(ValueError, match=message):
        UltrasoundSettings(**changes)


def test_presets_switch_compounding_on() -> None:
    assert scanner_preset("vascular").settings().compound_frames == 1
    settings = scanner_preset("vascular-compound").settings()
    assert (settings.compound_frames, settings.compound_angle) == (3, 0.17)
    drawn = [random_preset(seed) for seed in range(30)]
    assert {preset.compound_frames for preset in drawn} == set(COMPOUND_FRAMES)
    for preset in drawn:
        assert (preset.compound_angle > 0) == (preset.compound_frames > 1)
        preset.settings()  # each one a valid setting
