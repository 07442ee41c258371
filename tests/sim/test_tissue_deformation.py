"""Tissue that answers the probe: the mechanics' laws against independent computations, and
deformed images and labels against the analytic deformed geometry."""

import dataclasses
import math
from collections.abc import Callable

import numpy as np
import pytest
from scipy import integrate

from sim.fingerprint import simulator_fingerprint
from sim.phantom import (
    Phantom,
    PhantomSpec,
    VesselSpec,
    load_phantom,
    make_subject,
)
from sim.phantom.mechanics import (
    PASCAL_PER_MMHG,
    SYSTOLE_FRACTION,
    TissueMechanics,
    bulk_row_shifts,
    cardiac_waveform,
    ellipse_perimeter,
    face_stress_fraction,
    perimeter_keeping_major,
    tissue_shift,
    vein_shape_harmonics,
)
from sim.ultrasound.deformation import TissueLoad, column_row_shifts
from sim.ultrasound.probe import LinearProbe
from sim.ultrasound.settings import UltrasoundSettings
from sim.ultrasound.simulator import UltrasoundSimulator
from sim.ultrasound.skin_pose import probe_pose_on_skin

VEIN_X, ARTERY_X, DEPTH = -0.008, 0.009, 0.016
VEIN_RADIUS, ARTERY_RADIUS = 0.005, 0.0035
MECHANICS = TissueMechanics(
    venous_pressure_mmhg=10.0,
    vein_collapse_pressure_mmhg=40.0,
    heart_rate_bpm=75.0,
    arterial_pulsation=0.08,
    respiratory_swing_mmhg=0.0,
    compression_length=0.02,
)
PROBE = LinearProbe(width=0.038, depth=0.04, cols=256, rows=256)


def straight_vessels_spec(
    gel_block_spec: Callable[..., PhantomSpec],
    mechanics: TissueMechanics | None = MECHANICS,
    vein_wall: float = 0.0004,
) -> PhantomSpec:
    """A gel block with a straight vein and a straight artery along y at one depth."""

    def tube(name: str, label: int, x: float, radius: float, wall: float) -> VesselSpec:
        points = [[x, -0.07, -DEPTH], [x, 0.0, -DEPTH], [x, 0.07, -DEPTH]]
        return VesselSpec(name, label, points, [radius] * 3, wall_thickness=wall)

    vessels = (
        tube("vein", 2, VEIN_X, VEIN_RADIUS, vein_wall),
        tube("artery", 1, ARTERY_X, ARTERY_RADIUS, 0.0004),
    )
    return gel_block_spec("straight", (0.1, 0.16, 0.06), vessels, mechanics)


@pytest.fixture(scope="module")
def simulator(gel_block_spec) -> UltrasoundSimulator:
    return UltrasoundSimulator(Phantom(straight_vessels_spec(gel_block_spec)), PROBE)


def pixel_centres() -> tuple[np.ndarray, np.ndarray]:
    """(rows, cols) lateral and depth coordinates of every pixel centre in the probe frame."""
    points = PROBE.pixel_points()
    return points[..., 0], points[..., 2]


def pressed_pose(phantom: Phantom, indentation: float) -> np.ndarray:
    pose = probe_pose_on_skin(phantom, 0.0, 0.0)
    pose[:3, 3] += pose[:3, 2] * indentation
    return pose


# --- the laws ---------------------------------------------------------------------------------


@pytest.mark.parametrize("x, y, z", [(0.0, 0.0, 0.016), (0.006, 0.002, 0.01), (0.03, 0.0, 0.02)])
def test_face_stress_is_boussinesq_integrated_over_the_face(x, y, z):
    width, length = 0.038, 0.010

    def point_load(v, u):  # Boussinesq: vertical stress of a point load at (u, v) per newton
        r2 = (x - u) ** 2 + (y - v) ** 2 + z * z
        return 3.0 * z**3 / (2.0 * math.pi * r2**2.5)

    # unit pressure over the face: the stress is the point-load kernel integrated over it
    expected, _ = integrate.dblquad(
        point_load, -width / 2, width / 2, -length / 2, length / 2, epsabs=1e-12
    )
    assert float(face_stress_fraction(x, y, z, width, length)) == pytest.approx(expected, rel=1e-6)


def test_face_stress_is_the_contact_pressure_just_under_the_face_and_none_beside_it():
    assert float(face_stress_fraction(0.0, 0.0, 1e-6, 0.038, 0.01)) == pytest.approx(1.0, abs=1e-4)
    assert float(face_stress_fraction(0.05, 0.0, 1e-6, 0.038, 0.01)) == pytest.approx(0.0, abs=1e-9)


