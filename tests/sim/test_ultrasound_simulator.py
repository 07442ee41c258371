"""The B-mode simulator on the real phantoms: determinism, phantom-fixed speckle, vessels,
posterior enhancement, bone shadow, skin contact and exact labels."""

from __future__ import annotations

from dataclasses import replace

import numpy as np
import pytest

from sim.phantom import ARTERY, VEIN, Phantom, load_phantom, make_subject
from sim.transforms import make_pose
from sim.ultrasound import simulator as simulator_module
from sim.ultrasound.deformation import TissueLoad
from sim.ultrasound.probe import LinearProbe
from sim.ultrasound.settings import UltrasoundSettings
from sim.ultrasound.simulator import UltrasoundSimulator
from sim.ultrasound.skin_pose import probe_pose_on_skin

SMALL_PROBE = LinearProbe(cols=128, rows=128)


@pytest.fixture(scope="module")
def simulator(default_phantom: Phantom) -> UltrasoundSimulator:
    return UltrasoundSimulator(default_phantom)


def test_same_pose_gives_the_same_frame(simulator: UltrasoundSimulator) -> None:
    pose = probe_pose_on_skin(simulator.phantom, 0.001, -0.03, rotation=0.2)
    image, labels = simulator.render(pose)
    again, labels_again = UltrasoundSimulator(simulator.phantom).render(pose)
    assert image.shape == labels.shape == (256, 256)
    assert image.dtype == labels.dtype == np.uint8
    np.testing.assert_array_equal(image, again)
    np.testing.assert_array_equal(labels, labels_again)


def test_another_subject_seed_gives_other_speckle(default_phantom: Phantom) -> None:
    spec = default_phantom.spec
    pose = probe_pose_on_skin(default_phantom, 0.0, 0.05)
    first, _ = UltrasoundSimulator(default_phantom, SMALL_PROBE).render(pose)
    other = Phantom(replace(spec, subject=5))  # same geometry, another subject's seed
    second, _ = UltrasoundSimulator(other, SMALL_PROBE).render(pose)
    tissue = slice(3, 35)  # gel above the vessels (depth 1-14 mm)
    a = first[tissue].astype(float).ravel()
    b = second[tissue].astype(float).ravel()
    assert abs(np.corrcoef(a, b)[0, 1]) < 0.1
    assert abs(a.mean() - b.mean()) < 3.0  # same tissue, same brightness


def test_speckle_is_fixed_in_the_phantom(default_phantom: Phantom) -> None:
    """Shift the probe by exactly k pixel widths along its array: every column away from the
    image edges (beyond the lateral beam's reach) images the same tissue line and must come
    out identical. Noise is off because electronic noise is, rightly, not tissue-fixed."""
    settings = UltrasoundSettings(electronic_noise_db=-300.0)
    simulator = UltrasoundSimulator(default_phantom, SMALL_PROBE, settings)
    shift = 20
    pose = probe_pose_on_skin(default_phantom, 0.0, 0.02, rotation=0.3, tilt=0.1)
    moved = pose.copy()
    moved[:3, 3] += pose[:3, 0] * shift * SMALL_PROBE.pixel_width
    first, _ = simulator.render(pose)
    second, _ = simulator.render(moved)
    margin = 12  # lateral kernel half-width at the deepest row
    overlap_first = first[:, shift + margin : -margin].astype(int)
    overlap_second = second[:, margin : -shift - margin].astype(int)
    assert np.abs(overlap_first - overlap_second).max() <= 1  # float rounding of positions
    assert (overlap_first == overlap_second).mean() > 0.99
    # ... whereas an elevational step of 2 mm (twice the slice thickness) decorrelates it.
    lifted = pose.copy()
    lifted[:3, 3] += pose[:3, 1] * 0.002
    third, _ = simulator.render(lifted)
    rows = slice(3, 35)  # gel above the vessels
    correlation = np.corrcoef(first[rows].ravel(), third[rows].ravel())[0, 1]
    assert correlation < 0.2


