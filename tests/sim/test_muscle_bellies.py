"""Muscle bellies of the femoral subjects: where the spline tube is, the phantom is muscle
(label 0); they keep clear of the vessels; adding them moved no subject's vessels."""

from __future__ import annotations

import dataclasses

import numpy as np
import pytest
from spline_tubes import centreline, distance_to

from sim.phantom import Phantom, load_phantom
from sim.phantom.spec import PhantomSpec
from sim.phantom.subjects import MUSCLE_KEYS, make_subject


@pytest.fixture(scope="module")
def subjects() -> list[PhantomSpec]:
    nominal = load_phantom("femoral")
    return [make_subject(nominal, k) for k in range(8)]


def test_the_nominal_femoral_phantom_has_no_bellies_and_subjects_have_some(subjects) -> None:
    assert load_phantom("femoral").muscles == ()
    counts = [len(s.muscles) for s in subjects]
    assert sum(counts) >= 4 and min(counts) == 0  # drawn 0 to 5, those in the way left out


def test_points_in_a_belly_are_muscle_and_label_nothing(subjects) -> None:
    subject = next(s for s in subjects if s.muscles)
    phantom = Phantom(subject)
    names = [m.name for m in phantom.materials]
    muscle = names.index("muscle")
    # bone and lymph nodes win over muscle where they overlap a belly
    overriding = {names.index("cortical bone"), names.index("lymph node")}
    curves = [centreline(belly) for belly in subject.muscles]
    rng = np.random.default_rng(5)
    for belly, curve in zip(subject.muscles, curves, strict=True):
        radius = float(belly.radii[0])
        middle = curve[len(curve) // 2]
        points = middle + rng.uniform(-1.6, 1.6, (3000, 3)) * [radius, 4 * radius, radius]
        radii = [float(b.radii[0]) for b in subject.muscles]
        signed = np.min(  # bellies may touch one another: inside any is muscle
            [distance_to(points, c) - r for c, r in zip(curves, radii, strict=True)], axis=0
        )
        clear = np.abs(signed) > 2e-4  # the tube is a chain of round cones: keep off the surface
        sample = phantom.sample(points[clear])
        inside = signed[clear] < 0
        assert inside.sum() > 300 and (~inside).sum() > 300
        assert (sample.label[inside] == 0).all()
        kept = ~np.isin(sample.material[inside], list(overriding))
        assert kept.mean() > 0.8 and (sample.material[inside][kept] == muscle).all()
        assert (sample.material[~inside] != muscle).all()


def test_bellies_keep_min_gap_from_every_vessel_wall(subjects) -> None:
    for subject in subjects:
        gap = subject.variation.min_gap
        for belly in subject.muscles:
            curve = centreline(belly, 800)
            for vessel in subject.vessels:
                reach = float(vessel.radii.max()) + vessel.wall_thickness + float(belly.radii[0])
                nearest = distance_to(centreline(vessel, 400), curve).min()
                assert nearest - reach >= gap - 2e-4, (subject.name, belly.name, vessel.name)


def test_drawing_the_bellies_moved_no_vessel_node_or_layer(subjects) -> None:
    """The bellies' quantities come from a generator of their own: a phantom without their
    ranges gives the same subjects, less the bellies."""
    nominal = load_phantom("femoral")
    ranges = {k: v for k, v in nominal.variation.ranges.items() if k not in MUSCLE_KEYS}
    without = dataclasses.replace(
        nominal, variation=dataclasses.replace(nominal.variation, ranges=ranges)
    )
    for k, subject in enumerate(subjects):
        other = make_subject(without, k)
        assert other.muscles == ()
        assert other.vessels == subject.vessels and other.nodes == subject.nodes
        assert other.layers == subject.layers and other.mechanics == subject.mechanics


def test_bellies_need_a_muscle_material(subjects) -> None:
    subject = next(s for s in subjects if s.muscles)
    with pytest.raises(ValueError, match="muscle bellies are given but no muscle material"):
        dataclasses.replace(subject, muscle=None)


def test_bellies_lie_where_they_would_whichever_side_the_artery_takes(subjects) -> None:
    """The bellies are placed about the pair's midline by its unsigned width: a transposed pair
    (artery medial, negative `artery_vein_spacing`) gets the same bellies, not ones pulled
    inside the pair and then left out."""
    from sim.phantom.anatomy import build_muscles

    for subject in subjects[:4]:
        anatomy = dataclasses.replace(subject.anatomy, muscle_count=5.0)
        transposed = dataclasses.replace(anatomy, artery_vein_spacing=-anatomy.artery_vein_spacing)
        bellies = build_muscles(anatomy, subject.body, subject.lateral_sign)
        assert len(bellies) == 5
        assert build_muscles(transposed, subject.body, subject.lateral_sign) == bellies