def test_the_flattening_vein_keeps_its_perimeter():
    for minor in (1.0, 0.7, 0.3, 0.08):
        major = perimeter_keeping_major(minor)
        exact, _ = integrate.quad(
            lambda t, a=major, b=minor: math.hypot(a * math.sin(t), b * math.cos(t)), 0, 2 * math.pi
        )
        assert exact == pytest.approx(2 * math.pi, rel=1e-4)
        assert ellipse_perimeter(major, minor) == pytest.approx(exact, rel=1e-4)


def test_vein_law_round_below_venous_pressure_then_linear_then_collapsed():
    venous, collapse = MECHANICS.venous_pressure_mmhg, MECHANICS.vein_collapse_pressure_mmhg
    assert MECHANICS.vein_semi_axes(venous - 1.0, 0.0) == (1.0, pytest.approx(1.0))
    minor, _ = MECHANICS.vein_semi_axes(venous + collapse / 4, 0.0)
    assert minor == pytest.approx(0.75)
    assert MECHANICS.vein_semi_axes(venous + 2 * collapse, 0.0)[0] == MECHANICS.collapsed_fraction


def test_a_thick_wall_adds_the_cube_of_its_thickness_over_radius_to_the_collapse_pressure():
    """Stiffness 1000 mmHg and h / R = 0.3: the collapse pressure gains 27 mmHg (40 + 27)."""
    stiff = dataclasses.replace(MECHANICS, vein_wall_stiffness_mmhg=1000.0)
    venous = MECHANICS.venous_pressure_mmhg
    minor, major = stiff.vein_semi_axes(venous + 67.0 / 4, 0.0, wall_ratio=0.3)
    assert minor == pytest.approx(0.75) and major == pytest.approx(perimeter_keeping_major(0.75))
    thin = stiff.vein_semi_axes(venous + 10.0, 0.0, wall_ratio=0.0)  # no wall: the tissue's law
    assert thin == MECHANICS.vein_semi_axes(venous + 10.0, 0.0)
    assert stiff.vein_semi_axes(venous + 200.0, 0.0, 0.3)[0] == MECHANICS.collapsed_fraction


def test_cardiac_waveform_rises_in_systole_and_runs_off_to_zero():
    phases = np.linspace(0.0, 1.0, 2001)
    wave = np.array([cardiac_waveform(p) for p in phases])
    assert wave[0] == 0.0 and wave[-1] == pytest.approx(0.0, abs=1e-12)
    assert wave.max() == pytest.approx(1.0) and phases[wave.argmax()] == pytest.approx(
        SYSTOLE_FRACTION, abs=1e-3
    )
    assert np.abs(np.diff(wave)).max() < 0.01  # continuous, no jump at the cycle's end


@pytest.mark.parametrize("indentation", [0.004, -0.003, 0.0, 0.02])
def test_bulk_row_shifts_invert_the_compression_either_way(indentation):
    """Pressed in (the skin sinks with the face), drawn up (the skin rises to it) or not at
    all: the tissue each depth shows came from D = depth + indentation - shift, and the
    forward law `tissue_shift` takes D back to that depth; the skin lands on the face. 20 mm
    is past the strain cap (16 mm on 20): the excess moves the tissue rigidly."""
    depths = np.linspace(0.0, 0.04, 50)
    shifts = bulk_row_shifts(depths, indentation, 0.02)
    undeformed = depths + indentation - shifts
    forward = undeformed - indentation + tissue_shift(undeformed, indentation, 0.02)
    assert forward == pytest.approx(depths, abs=1e-12)
    assert undeformed[0] == pytest.approx(0.0, abs=1e-12)
    assert np.all(np.diff(undeformed) > 0)


def test_column_row_shifts_interpolate_the_exact_inversion_within_a_micrometre():
    """Columns sunk between -1.5 and +2.5 mm (a pressed face on a curved skin): each column's
    shifts within 1 um of inverting the compression for that column alone."""
    depths = (np.arange(256) + 0.5) * 0.04 / 256
    columns = 0.0025 - 0.004 * np.linspace(-1.0, 1.0, 128) ** 2
    interpolated = column_row_shifts(depths, columns, 0.02)
    exact = np.array([bulk_row_shifts(depths, sunk, 0.02) for sunk in columns])
    assert np.abs(interpolated - exact).max() < 1e-6
    flat = column_row_shifts(depths, np.full(4, 0.002), 0.02)
    np.testing.assert_array_equal(flat, np.tile(bulk_row_shifts(depths, 0.002, 0.02), (4, 1)))