def _lumen_core(labels: np.ndarray, value: int) -> np.ndarray:
    """The lumen mask of class `value` eroded by 2 pixels (clear of the wall and its blur)."""
    from scipy.ndimage import binary_erosion

    return binary_erosion(labels == value, iterations=2)


def test_vessels_are_dark_with_bright_walls(simulator: UltrasoundSimulator) -> None:
    pose = probe_pose_on_skin(simulator.phantom, 0.0, -0.06)
    image, labels = simulator.render(pose)
    background = image[(labels == 0) & (np.arange(256)[:, None] < 200)].mean()
    for value in (ARTERY, VEIN):
        inner = _lumen_core(labels, value)
        assert inner.sum() > 100
        assert image[inner].mean() < 0.25 * background
        # Top and bottom of the ring (where the beam meets the wall head-on) outshine the gel.
        rows, cols = np.nonzero(labels == value)
        centre_col = int(np.median(cols))
        column = image[:, centre_col - 2 : centre_col + 3].astype(float).mean(axis=1)
        top, bottom = rows.min(), rows.max()
        assert column[top - 4 : top + 1].max() > background + 40
        assert column[bottom : bottom + 5].max() > background + 40


def test_posterior_enhancement_below_a_vessel(default_phantom: Phantom) -> None:
    simulator = UltrasoundSimulator(default_phantom)
    pose = probe_pose_on_skin(default_phantom, 0.0, -0.06)
    image = np.zeros((256, 256))
    shifts = range(-3, 4)
    for k in shifts:  # average a few elevational positions to beat the speckle down
        moved = pose.copy()
        moved[:3, 3] += pose[:3, 1] * 0.002 * k
        image += simulator.render(moved)[0] / len(shifts)
    labels = simulator.render(pose)[1]
    rows, cols = np.nonzero(labels == VEIN)
    below = slice(rows.max() + 15, rows.max() + 60)
    behind = image[below, cols.min() + 8 : cols.max() - 8].mean()
    artery_cols = np.nonzero((labels == ARTERY).any(axis=0))[0]
    beside_cols = np.setdiff1d(np.arange(0, 256), np.arange(cols.min() - 10, cols.max() + 11))
    beside_cols = np.setdiff1d(
        beside_cols, np.arange(artery_cols.min() - 10, artery_cols.max() + 11)
    )
    beside = image[below, beside_cols].mean()
    # Blood attenuates 0.18 instead of 0.5 dB/cm/MHz over ~9 mm of lumen: ~ +4 dB, ~20 grey.
    assert behind > beside + 8


def test_bone_shadows_what_lies_below() -> None:
    phantom = Phantom(load_phantom("leg"))
    deep_probe = LinearProbe(cols=128, rows=128, depth=0.065)  # room below the 45 mm femur
    simulator = UltrasoundSimulator(phantom, deep_probe)
    femur_x = phantom.spec.bones[0].control_points[1, 0]
    top = -(phantom.spec.anatomy.femur_depth)
    # Pressed into the rigid leg so that every element touches (a flat probe on a 70 mm radius
    # thigh is 2.6 mm off the skin at its ends).
    pose = probe_pose_on_skin(phantom, femur_x, 0.0, lift=-0.0027)
    image, _ = simulator.render(pose)
    pixel_points = (
        pose @ deep_probe.image_to_probe() @ np.array([[64, r, 0, 1] for r in range(128)]).T
    )[2]
    bone_row = int(np.argmin(np.abs(pixel_points - top)))
    centre = slice(54, 75)
    surface = image[bone_row - 3 : bone_row + 4, centre].max(axis=0).mean()
    shadow = image[bone_row + 12 : 128, centre].mean()  # below the curved cortex
    above = image[bone_row - 25 : bone_row - 10, centre].mean()
    assert surface > above + 40  # the bone surface is a bright specular line
    assert shadow < 0.35 * above  # and nothing gets through it


