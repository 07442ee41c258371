"""The vessel map and needle site on a simulated sweep, checked against the phantom's truth.

One 8 cm sweep with 96 x 96 frames (the femoral bifurcation and the saphenous junction in
view), mapped once at 0.4 mm voxels from its ground-truth labels.
"""

import dataclasses
import itertools
import math

import numpy as np
import pytest
from scipy.spatial import cKDTree
from simulated_sweeps import simulate_vessel_sweep

from resus.acquisition.simulation import phantom_spec, resolve_scene
from resus.sweep.io import read_sweep
from resus.vessels.anatomy import AnatomicalFrame
from resus.vessels.map import VesselMapSettings, build_vessel_map
from resus.vessels.mesh_distance import MeshDistance
from resus.vessels.metrics import needle_truth, score_map
from resus.vessels.needle import NeedleSettings, SkinModel, plan_needle
from resus.vessels.track import vessel_track
from sim.phantom import Phantom
from sim.transforms import invert_pose

SETTINGS = VesselMapSettings(spacing=0.4e-3)


@pytest.fixture(scope="module")
def mapped(tmp_path_factory):
    scene = resolve_scene("default", None, None)
    path = tmp_path_factory.mktemp("vessels") / "sweep.h5"
    sweep = read_sweep(simulate_vessel_sweep(path, start_y=-0.06, length=0.08, pixels=96))
    frame = AnatomicalFrame.from_scene(scene)
    vessel_map = build_vessel_map(
        sweep.frames, sweep.labels, sweep.probe_to_base, sweep.image_to_probe, frame, SETTINGS
    )
    tracks = {
        name: vessel_track(vessel_map.labels == label, vessel_map.grid, frame.proximal)
        for name, label in (("artery", 1), ("vein", 2))
    }
    return scene, sweep, frame, vessel_map, tracks, Phantom(phantom_spec(scene))


@pytest.fixture(scope="module")
def scores(mapped):
    scene, _, _, vessel_map, tracks, phantom = mapped
    return score_map(vessel_map, phantom, scene.phantom_to_base, tracks)


def test_ground_truth_map_lies_within_half_a_millimetre_of_the_phantom(mapped, scores) -> None:
    vessel_map = mapped[3]
    for name in ("artery", "vein"):
        score = scores[name]
        assert score.mean_surface_distance_mm < 0.5, (name, score)
        assert score.hd95_mm < 1.0, (name, score)
        assert score.dice > 0.9, (name, score)
        assert score.centreline_distance_mm < 0.5, (name, score)
    assert vessel_map.meshes["artery"].is_watertight and vessel_map.meshes["vein"].is_watertight


def test_dice_matches_an_independent_lookup_of_the_phantom(mapped, scores) -> None:
    scene, _, _, vessel_map, _, phantom = mapped
    # Independently: the voxels whose whole L1 ball of 3 voxels holds data (the scored region
    # by its definition, not by erosion), labelled through the pose inverted by hand.
    grid = vessel_map.grid
    rotation, origin = scene.phantom_to_base[:3, :3], scene.phantom_to_base[:3, 3]
    padded = np.pad(vessel_map.filled, 3, constant_values=False)
    region = np.ones(grid.shape, dtype=bool)
    for offset in itertools.product(range(-3, 4), repeat=3):
        if sum(map(abs, offset)) <= 3:
            window = zip(offset, grid.shape, strict=True)
            region &= padded[tuple(slice(3 + d, 3 + d + n) for d, n in window)]
    index = np.argwhere(region)
    truth = phantom.labels((grid.to_world(index.astype(float)) - origin) @ rotation)
    mapped_labels = vessel_map.labels[tuple(index.T)]
    for label, name in ((1, "artery"), (2, "vein")):
        a, b = mapped_labels == label, truth == label
        assert scores[name].dice == pytest.approx(2 * np.sum(a & b) / (a.sum() + b.sum()))