@pytest.mark.parametrize(
    "field, value, message",
    [
        ("venous_pressure_mmhg", 0.0, "mechanics.venous_pressure_mmhg must be positive"),
        ("collapsed_fraction", 1.0, "mechanics.collapsed_fraction must be in"),
        ("arterial_pulsation", 0.6, "mechanics.arterial_pulsation must be in"),
        ("cardiac_phase", 1.0, "mechanics.cardiac_phase must be in"),
        ("vein_wall_stiffness_mmhg", -1.0, "mechanics.vein_wall_stiffness_mmhg must be >= 0"),
        ("vein_irregularity", 0.3, r"mechanics.vein_irregularity must be in \[0, 0.25\]"),
    ],
)
def test_mechanics_refuse_bad_values_by_name(field, value, message):
    with pytest.raises(ValueError, match=message):
        dataclasses.replace(MECHANICS, **{field: value})


def test_subjects_draw_mechanics_without_moving_their_anatomy():
    spec = load_phantom("femoral")
    rigid = dataclasses.replace(spec, mechanics=None)
    for subject in (0, 3):
        deformable, plain = make_subject(spec, subject), make_subject(rigid, subject)
        assert deformable.vessels == plain.vessels and plain.mechanics is None
        assert 5.0 <= deformable.mechanics.venous_pressure_mmhg <= 15.0
        assert 60.0 <= deformable.mechanics.heart_rate_bpm <= 100.0
    assert make_subject(spec, 0).mechanics != make_subject(spec, 1).mechanics


def test_vein_shapes_are_drawn_per_subject_and_vessel_within_the_irregularity():
    draws = [vein_shape_harmonics(0.1, 7, subject, 2) for subject in (None, 0, 1)]
    assert all(d.shape == (3, 2) for d in draws)
    assert all(((d[:, 0] >= 0.0) & (d[:, 0] <= 0.1)).all() for d in draws)
    assert all(((d[:, 1] >= 0.0) & (d[:, 1] < 2 * math.pi)).all() for d in draws)
    assert not np.array_equal(draws[0], draws[1]) and not np.array_equal(draws[1], draws[2])
    assert not np.array_equal(draws[1], vein_shape_harmonics(0.1, 7, 0, 3))
    assert np.array_equal(draws[1], vein_shape_harmonics(0.1, 7, 0, 2))
    assert not vein_shape_harmonics(0.0, 7, 0, 2)[:, 0].any()


def test_the_saphenous_vein_has_its_own_thicker_wall():
    subject = make_subject(load_phantom("femoral"), 2)
    walls = {vessel.name: vessel.wall_thickness for vessel in subject.vessels}
    assert walls["GSV"] == subject.anatomy.gsv_wall > subject.anatomy.vein_wall
    assert walls["CFV"] == walls["FV"] == subject.anatomy.vein_wall
    assert subject.mechanics.vein_wall_stiffness_mmhg > 0


# --- deformed images --------------------------------------------------------------------------


def expected_vein_semi_axes(
    force: float,
    indentation: float,
    mechanics: TissueMechanics = MECHANICS,
    wall_ratio: float = 0.0,
) -> tuple[float, float]:
    """The law at the vein's centre, computed here from the face and the vein's depth."""
    stress = (
        force
        / (PROBE.width * PROBE.face_thickness)
        / PASCAL_PER_MMHG
        * float(face_stress_fraction(VEIN_X, 0.0, DEPTH - indentation, PROBE.width, 0.01))
    )
    return mechanics.vein_semi_axes(stress, 0.0, wall_ratio)


@pytest.mark.parametrize("force, indentation", [(2.0, 0.0), (6.0, 0.0), (9.0, 0.004)])
def test_labels_are_the_deformed_geometry_evaluated_exactly(simulator, force, indentation):
    """Every vein label of a pressed frame is the law's ellipse, moved with the tissue at its
    centre: down by indentation * exp(-depth / compression_length) from where the rigid face
    would see it (computed here from the law's formula)."""
    pose = pressed_pose(simulator.phantom, indentation)
    _, labels = simulator.render(pose, TissueLoad(force, 0.0))
    lateral, depth = pixel_centres()
    minor, major = expected_vein_semi_axes(force, indentation)
    centre_depth = DEPTH - indentation + indentation * math.exp(-DEPTH / 0.02)
    ellipse = ((depth - centre_depth) / (minor * VEIN_RADIUS)) ** 2 + (
        (lateral - VEIN_X) / (major * VEIN_RADIUS)
    ) ** 2
    clear = np.abs(ellipse - 1.0) > 1e-6
    assert np.array_equal((labels == 2)[clear], (ellipse <= 1.0)[clear])
    assert (labels == 2).sum() > 100


