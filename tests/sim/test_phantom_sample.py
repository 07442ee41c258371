"""Phantom.sample on known points: depth, materials and layers, vessel distance and normal."""

from __future__ import annotations

import numpy as np
import pytest

from sim.phantom import ARTERY, VESSEL_SEARCH_RADIUS, Phantom, TissueSample


def test_block_depth_material_and_air(default_phantom: Phantom) -> None:
    points = np.array([[0.0, 0.0, -0.001], [0.0, 0.0, 0.01], [0.06, 0.0, -0.01], [0, 0, -0.059]])
    sample = default_phantom.sample(points)
    np.testing.assert_allclose(sample.depth, [0.001, -0.01, 0.01, 0.059])
    np.testing.assert_array_equal(sample.material, [0, -1, -1, 0])  # gel, air, beside, gel
    np.testing.assert_array_equal(sample.label, 0)
    assert [m.name for m in default_phantom.materials] == ["gel", "blood"]
    assert np.isinf(sample.vessel_distance[0]) and sample.vessel_index[0] == -1
    np.testing.assert_array_equal(sample.vessel_normal[0], 0.0)
    np.testing.assert_allclose(default_phantom.skin_height([0.0, 0.06], [0.0, 0.0]), [0.0, np.nan])
    np.testing.assert_allclose(default_phantom.skin_normal([0.01], [0.02]), [[0.0, 0.0, 1.0]])