def test_swapped_labels_are_put_right_by_anatomy(mapped) -> None:
    _, sweep, frame, vessel_map, _, _ = mapped
    swapped = np.choose(sweep.labels, [0, 2, 1]).astype(np.uint8)
    swapped_map = build_vessel_map(
        sweep.frames, swapped, sweep.probe_to_base, sweep.image_to_probe, frame, SETTINGS
    )
    np.testing.assert_array_equal(swapped_map.labels, vessel_map.labels)
    assert all(part.segmented_label != part.label for part in swapped_map.parts)


@pytest.mark.parametrize(
    ("target", "label", "other"), [("vein", 2, "artery"), ("artery", 1, "vein")]
)
def test_needle_path_reaches_the_target_lumen_and_keeps_its_clearance(
    mapped, target, label, other
) -> None:
    scene, sweep, _, vessel_map, tracks, phantom = mapped
    settings = NeedleSettings(angle_deg=45.0, min_clearance=3e-3)
    plan = plan_needle(
        tracks[target], target, vessel_map.meshes[other], SkinModel.from_poses(sweep.probe_to_base),
        vessel_map.covered, vessel_map.label_at, label, settings,
    )  # fmt: skip
    assert plan.safe, plan.reason
    # Geometry: 45 degrees to the skin (probe face), pointing proximally, ending at the target.
    normal = -sweep.probe_to_base[0, :3, 2]
    assert math.degrees(math.asin(-plan.direction @ normal)) == pytest.approx(45.0, abs=1.0)
    assert plan.direction @ np.array([0.0, -1.0, 0.0]) > 0.6
    assert plan.insertion_depth == pytest.approx(plan.vessel_depth / math.sin(math.pi / 4))
    assert plan.wall_depth < plan.insertion_depth
    # On the phantom's exact geometry: the tip is in the lumen and the clearance holds.
    truth = needle_truth(plan.path(1e-4), label, phantom, invert_pose(scene.phantom_to_base))
    assert truth.tip_in_target_lumen and truth.tip_depth_in_target_mm > 2.0
    assert truth.clearance_from_other_mm > 3.0 - 0.5
    # Clearance against brute force: every path point to dense samples of the other surface.
    path = plan.path(settings.path_step)
    surface = np.vstack([vessel_map.meshes[other].vertices,
                         vessel_map.meshes[other].sample(200000, seed=1)])  # fmt: skip
    brute = cKDTree(surface).query(path)[0].min()
    assert plan.clearance <= brute + 1e-9
    assert plan.clearance == pytest.approx(brute, abs=0.05e-3)
    finer = MeshDistance(vessel_map.meshes[other]).minimum(plan.path(0.01e-3))
    assert finer == pytest.approx(plan.clearance, abs=0.01e-3)
    # The chosen station is straight and away from branches.
    assert plan.station["branch_distance_mm"] >= 10.0
    assert plan.station["curvature_per_m"] <= 25.0


def test_no_safe_site_when_the_clearance_cannot_be_met(mapped) -> None:
    _, sweep, _, vessel_map, tracks, _ = mapped
    skin = SkinModel.from_poses(sweep.probe_to_base)
    plan = plan_needle(
        tracks["vein"], "vein", vessel_map.meshes["artery"], skin, vessel_map.covered,
        vessel_map.label_at, 2, NeedleSettings(min_clearance=30e-3),
    )  # fmt: skip
    assert not plan.safe and plan.entry is None
    assert "no safe site" in plan.reason and "too close" in plan.reason
    assert plan.rejected["too close"] > 0
    strict = dataclasses.replace(NeedleSettings(), min_branch_distance=1.0)
    plan = plan_needle(
        tracks["vein"], "vein", vessel_map.meshes["artery"], skin, vessel_map.covered,
        vessel_map.label_at, 2, strict,
    )  # fmt: skip
    assert not plan.safe and plan.rejected["near a branch"] == len(tracks["vein"].positions)