def test_an_irregular_veins_labels_are_its_bent_edge_exactly(gel_block_spec):
    """With `vein_irregularity`, the vein's label is the law's ellipse with its edge bent by
    its drawn harmonics, the angle measured round its axis (+y) from the phantom's up (+z):
    the point at angle a lies at x = sin a, z = cos a (computed here from that convention),
    and the artery stays round."""
    bent = dataclasses.replace(MECHANICS, vein_irregularity=0.2)
    spec = straight_vessels_spec(gel_block_spec, bent)
    irregular = UltrasoundSimulator(Phantom(spec), PROBE)
    _, labels = irregular.render(pressed_pose(irregular.phantom, 0.0), TissueLoad(2.0, 0.0))
    lateral, depth = pixel_centres()
    minor, major = expected_vein_semi_axes(2.0, 0.0, bent)
    dx, dz = lateral - VEIN_X, -(depth - DEPTH)  # phantom x and z from the vein's centre
    angle = np.arctan2(dx, dz)
    edge = 1.0 + sum(
        amplitude * np.cos(order * (angle - phase))
        for order, (amplitude, phase) in zip(
            (2, 3, 4), vein_shape_harmonics(0.2, spec.seed, spec.subject, 0), strict=True
        )
    )
    radius = np.hypot(dz / (minor * VEIN_RADIUS), dx / (major * VEIN_RADIUS)) / edge
    clear = np.abs(radius - 1.0) > 1e-6
    assert np.array_equal((labels == 2)[clear], (radius <= 1.0)[clear])
    ellipse = np.hypot(dz / (minor * VEIN_RADIUS), dx / (major * VEIN_RADIUS)) <= 1.0
    assert ((labels == 2) != ellipse).sum() > 0.05 * ellipse.sum()  # the bend shows
    circle = np.hypot(lateral - ARTERY_X, depth - DEPTH) / ARTERY_RADIUS
    clear = np.abs(circle - 1.0) > 1e-6
    assert np.array_equal((labels == 1)[clear], (circle <= 1.0)[clear])


def test_pressed_arteries_stay_round(simulator):
    """Bulk compression moves the artery but does not squash it: its label is a circle of
    the pulsed radius, wherever the press put it."""
    pose = pressed_pose(simulator.phantom, 0.006)
    _, labels = simulator.render(pose, TissueLoad(10.0, 0.0))
    lateral, depth = pixel_centres()
    artery = labels == 1
    radius = ARTERY_RADIUS * MECHANICS.artery_scale(0.0)
    centre = depth[artery].mean()
    distance = np.hypot(depth - centre, lateral - ARTERY_X)
    clear = np.abs(distance - radius) > PROBE.pixel_height
    assert np.array_equal(artery[clear], (distance <= radius)[clear])
    assert centre == pytest.approx(DEPTH - 0.006 + 0.006 * math.exp(-DEPTH / 0.02), abs=2e-5)


def test_vein_minor_axis_against_force_follows_the_law(simulator):
    lateral, _ = pixel_centres()
    column = int(np.argmin(np.abs(lateral[0] - VEIN_X)))
    pixel = PROBE.pixel_height
    for force in np.linspace(0.0, 14.0, 8):
        _, labels = simulator.render(pressed_pose(simulator.phantom, 0.0), TissueLoad(force, 0.0))
        measured = (labels[:, column] == 2).sum() * pixel / 2
        minor, _ = expected_vein_semi_axes(force, 0.0)
        if minor >= 0.3:
            assert measured == pytest.approx(minor * VEIN_RADIUS, rel=0.05)
        else:  # collapsed to a slit: within a pixel of the law
            assert abs(measured - minor * VEIN_RADIUS) <= pixel
    assert minor == MECHANICS.collapsed_fraction  # the last force collapses the vein


