"""Geometry under the vessel map: exact mesh distances, Dice, and the artery/vein anatomy rule."""

import math

import numpy as np
import pytest
import trimesh

from resus.reconstruction.grid import VolumeGrid
from resus.vessels.anatomy import AnatomicalFrame, assign_by_anatomy, find_parts
from resus.vessels.mesh_distance import MeshDistance, closest_points_on_triangles
from resus.vessels.metrics import dice, distance_to_polylines
from sim.robot.scene_config import SceneConfig
from sim.transforms import make_pose


def brute_force_triangle_distance(point: np.ndarray, triangle: np.ndarray, n: int = 400) -> float:
    """Distance to a dense barycentric lattice of the triangle (an upper bound, tight to ~1e-3)."""
    u, v = np.meshgrid(np.linspace(0, 1, n), np.linspace(0, 1, n))
    keep = u + v <= 1
    a, b, c = triangle
    lattice = a + u[keep, None] * (b - a) + v[keep, None] * (c - a)
    return float(np.linalg.norm(lattice - point, axis=1).min())


def test_closest_point_on_triangle_matches_brute_force() -> None:
    rng = np.random.default_rng(1)
    triangles = rng.normal(size=(60, 3, 3))
    points = rng.normal(size=(60, 3)) * 2
    closest = closest_points_on_triangles(points, triangles)
    exact = np.linalg.norm(points - closest, axis=1)
    brute = [brute_force_triangle_distance(p, t) for p, t in zip(points, triangles, strict=True)]
    np.testing.assert_allclose(exact, brute, atol=2e-2 * np.ptp(triangles) / 400 + 1e-3)
    assert np.all(exact <= np.array(brute) + 1e-12)


def test_mesh_distance_is_exact_for_a_box() -> None:
    box = trimesh.creation.box(extents=(2.0, 4.0, 6.0))
    rng = np.random.default_rng(2)
    points = rng.uniform(-5, 5, size=(500, 3))
    outside = np.linalg.norm(np.maximum(np.abs(points) - (1.0, 2.0, 3.0), 0.0), axis=1)
    inside = np.min((1.0, 2.0, 3.0) - np.abs(points), axis=1)
    expected = np.where(outside > 0, outside, inside)
    distance = MeshDistance(box)
    np.testing.assert_allclose(distance(points), expected, atol=1e-12)
    assert distance.minimum(points) == pytest.approx(expected.min(), abs=1e-12)


def test_distance_to_polyline_is_exact() -> None:
    line = np.array([[0.0, 0.0, 0.0], [1.0, 0.0, 0.0], [1.0, 1.0, 0.0]])
    points = np.array([[0.5, -2.0, 0.0], [2.0, 0.5, 0.0], [-1.0, 0.0, 1.0], [1.0, 2.0, 0.0]])
    np.testing.assert_allclose(
        distance_to_polylines(points, [line]), [2.0, 1.0, math.sqrt(2), 1.0], atol=1e-12
    )


def ball(grid: VolumeGrid, centre: np.ndarray, radius: float) -> np.ndarray:
    indices = np.indices(grid.shape).reshape(3, -1).T.astype(float)
    inside = np.linalg.norm(grid.to_world(indices) - centre, axis=1) <= radius
    return inside.reshape(grid.shape)


def test_dice_of_two_balls_matches_their_analytic_overlap() -> None:
    radius, offset = 1.0, 0.8
    grid = VolumeGrid(np.full(3, -1.6), np.eye(3) * 0.03, (135, 108, 108))
    a = ball(grid, np.zeros(3), radius)
    b = ball(grid, np.array([offset, 0.0, 0.0]), radius)
    lens = math.pi * (2 * radius - offset) ** 2 * (offset**2 + 4 * radius * offset) / (12 * offset)
    expected = 2 * lens / (2 * 4 / 3 * math.pi * radius**3)
    assert dice(a, b) == pytest.approx(expected, rel=0.01)
    assert dice(a, a) == 1.0
    assert dice(a & False, b & False) == 1.0


def two_tubes(leg_side: str, yaw: float) -> tuple[np.ndarray, VolumeGrid, AnatomicalFrame]:
    """An artery (radius 4 mm, lateral) and vein (5 mm, medial) along the leg, and a small
    lateral branch, labelled 1/2 as anatomy says, in the phantom frame turned by `yaw`."""
    scene = SceneConfig(leg_side=leg_side, phantom_to_base=make_pose(
        np.array([[math.cos(yaw), -math.sin(yaw), 0], [math.sin(yaw), math.cos(yaw), 0],
                  [0, 0, 1]]), np.zeros(3)))  # fmt: skip
    frame = AnatomicalFrame.from_scene(scene)
    grid = VolumeGrid(np.array([-0.03, -0.03, -0.03]), np.eye(3) * 0.5e-3, (121, 121, 61))
    points = grid.to_world(np.indices(grid.shape).reshape(3, -1).T.astype(float))
    local = (points - scene.phantom_to_base[:3, 3]) @ scene.phantom_to_base[:3, :3]
    side = 1.0 if leg_side == "right" else -1.0

    def tube(x: float, radius: float) -> np.ndarray:
        return (np.hypot(local[:, 0] - side * x, local[:, 2] + 0.015) < radius) & (
            np.abs(local[:, 1]) < 0.02
        )

    labels = np.zeros(len(points), dtype=np.uint8)
    labels[tube(0.007, 0.004)] = 1
    labels[tube(-0.007, 0.005)] = 2
    branch = np.linalg.norm(local - (side * 0.018, 0.0, -0.015), axis=1) < 0.003
    labels[branch] = 1
    return labels.reshape(grid.shape), grid, frame


@pytest.mark.parametrize(("leg_side", "yaw"), [("right", 0.0), ("left", 0.0), ("right", 2.5)])
def test_anatomy_relabels_swapped_and_merged_classes(leg_side: str, yaw: float) -> None:
    truth, grid, frame = two_tubes(leg_side, yaw)
    swapped = np.choose(truth, [0, 2, 1]).astype(np.uint8)
    merged = (truth > 0).astype(np.uint8)
    for segmented in (truth, swapped, merged):
        part_index, parts = find_parts(truth > 0, segmented, grid, frame, min_volume=1e-9)
        reasoning = assign_by_anatomy(parts)
        assert len(parts) == 3
        relabelled = np.zeros_like(truth)
        for part in parts:
            relabelled[part_index == part.index] = part.label
        np.testing.assert_array_equal(relabelled, truth)
        assert "artery" in reasoning
    assert sum(p.label != p.segmented_label for p in parts) == 1  # merged: the vein changes


def test_specks_are_dropped_and_a_single_part_keeps_its_class() -> None:
    truth, grid, frame = two_tubes("right", 0.0)
    vein_only = np.where(truth == 2, 2, 0).astype(np.uint8)
    vein_only[5:7, 5:7, 5:7] = 2  # a 2x2x2-voxel speck, 1 mm^3
    part_index, parts = find_parts(vein_only > 0, vein_only, grid, frame, min_volume=20e-9)
    assert len(parts) == 1 and part_index.max() == 2
    assert "one vessel part" in assign_by_anatomy(parts)
    assert parts[0].label == 2
