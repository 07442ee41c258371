"""The femoral nerve of the femoral subjects: lateral to the artery and a little deeper, clear
of the vessels; inside it the phantom is epineurium, or fascicle inside a fascicle (label 0),
against the spline tubes computed here; drawing it moved no other structure."""

from __future__ import annotations

import dataclasses

import numpy as np
import pytest
from spline_tubes import centreline, distance_to

from sim.phantom import Phantom, load_phantom
from sim.phantom.anatomy import EPINEURIUM
from sim.phantom.spec import PhantomSpec
from sim.phantom.subjects import NERVE_KEYS, make_subject


@pytest.fixture(scope="module")
def subjects() -> list[PhantomSpec]:
    nominal = load_phantom("femoral")
    return [nominal, *(make_subject(nominal, k) for k in range(8))]


def test_the_nerve_lies_lateral_to_the_artery_a_little_deeper_and_clear_of_the_vessels(
    subjects,
) -> None:
    with_nerve = [s for s in subjects if s.nerves]
    assert subjects[0].nerves and len(with_nerve) >= 7  # left out only where a vessel is in the way
    for subject in with_nerve:
        a, lateral = subject.anatomy, subject.lateral_sign
        cfa = centreline(next(v for v in subject.vessels if v.name == "CFA"), 2000)
        assert len(subject.nerves) == int(a.nerve_lobes) and len(subject.fascicles) >= 3
        for lobe in subject.nerves:
            points = lobe.control_points[lobe.control_points[:, 1] < cfa[-1, 1]]
            artery = cfa[np.abs(cfa[:, 1][None] - points[:, 1][:, None]).argmin(axis=1)]
            assert ((points[:, 0] - artery[:, 0]) * lateral > 0.004).all()
            np.testing.assert_allclose(  # depths below the top line, like the artery's
                artery[:, 2] - points[:, 2],
                a.nerve_drop,
                atol=2e-5,  # the artery's samples lie within 0.05 mm along y of the stations
            )
            radius = float(lobe.radii[0])
            for vessel in subject.vessels:
                reach = float(vessel.radii.max()) + vessel.wall_thickness + radius
                nearest = distance_to(centreline(vessel, 400), centreline(lobe, 800)).min()
                assert nearest - reach >= subject.variation.min_gap - 2e-4


def test_fascicles_lie_inside_the_nerve_apart_from_one_another(subjects) -> None:
    for subject in (s for s in subjects if s.nerves):
        radius = float(subject.nerves[0].radii[0])
        lobes = [lobe.control_points for lobe in subject.nerves]
        centres, radii = [], []
        for fascicle in subject.fascicles:
            points, r = fascicle.control_points, float(fascicle.radii[0])
            # the same stations as the lobes: the cross-section offsets are exact there
            inside = np.min([np.linalg.norm(points - lobe, axis=1) for lobe in lobes], axis=0)
            assert (inside + r <= radius - EPINEURIUM + 1e-9).all()
            centres.append(points[0])
            radii.append(r)
        gaps = np.linalg.norm(np.array(centres)[:, None] - np.array(centres)[None], axis=2)
        reach = np.add.outer(radii, radii) + EPINEURIUM
        assert (gaps + np.eye(len(radii)) * 1.0 >= reach - 1e-9).all()


def test_points_in_the_nerve_are_epineurium_or_fascicle_and_label_nothing(subjects) -> None:
    subject = next(s for s in subjects[1:] if len(s.nerves) >= 2)
    phantom = Phantom(subject)
    names = [m.name for m in phantom.materials]
    epineurium, fascicle = names.index("epineurium"), names.index("nerve fascicle")
    middle = subject.nerves[len(subject.nerves) // 2]
    y = float(np.median(middle.control_points[:, 1]))
    centre = middle.control_points[np.abs(middle.control_points[:, 1] - y).argmin()]
    rng = np.random.default_rng(11)
    points = centre + rng.uniform(-1.0, 1.0, (5000, 3)) * [0.007, 0.004, 0.003]

    def signed(tubes) -> np.ndarray:
        curves = [centreline(tube, 3000) for tube in tubes]
        curves = [curve[np.abs(curve[:, 1] - centre[1]) < 0.008] for curve in curves]
        radii = [float(tube.radii[0]) for tube in tubes]
        return np.min(
            [distance_to(points, c) - r for c, r in zip(curves, radii, strict=True)], axis=0
        )

    nerve, fascicles = signed(subject.nerves), signed(subject.fascicles)
    clear = (np.abs(nerve) > 2e-5) & (np.abs(fascicles) > 2e-5)  # off every surface
    sample = phantom.sample(points[clear])
    in_nerve, in_fascicle = nerve[clear] < 0, fascicles[clear] < 0
    assert (in_nerve & in_fascicle).sum() > 200 and (in_nerve & ~in_fascicle).sum() > 300
    assert (sample.material[in_nerve & in_fascicle] == fascicle).all()
    assert (sample.material[in_nerve & ~in_fascicle] == epineurium).all()
    assert not np.isin(sample.material[~in_nerve], [epineurium, fascicle]).any()
    assert (sample.label[in_nerve] == 0).all()


def test_drawing_the_nerve_moved_no_vessel_node_belly_or_layer(subjects) -> None:
    """The nerve's quantities come from a generator of their own: a phantom without their ranges
    gives the same subjects, with the nominal nerve."""
    nominal = subjects[0]
    ranges = {k: v for k, v in nominal.variation.ranges.items() if k not in NERVE_KEYS}
    without = dataclasses.replace(
        nominal, variation=dataclasses.replace(nominal.variation, ranges=ranges)
    )
    for k, subject in enumerate(subjects[1:]):
        other = make_subject(without, k)
        assert other.vessels == subject.vessels and other.nodes == subject.nodes
        assert other.muscles == subject.muscles and other.layers == subject.layers
        assert other.mechanics == subject.mechanics
        assert other.anatomy.nerve_radius == nominal.anatomy.nerve_radius


def test_a_nerve_needs_its_materials_and_at_least_one_lobe(subjects, tmp_path) -> None:
    subject = subjects[0]
    with pytest.raises(ValueError, match="a nerve is given but no nerve material"):
        dataclasses.replace(subject, nerve=None)
    with pytest.raises(ValueError, match="fascicles need a fascicle material and a nerve"):
        dataclasses.replace(subject, nerves=())
    spec = tmp_path / "flat.yaml"
    spec.write_text("extends: femoral\nanatomy: {nerve_lobes: 0}\n")
    with pytest.raises(ValueError, match=r"flat\.yaml: nerve_lobes must be >= 1, got 0"):
        load_phantom(spec)