def test_a_thick_walled_vein_flattens_by_the_law_with_its_wall(gel_block_spec):
    """A vein whose wall is 0.3 of its radius, with wall stiffness 1000 mmHg: its label's minor
    axis is the law's with the 27 mmHg its wall adds, and it stays rounder than a thin-walled
    vein under the same press."""
    stiff = dataclasses.replace(MECHANICS, vein_wall_stiffness_mmhg=1000.0)
    spec = straight_vessels_spec(gel_block_spec, stiff, vein_wall=0.3 * VEIN_RADIUS)
    thick = UltrasoundSimulator(Phantom(spec), PROBE)
    lateral, _ = pixel_centres()
    column = int(np.argmin(np.abs(lateral[0] - VEIN_X)))
    _, labels = thick.render(pressed_pose(thick.phantom, 0.0), TissueLoad(6.0, 0.0))
    measured = (labels[:, column] == 2).sum() * PROBE.pixel_height / 2
    minor, _ = expected_vein_semi_axes(6.0, 0.0, stiff, wall_ratio=0.3)
    assert measured == pytest.approx(minor * VEIN_RADIUS, rel=0.05)
    assert minor > expected_vein_semi_axes(6.0, 0.0)[0] + 0.1


def test_artery_pulses_at_the_heart_rate_by_the_set_amount_only(simulator):
    times = np.arange(120) / 30.0
    pose = pressed_pose(simulator.phantom, 0.0)
    areas = np.array(
        [(simulator.render(pose, TissueLoad(8.0, t))[1] == 1).sum() for t in times], dtype=float
    )
    scale = np.sqrt(areas / areas.min())
    expected = np.array([MECHANICS.artery_scale(t) for t in times])
    assert scale == pytest.approx(expected / expected.min(), abs=0.005)
    spectrum = np.abs(np.fft.rfft(areas - areas.mean()))
    peak = np.fft.rfftfreq(len(times), 1 / 30.0)[spectrum.argmax()]
    assert peak == pytest.approx(MECHANICS.heart_rate_bpm / 60.0, abs=0.25)


def test_without_a_load_or_mechanics_every_image_is_the_rigid_worlds(simulator, gel_block_spec):
    rigid = UltrasoundSimulator(Phantom(straight_vessels_spec(gel_block_spec, None)), PROBE)
    for indentation in (0.0, 0.003):
        pose = pressed_pose(simulator.phantom, indentation)
        image, labels = simulator.render(pose)
        rigid_image, rigid_labels = rigid.render(pose, TissueLoad(6.0, 0.5))
        assert np.array_equal(image, rigid_image) and np.array_equal(labels, rigid_labels)
        assert simulator.last_deformation is None and rigid.deformation is None


def test_an_unloaded_deformable_phantom_images_as_the_rigid_one(simulator, gel_block_spec):
    """No force, no indentation, no pulsation, no bent vein edges: the deformed path
    (speckle read at each pixel's own tissue point) sees what the rigid one does, up to
    float32 rounding of the lattice."""
    still = dataclasses.replace(MECHANICS, arterial_pulsation=0.0)
    unloaded = UltrasoundSimulator(Phantom(straight_vessels_spec(gel_block_spec, still)), PROBE)
    pose = pressed_pose(unloaded.phantom, 0.0)
    image, labels = unloaded.render(pose, TissueLoad(0.0, 0.0))
    rigid_image, rigid_labels = unloaded.render(pose)
    assert np.array_equal(labels, rigid_labels)
    difference = np.abs(image.astype(int) - rigid_image)
    assert difference.max() <= 2 and difference.mean() < 0.05


CURVED_PROBE = LinearProbe(width=0.038, depth=0.02, cols=128, rows=128)
QUIET = UltrasoundSettings(electronic_noise_db=-80.0)


def top_gel_rows(image: np.ndarray) -> np.ndarray:
    """(cols,) how many black rows (gel, nothing to echo) each column starts with."""
    return np.argmax(image > 0, axis=0)


@pytest.fixture(scope="module")
def thigh() -> UltrasoundSimulator:
    """The femoral phantom's nominal thigh (a cylinder of radius 110 mm) with its mechanics."""
    return UltrasoundSimulator(Phantom(load_phantom("femoral")), CURVED_PROBE, QUIET)


def test_each_column_sinks_by_the_faces_penetration_of_the_curved_skin(thigh):
    """On a cylinder of radius R, a flat face pressed d at its middle penetrates
    d - (R - sqrt(R^2 - x^2)) at x across it; where that is negative the skin is drawn up
    to the face by at most the deepest penetration (d, less the half column's sagitta)."""
    radius = thigh.phantom.spec.body.radius
    for pressed in (0.002, 0.0005):
        pose = probe_pose_on_skin(thigh.phantom, 0.0, 0.0, lift=-pressed)
        x = (np.arange(CURVED_PROBE.cols) - (CURVED_PROBE.cols - 1) / 2) * CURVED_PROBE.pixel_width
        penetration = pressed - (radius - np.sqrt(radius**2 - x**2))
        expected = np.maximum(penetration, -penetration.max())
        got = thigh.deformation.column_indentation(pose)
        np.testing.assert_allclose(got, expected, atol=1e-9)