def test_vessel_distance_sign_and_normal_around_the_cfa(default_phantom: Phantom) -> None:
    spec = default_phantom.spec
    cfa = [v.name for v in spec.vessels].index("CFA")
    nodes = default_phantom.centrelines()["CFA"]
    node = nodes[len(nodes) // 3]
    tangent = nodes[len(nodes) // 3 + 1] - node
    up = np.cross(np.cross(tangent, [0.0, 0.0, 1.0]), tangent)
    up /= np.linalg.norm(up)  # perpendicular to the vessel, towards the skin
    radius = default_phantom.centreline_radii()["CFA"][len(nodes) // 3]
    offsets = np.array([-0.5 * radius, 0.0, radius - 1e-3, radius + 1e-3, radius + 0.004])
    sample = default_phantom.sample(node + offsets[:, None] * up)
    np.testing.assert_allclose(sample.vessel_distance, np.abs(offsets) - radius, atol=5e-6)
    np.testing.assert_array_equal(sample.vessel_index, cfa)
    np.testing.assert_array_equal(sample.label, [ARTERY, ARTERY, ARTERY, 0, 0])
    np.testing.assert_array_equal(sample.material, [1, 1, 1, 0, 0])  # blood inside, gel outside
    on_axis = 1  # where the normal's direction is arbitrary
    for i, expected in enumerate([-up, None, up, up, up]):
        if i != on_axis:
            assert sample.vessel_normal[i] @ expected > 0.999
    beyond = default_phantom.sample(node[None] + (radius + VESSEL_SEARCH_RADIUS + 1e-4) * up)
    assert np.isinf(beyond.vessel_distance[0]) and beyond.vessel_index[0] == -1


def test_a_smaller_search_radius_keeps_the_near_surfaces_exactly(default_phantom: Phantom) -> None:
    rng = np.random.default_rng(3)
    nodes = default_phantom.centrelines()["CFA"]
    points = nodes[rng.integers(len(nodes), size=4000)] + rng.normal(0.0, 0.004, (4000, 3))
    full = default_phantom.sample(points)
    near = default_phantom.sample(points, search_radius=1.0e-3)
    within = full.vessel_distance < 1.0e-3
    assert 0.2 < within.mean() < 0.9
    np.testing.assert_array_equal(near.vessel_distance[within], full.vessel_distance[within])
    np.testing.assert_array_equal(near.vessel_normal[within], full.vessel_normal[within])
    np.testing.assert_array_equal(near.vessel_index[within], full.vessel_index[within])
    assert np.isinf(near.vessel_distance[~within]).all()
    assert (near.vessel_index[~within] == -1).all()
    for name in ("label", "material", "depth"):
        np.testing.assert_array_equal(getattr(near, name), getattr(full, name))
    with pytest.raises(ValueError, match="search_radius must be >= 0, got -1"):
        default_phantom.sample(points, search_radius=-1.0)


def test_leg_layers_follow_the_curved_skin(leg_phantom: Phantom) -> None:
    radius = leg_phantom.spec.body.radius
    names = [m.name for m in leg_phantom.materials]
    assert names == ["skin", "fat", "muscle", "blood", "cortical bone"]
    angle = 0.6  # on the side of the thigh, where depth is along the tilted normal
    normal = leg_phantom.skin_normal(radius * np.sin(angle), 0.0)
    np.testing.assert_allclose(normal, [np.sin(angle), 0.0, np.cos(angle)])
    skin_point = np.array(
        [radius * np.sin(angle), 0.0, leg_phantom.skin_height(radius * np.sin(angle), 0)]
    )
    depths = np.array([0.001, 0.004, 0.02, -0.003])
    sample = leg_phantom.sample(skin_point - depths[:, None] * normal)
    np.testing.assert_allclose(sample.depth, depths, atol=1e-12)
    np.testing.assert_array_equal(sample.material, [0, 1, 2, -1])  # skin, fat, muscle, air
    assert np.isnan(leg_phantom.skin_height(radius * 1.01, 0.0))


def test_leg_femur_is_bone(leg_phantom: Phantom) -> None:
    femur = leg_phantom.spec.bones[0]
    centre = femur.control_points[1]
    points = centre + np.array(
        [[0, 0, 0], [0, 0, femur.radii[1] - 5e-4], [0, 0, femur.radii[1] + 5e-4]]
    )
    sample = leg_phantom.sample(points)
    np.testing.assert_array_equal(sample.material, [4, 4, 2])  # bone, bone, muscle
    np.testing.assert_array_equal(sample.label, 0)


def test_sample_reuses_buffers_and_matches_labels(default_phantom: Phantom) -> None:
    rng = np.random.default_rng(0)
    points = rng.uniform([-0.05, -0.08, -0.06], [0.05, 0.08, 0.005], (20_000, 3))
    out = TissueSample.empty(len(points))
    sample = default_phantom.sample(points, out=out)
    assert sample is out
    np.testing.assert_array_equal(sample.label, default_phantom.labels(points))
    assert sample.label.dtype == np.uint8 and sample.material.dtype == np.int8
    assert sample.vessel_index.dtype == np.int16 and sample.vessel_normal.shape == (20_000, 3)
    with pytest.raises(ValueError, match="out holds"):
        default_phantom.sample(points[:10], out=out)


def capsule_distance(points: np.ndarray, a: np.ndarray, b: np.ndarray, radius: float) -> np.ndarray:
    """Signed distance to the capsule of `radius` around segment ab (negative inside)."""
    axis = b - a
    t = np.clip((points - a) @ axis / (axis @ axis), 0.0, 1.0)
    return np.linalg.norm(points - (a + t[:, None] * axis), axis=1) - radius


def test_lymph_nodes_are_node_or_hilum_material_where_their_capsules_are_and_label_nothing() -> (
    None
):
    """Each subject's inguinal nodes, against the analytic capsules: points inside a node are
    the node (cortex) material, or the hilum material inside its hilum, label 0 either way (a
    node is not a vessel); points outside are the layer at their depth. Every hilum lies inside
    its node with at least `HILUM_CORTEX` of cortex round it; every node clears the vessels by
    min_gap and lies medial to the vein."""
    from sim.phantom import load_phantom
    from sim.phantom.anatomy import HILUM_CORTEX
    from sim.phantom.subjects import make_subject

    nominal = load_phantom("femoral")
    subject = next(s for s in (make_subject(nominal, k) for k in range(10)) if len(s.nodes) >= 2)
    assert len(subject.hila) == len(subject.nodes)
    phantom = Phantom(subject)
    names = [m.name for m in phantom.materials]
    node_material, hilum_material = names.index("lymph node"), names.index("lymph node hilum")
    rng = np.random.default_rng(3)

    def nearest_distance(points: np.ndarray, tubes) -> np.ndarray:
        """Signed distance to the nearest of `tubes` (nodes may touch one another)."""
        return np.min(
            [capsule_distance(points, *t.control_points, float(t.radii[0])) for t in tubes], axis=0
        )

    for node, hilum in zip(subject.nodes, subject.hila, strict=True):
        a, b = node.control_points
        radius = float(node.radii[0])
        centre = (a + b) / 2
        points = centre + rng.uniform(-1.0, 1.0, (6000, 3)) * (np.abs(b - a) / 2 + 1.5 * radius)
        in_hilum = capsule_distance(points, *hilum.control_points, float(hilum.radii[0])) < 0
        assert in_hilum.sum() > 100
        own = capsule_distance(points[in_hilum], a, b, radius)
        assert own.max() <= -HILUM_CORTEX + 1e-9  # the hilum wrapped in cortex
        node_distance, hilum_distance = (
            nearest_distance(points, subject.nodes),
            nearest_distance(points, subject.hila),
        )
        clear = (np.abs(node_distance) > 1e-6) & (np.abs(hilum_distance) > 1e-6)
        sample = phantom.sample(points[clear])
        inside, hilar = node_distance[clear] < 0, hilum_distance[clear] < 0
        assert (inside & ~hilar).sum() > 200 and hilar.sum() > 100 and (~inside).sum() > 200
        assert (sample.material[inside & ~hilar] == node_material).all()
        assert (sample.material[hilar] == hilum_material).all()
        assert not np.isin(sample.material[~inside], [node_material, hilum_material]).any()
        assert (sample.label[inside] == 0).all()
        vein = next(v for v in subject.vessels if v.name == "CFV")
        assert (centre[0] - vein.control_points[:, 0].mean()) * subject.lateral_sign < 0  # medial
        for label in (1, 2):  # the node keeps min_gap from every lumen (and wall)
            assert (
                phantom.vessel_sdf(points[clear][inside], label).min() >= subject.variation.min_gap
            )


def test_hila_moved_no_node_and_need_their_material_and_nodes() -> None:
    """Hila are drawn from a generator of their own: a spec without the hilum material gives
    the same subjects, nodes and all, only without hila; a hilum with no node to lie in, or no
    material, is refused in one line."""
    import dataclasses

    from sim.phantom import load_phantom
    from sim.phantom.subjects import make_subject

    nominal = load_phantom("femoral")
    without = dataclasses.replace(nominal, hilum=None, hila=())
    for k in range(4):
        subject, plain = make_subject(nominal, k), make_subject(without, k)
        assert subject.nodes == plain.nodes and subject.vessels == plain.vessels
        assert subject.muscles == plain.muscles and subject.nerves == plain.nerves
        assert len(subject.hila) == len(subject.nodes) and plain.hila == ()
    with pytest.raises(ValueError, match="hila need a hilum material and lymph nodes"):
        dataclasses.replace(nominal, hilum=None)
    with pytest.raises(ValueError, match="hila need a hilum material and lymph nodes"):
        dataclasses.replace(nominal, nodes=())
