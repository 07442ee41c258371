"""Phantom geometry against independent computations: labels, distances, normals, meshes."""

from __future__ import annotations

from collections.abc import Callable

import numpy as np
import pytest
import trimesh
from scipy.interpolate import CubicSpline

from sim.phantom import (
    ARTERY,
    VEIN,
    Phantom,
    PhantomSpec,
    VesselSpec,
    load_phantom,
    make_subject,
)
from sim.phantom.centreline import sample_tube

TOLERANCE = 10e-6
"""Where labels may legitimately differ from the brute force (m): the segment chain follows the
spline within 2 um (its chord tolerance), and a round cone's surface differs from "radius at the
foot of the perpendicular" by about r (dr/ds)^2 / 2 <= 6 um for the steepest taper here."""


def brute_force_signed_distance(
    vessels: tuple[VesselSpec, ...], points: np.ndarray, reach: float = 0.02
) -> np.ndarray:
    """Min over vessels of (distance to a dense spline polyline - radius at the foot).

    The polyline has 10x as many vertices as the phantom's chain (which is <= 1 mm per
    segment); points farther than `reach` from a vessel's box get +inf for that vessel.
    """
    best = np.full(len(points), np.inf)
    for vessel in vessels:
        chords = np.linalg.norm(np.diff(vessel.control_points, axis=0), axis=1)
        knots = np.concatenate([[0.0], np.cumsum(chords)])
        spline = CubicSpline(knots, vessel.control_points)
        chain_nodes = len(sample_tube(vessel).nodes)
        u = np.linspace(0.0, knots[-1], 10 * chain_nodes)
        nodes, radii = spline(u), np.interp(u, knots, vessel.radii)
        a, ab = nodes[:-1], np.diff(nodes, axis=0)
        lo, hi = nodes.min(axis=0) - reach, nodes.max(axis=0) + reach
        near = np.nonzero(((points >= lo) & (points <= hi)).all(axis=1))[0]
        for chunk in np.array_split(near, max(1, len(near) // 64)):
            p = points[chunk, None, :]
            t = np.clip(((p - a) * ab).sum(-1) / (ab * ab).sum(-1), 0.0, 1.0)
            distance = np.linalg.norm(p - (a + t[..., None] * ab), axis=-1)
            radius = radii[:-1] + t * np.diff(radii)
            best[chunk] = np.minimum(best[chunk], (distance - radius).min(axis=1))
    return best


def points_near_walls(phantom: Phantom, count: int, seed: int) -> np.ndarray:
    """Random points around the vessels: half within 0.3 mm of a wall, half up to 1.6 radii out."""
    rng = np.random.default_rng(seed)
    nodes = np.concatenate(list(phantom.centrelines().values()))
    radii = np.concatenate(list(phantom.centreline_radii().values()))
    inside_y = np.abs(nodes[:, 1]) < 0.07
    nodes, radii = nodes[inside_y], radii[inside_y]
    pick = rng.integers(0, len(nodes), count)
    direction = rng.normal(size=(count, 3))
    direction /= np.linalg.norm(direction, axis=1, keepdims=True)
    near_wall = radii[pick] + rng.uniform(-3e-4, 3e-4, count)
    anywhere = radii[pick] * rng.uniform(0.0, 1.6, count)
    reach = np.where(np.arange(count) % 2 == 0, near_wall, anywhere)
    return nodes[pick] + reach[:, None] * direction


@pytest.mark.parametrize("subject", [None, 3])
def test_labels_match_brute_force_point_in_tube(subject: int | None) -> None:
    spec = load_phantom("default")
    phantom = Phantom(spec if subject is None else make_subject(spec, subject))
    points = points_near_walls(phantom, 2000, seed=11)
    labels = phantom.labels(points)
    vessels = phantom.spec.vessels
    artery = brute_force_signed_distance(tuple(v for v in vessels if v.label == ARTERY), points)
    vein = brute_force_signed_distance(tuple(v for v in vessels if v.label == VEIN), points)
    expected = np.where(artery < 0, ARTERY, np.where(vein < 0, VEIN, 0))
    clear = np.minimum(np.abs(artery), np.abs(vein)) > TOLERANCE
    assert clear.mean() > 0.97  # the band is thin: few points fall inside it
    np.testing.assert_array_equal(labels[clear], expected[clear])
    assert (labels == ARTERY).sum() > 150 and (labels == VEIN).sum() > 150
    # Exact distances agree with the brute force to the same tolerance, inside and out
    # (within 12 mm, where the brute force's 20 mm reach around each vessel sees every vessel).
    for label, expected_distance in [(ARTERY, artery), (VEIN, vein)]:
        looked = expected_distance < 0.012
        assert looked.mean() > 0.5
        np.testing.assert_allclose(
            phantom.vessel_sdf(points, label)[looked], expected_distance[looked], atol=TOLERANCE
        )
    # sample() agrees with labels() and reports the nearer class's distance.
    sample = phantom.sample(points)
    np.testing.assert_array_equal(sample.label, labels)
    nearest = np.minimum(artery, vein)
    within = nearest < 4.9e-3
    np.testing.assert_allclose(sample.vessel_distance[within], nearest[within], atol=TOLERANCE)


def test_far_points_use_exact_distance_beyond_the_grid(default_phantom: Phantom) -> None:
    points = np.array([[0.0, 0.0, 0.5], [0.3, -0.2, -0.1]])
    artery = brute_force_signed_distance(
        tuple(v for v in default_phantom.spec.vessels if v.label == ARTERY), points, reach=1.0
    )
    np.testing.assert_allclose(default_phantom.vessel_sdf(points, ARTERY), artery, atol=TOLERANCE)
    assert np.isinf(default_phantom.sample(points).vessel_distance).all()


def test_normals_are_the_distance_gradient(default_phantom: Phantom) -> None:
    points = points_near_walls(default_phantom, 400, seed=5)
    sample = default_phantom.sample(points)
    near = np.isfinite(sample.vessel_distance) & (np.abs(sample.vessel_distance) > 1e-4)
    step = 1e-6
    gradient = np.zeros((len(points), 3))
    for axis in range(3):
        offset = np.zeros(3)
        offset[axis] = step
        plus = default_phantom.sample(points + offset).vessel_distance
        minus = default_phantom.sample(points - offset).vessel_distance
        gradient[:, axis] = (plus - minus) / (2 * step)
    np.testing.assert_allclose(np.linalg.norm(sample.vessel_normal[near], axis=1), 1.0, atol=1e-9)
    agreement = (gradient[near] * sample.vessel_normal[near]).sum(axis=1)
    assert np.quantile(agreement, 0.02) > 0.999  # a few points sit on a crease between tubes


def arc_tube_spec(
    gel_block_spec: Callable[..., PhantomSpec], radius: float, bend_radius: float, angle: float
) -> PhantomSpec:
    """One constant-radius tube along a circular arc in the plane z = -0.02."""
    theta = np.linspace(0.0, angle, 10)
    points = np.stack(
        [bend_radius * (1 - np.cos(theta)), bend_radius * np.sin(theta) - 0.03, -0.02 + 0 * theta],
        axis=1,
    )
    vessel = VesselSpec("arc", ARTERY, points, np.full(10, radius), 5e-4)
    return gel_block_spec("arc", (0.1, 0.1, 0.05), (vessel,))


def test_arc_tube_mesh_volume_matches_pappus(gel_block_spec) -> None:
    radius, bend, angle = 3e-3, 0.04, np.pi / 2
    phantom = Phantom(arc_tube_spec(gel_block_spec, radius, bend, angle))
    mesh = phantom.mesh("artery", resolution=0.25e-3)
    assert mesh.is_watertight and mesh.is_winding_consistent
    expected = np.pi * radius**2 * bend * angle + 4 / 3 * np.pi * radius**3
    assert mesh.volume == pytest.approx(expected, rel=0.01)


@pytest.mark.parametrize("what", ["artery", "vein"])
def test_vessel_meshes_are_watertight_and_match_the_exact_volume(
    default_phantom: Phantom, what: str
) -> None:
    mesh = default_phantom.mesh(what, resolution=0.5e-3)
    assert mesh.is_watertight and mesh.volume > 0
    rng = np.random.default_rng(2)
    lo, hi = mesh.bounds
    points = rng.uniform(lo, hi, (400_000, 3))
    label = ARTERY if what == "artery" else VEIN
    inside = (default_phantom.vessel_sdf(points, label) < 0).mean()
    monte_carlo = inside * np.prod(hi - lo)  # relative standard error about 0.5 %
    assert mesh.volume == pytest.approx(monte_carlo, rel=0.03)


def test_body_meshes_and_export_round_trip(tmp_path, gel_block_spec) -> None:
    block = Phantom(load_phantom("default")).mesh("body")
    assert block.is_watertight and block.volume == pytest.approx(0.1 * 0.16 * 0.06)
    assert block.bounds[1][2] == pytest.approx(0.0) and block.bounds[0][2] == pytest.approx(-0.06)
    leg_phantom = Phantom(load_phantom("leg"))
    leg = leg_phantom.mesh("body")
    assert leg.is_watertight
    # Facets stray less than the resolution (0.25 mm) from the circle: area within 2 res / R.
    assert leg.volume == pytest.approx(np.pi * 0.07**2 * 0.18, rel=2 * 0.25e-3 / 0.07)
    radial = np.hypot(leg.vertices[:, 0], leg.vertices[:, 2] + 0.07)
    np.testing.assert_allclose(radial[radial > 1e-9], 0.07, atol=1e-12)  # cap centres aside
    assert leg.bounds[1][2] == pytest.approx(0.0, abs=1e-9)
    bone = leg_phantom.mesh("bone", resolution=0.5e-3)
    assert bone.is_watertight
    for suffix in ("stl", "ply"):
        path = tmp_path / f"artery.{suffix}"
        mesh = Phantom(arc_tube_spec(gel_block_spec, 3e-3, 0.04, 1.0)).mesh(
            "artery", resolution=0.5e-3
        )
        mesh.export(path)
        back = trimesh.load(path)
        assert back.is_watertight
        assert back.volume == pytest.approx(mesh.volume, rel=1e-6)


def test_mesh_rejects_unknown_parts(default_phantom: Phantom) -> None:
    with pytest.raises(ValueError, match="mesh must be one of"):
        default_phantom.mesh("nerve")
    with pytest.raises(ValueError, match="no bone"):
        default_phantom.mesh("bone")
    with pytest.raises(ValueError, match="label must be"):
        default_phantom.vessel_sdf(np.zeros((1, 3)), 3)
    with pytest.raises(ValueError, match=r"shape \(N, 3\)"):
        default_phantom.labels(np.zeros((4, 2)))


@pytest.mark.parametrize("subject", [0, 3])
def test_structure_materials_match_brute_force_point_in_tube(subject: int) -> None:
    """Every point's material against the structures' own tubes, by brute force: a vessel's
    lumen is blood, else bone, lymph node (a hilum inside it), nerve (a fascicle inside it),
    muscle belly in that order, else a layer's material; so the one-lookup shortcut for points
    in no structure (`Phantom._structure_union`) changes nothing."""
    spec = make_subject(load_phantom("femoral"), subject)
    phantom = Phantom(spec)
    kinds = {kind: pair for kind, pair in spec.structures().items() if pair[1]}
    assert set(kinds) >= {"bone", "muscle", "nerve", "fascicle", "hilum"}
    rng = np.random.default_rng(subject)
    centres = np.concatenate([t.control_points for _, tubes in kinds.values() for t in tubes])
    points = centres[rng.integers(0, len(centres), 4000)] + rng.normal(0.0, 4e-3, (4000, 3))
    below_skin = points[:, 2] < phantom.skin_height(points[:, 0], points[:, 1])
    points = points[below_skin & (phantom.labels(points) == 0)]  # in the body, not a lumen
    distance = {
        kind: brute_force_signed_distance(tubes, points, 0.04) for kind, (_, tubes) in kinds.items()
    }
    clear = np.min([np.abs(d) for d in distance.values()], axis=0) > TOLERANCE
    points = points[clear]
    inside = {kind: d[clear] < 0 for kind, d in distance.items()}
    layers = np.arange(len(spec.layers))
    expected = np.full(len(points), -1)  # -1: a layer's material
    for kind in ("muscle", "nerve", "node", "bone"):  # the later kind overrules the earlier
        if kind in kinds:
            expected[inside[kind]] = phantom.materials.index(kinds[kind][0])
    nerve = phantom.materials.index(kinds["nerve"][0])
    expected[(expected == nerve) & inside["fascicle"]] = phantom.materials.index(
        kinds["fascicle"][0]
    )
    if "hilum" in kinds:  # a node's hilum inside its cortex
        node = phantom.materials.index(kinds["node"][0])
        expected[(expected == node) & inside["hilum"]] = phantom.materials.index(kinds["hilum"][0])
    material = phantom.sample(points).material
    in_structure = expected >= 0
    assert in_structure.sum() > 500 and (~in_structure).sum() > 500
    np.testing.assert_array_equal(material[in_structure], expected[in_structure])
    assert np.isin(material[~in_structure], layers).all()