def test_a_pressed_flat_face_images_the_curved_skin_flat(thigh):
    """Held at the skin, the face's edges stand R - sqrt(R^2 - x^2) above the thigh (1.6 mm
    at the ends): columns beyond the gel's `contact_tolerance` stay black, in the rigid
    image and in an unpressed deformed one alike. Pressed 2 mm, the skin follows the face
    across its width: every column touches and starts at the skin."""
    radius = thigh.phantom.spec.body.radius
    x = (np.arange(CURVED_PROBE.cols) - (CURVED_PROBE.cols - 1) / 2) * CURVED_PROBE.pixel_width
    coupled = radius - np.sqrt(radius**2 - x**2) <= QUIET.contact_tolerance + 1e-9
    assert 0 < coupled.sum() < CURVED_PROBE.cols
    touching = probe_pose_on_skin(thigh.phantom, 0.0, 0.0)
    for load in (None, TissueLoad(0.5, 0.0)):
        image = thigh.render(touching, load)[0]
        np.testing.assert_array_equal(thigh.contact(touching, thigh.last_deformation), coupled)
        assert image[:, ~coupled].max() == 0 and image[:, coupled].max() > 0
    pressed = probe_pose_on_skin(thigh.phantom, 0.0, 0.0, lift=-0.002)
    image = thigh.render(pressed, TissueLoad(3.0, 0.0))[0]
    assert thigh.contact(pressed, thigh.last_deformation).all()
    assert top_gel_rows(image).max() <= 1


def test_speckle_moves_with_the_compressed_tissue(simulator):
    """Pressed by 3 mm, a deep patch of the image is the rigid image of the tissue that moved
    there: the same speckle, found where the bulk law puts it."""
    pose = pressed_pose(simulator.phantom, 0.003)
    image, _ = simulator.render(pose, TissueLoad(0.0, 0.0))
    rigid, _ = simulator.render(pose)
    image_rows = slice(200, 240)
    patch = image[image_rows, 20:60].astype(float)
    shifts = range(0, 12)
    scores = [
        np.corrcoef(patch.ravel(), rigid[200 - k : 240 - k, 20:60].astype(float).ravel())[0, 1]
        for k in shifts
    ]
    expected = 0.003 * math.exp(-(0.035 + 0.003) / 0.02) / PROBE.pixel_height
    assert int(np.argmax(scores)) == pytest.approx(expected, abs=1.0)
    best, runner_up = sorted(scores)[-1], sorted(scores)[-2]
    assert best > 0.7 and runner_up < 0.4  # sub-pixel shifts decorrelate a little


# --- a simulated sweep ------------------------------------------------------------------------


def test_a_pressing_sweep_flattens_the_vein_and_rigid_turns_it_off(tmp_path, monkeypatch, capsys):
    """`resus simulate` on the femoral phantom at 9 N deforms the tissue under the measured
    force (provenance says so); `--rigid` gives the rigid world's frames of the same path."""
    from resus.sweep.io import read_sweep
    from tests.cli_runner import run_main

    common = ["--phantom", "femoral", "--subject", "0", "--length", "0.006", "--force", "9"]
    sweeps = {}
    for name, extra in (("deformed", []), ("rigid", ["--rigid"])):
        out = tmp_path / f"{name}.h5"
        status, _, err = run_main(monkeypatch, capsys, "simulate", "--out", out, *common, *extra)
        assert status == 0, err
        sweeps[name] = read_sweep(out)
    deformed, rigid = sweeps["deformed"], sweeps["rigid"]
    assert deformed.provenance["deformation"] is True
    assert deformed.provenance["simulator"] == simulator_fingerprint()  # what made the sweep
    assert rigid.provenance["deformation"] is False
    # the force that deformed them
    assert np.median(deformed.axial_force) == pytest.approx(9.0, abs=0.5)
    vein = [(s.labels == 2).sum(axis=(1, 2)).mean() for s in (deformed, rigid)]
    assert vein[0] < 0.8 * vein[1]  # flattened by the press
    assert not np.array_equal(deformed.frames, rigid.frames)