def test_no_contact_gives_a_black_frame_and_no_labels(simulator: UltrasoundSimulator) -> None:
    pose = probe_pose_on_skin(simulator.phantom, 0.0, -0.06, lift=0.005)
    image, labels = simulator.render(pose)
    assert not image.any()
    assert not labels.any()
    assert not simulator.contact(pose).any()


def test_labels_are_the_phantom_labels_at_the_pixel_centres(simulator: UltrasoundSimulator) -> None:
    phantom = simulator.phantom
    pose = probe_pose_on_skin(phantom, 0.003, 0.01, rotation=0.4, tilt=-0.15)
    _, labels = simulator.render(pose)
    probe = simulator.probe
    points = probe.pixel_points().reshape(-1, 3)
    in_phantom = points @ pose[:3, :3].T + pose[:3, 3]
    expected = phantom.labels(in_phantom).reshape(probe.rows, probe.cols)
    assert simulator.contact(pose).all()
    np.testing.assert_array_equal(labels, expected)
    assert (labels == ARTERY).any() and (labels == VEIN).any()


def test_half_off_the_phantom_images_only_the_touching_columns(default_phantom: Phantom) -> None:
    simulator = UltrasoundSimulator(default_phantom, SMALL_PROBE)
    half_x = default_phantom.spec.body.size[0] / 2
    pose = probe_pose_on_skin(default_phantom, half_x - 0.005, 0.0)  # 5 mm of the array on gel
    image, labels = simulator.render(pose)
    contact = simulator.contact(pose)
    element_x = (np.arange(128) - 63.5) * SMALL_PROBE.pixel_width + half_x - 0.005
    np.testing.assert_array_equal(contact, element_x <= half_x)
    assert not image[:, ~contact].any() and not labels[:, ~contact].any()
    assert image[:, contact].mean() > 60


def test_subjects_render(default_phantom: Phantom) -> None:
    subject = Phantom(make_subject(default_phantom.spec, 3))
    image, labels = UltrasoundSimulator(subject, SMALL_PROBE).render(
        probe_pose_on_skin(subject, 0.0, 0.0)
    )
    assert image.mean() > 40 and labels.max() > 0


def test_bad_pose_is_refused(simulator: UltrasoundSimulator) -> None:
    with pytest.raises(ValueError, match="probe_to_phantom"):
        simulator.render(np.eye(3))
    sheared = make_pose(np.diag([1.0, 2.0, 1.0]), np.zeros(3))
    with pytest.raises(ValueError, match="not rigid"):
        simulator.render(sheared)


def test_frames_need_the_vessel_surfaces_only_inside_the_wall_band(
    monkeypatch: pytest.MonkeyPatch,
) -> None:
    """The simulator asks the phantom for the nearest vessel surface only within the thickest
    wall (its echo and the angle of its steps need no more): asking within 5 mm instead gives
    the same frames, rigid and pressed (where the vein's ring stretches the tissue)."""
    phantom = Phantom(load_phantom("femoral"))
    probe = LinearProbe(rows=96, cols=80)
    poses = [probe_pose_on_skin(phantom, x, y) for x, y in [(0.0, 0.0), (0.006, -0.02)]]
    loads = [None, TissueLoad(12.0, 0.3)]
    narrow = UltrasoundSimulator(phantom, probe)
    monkeypatch.setattr(simulator_module, "WALL_SEARCH_PAD", 5.0e-3)
    wide = UltrasoundSimulator(phantom, probe)
    for pose in poses:
        pressed = pose.copy()
        pressed[:3, 3] += pose[:3, 2] * 0.004
        for frame_pose, load in zip((pose, pressed), loads, strict=True):
            image, labels = narrow.render(frame_pose, load)
            wide_image, wide_labels = wide.render(frame_pose, load)
            assert (labels > 0).any()
            np.testing.assert_array_equal(image, wide_image)
            np.testing.assert_array_equal(labels, wide_labels)
