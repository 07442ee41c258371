"""Scan patterns against their definitions, and imaging segments through the YAML file."""

import numpy as np
import pytest
from scipy.spatial.transform import Rotation

from resus.acquisition.patterns import (
    LinearPattern,
    fan_sweep,
    linear_sweep,
    multipass_sweep,
    raster_sweep,
)
from resus.acquisition.simulation import phantom_spec, resolve_scene
from resus.acquisition.trajectory import Trajectory
from resus.errors import ResusError
from sim.phantom import Phantom
from sim.transforms import invert_pose


@pytest.fixture(scope="module", params=["default", "leg"])
def scene(request):
    config = resolve_scene(request.param, None, None)
    return config, Phantom(phantom_spec(config))


def in_phantom(scene_config, trajectory, times=None):
    poses = trajectory.waypoints if times is None else trajectory.poses_at(times)
    return invert_pose(scene_config.phantom_to_base) @ poses


def test_every_pattern_keeps_the_probe_on_the_skin_and_normal_to_it(scene) -> None:
    config, phantom = scene
    for make in (linear_sweep, multipass_sweep, raster_sweep):
        trajectory = make(phantom, config.phantom_to_base, start=(-0.01, -0.04))
        poses = in_phantom(config, trajectory, np.linspace(0, trajectory.duration, 50))
        x, y, z = poses[:, :3, 3].T
        # On the skin between waypoints to within the chord sag of 5 mm steps on the leg.
        np.testing.assert_allclose(z, phantom.skin_height(x, y), atol=1e-4)
        normals = phantom.skin_normal(x, y)
        assert np.einsum("ni,ni->n", poses[:, :3, 2], -normals).min() > np.cos(np.radians(5))


def test_fan_rocks_about_the_array_on_one_spot(scene) -> None:
    config, phantom = scene
    fan = fan_sweep(phantom, config.phantom_to_base, start=(0.0, 0.01), fan_deg=30)
    poses = in_phantom(config, fan)
    np.testing.assert_allclose(poses[:, :2, 3], [[0.0, 0.01]] * len(poses), atol=1e-12)
    turn = Rotation.from_matrix(poses[0, :3, :3].T @ poses[-1, :3, :3]).as_rotvec()
    assert np.degrees(np.linalg.norm(turn)) == pytest.approx(30)
    np.testing.assert_allclose(np.abs(turn / np.linalg.norm(turn)), [1, 0, 0], atol=1e-9)
    assert fan.path_length == pytest.approx(np.radians(30) * fan.rotation_radius)


def test_raster_alternates_passes_joined_by_marked_u_turns(scene) -> None:
    config, phantom = scene
    raster = raster_sweep(phantom, config.phantom_to_base, passes=3, offset=0.015, length=0.05)
    assert len(raster.imaging_segments) == 3
    first_end, second_start = raster.imaging_segments[0][1], raster.imaging_segments[1][0]
    # A half circle of diameter 15 mm, drawn with 5 chords (1.6 % short of the arc).
    assert second_start - first_end == pytest.approx(np.pi * 0.0075, rel=0.03)
    times = np.linspace(0, raster.duration, 400)
    poses = in_phantom(config, raster, times)
    segment = raster.imaging_segment_at(times)
    first, second = poses[segment == 0], poses[segment == 1]
    assert first[-1, 1, 3] > first[0, 1, 3] and second[-1, 1, 3] < second[0, 1, 3]
    assert np.mean(second[:, 0, 3] - first[:, 0, 3].mean()) == pytest.approx(0.015, abs=2e-3)
    # The array keeps its heading (no turn about the beam) through the U-turns.
    assert np.abs(poses[:, 1, 0]).max() < 1e-9


def test_multipass_returns_in_transit_and_scans_one_way(scene) -> None:
    config, phantom = scene
    multipass = multipass_sweep(phantom, config.phantom_to_base, passes=2, offset=0.02)
    times = np.linspace(0, multipass.duration, 600)
    poses = in_phantom(config, multipass, times)
    segment = multipass.imaging_segment_at(times)
    for k in (0, 1):
        assert np.all(np.diff(poses[segment == k, 1, 3]) >= 0)
    assert (segment == -1).any()


def test_imaging_segments_survive_the_yaml_file(tmp_path, scene) -> None:
    config, phantom = scene
    raster = raster_sweep(phantom, config.phantom_to_base)
    raster.to_yaml(tmp_path / "raster.yaml")
    loaded = Trajectory.from_yaml(tmp_path / "raster.yaml")
    np.testing.assert_allclose(loaded.imaging_segments, raster.imaging_segments, atol=1e-12)
    np.testing.assert_allclose(loaded.waypoints, raster.waypoints, atol=1e-12)


def test_bad_pattern_input_is_a_clear_error(scene) -> None:
    config, phantom = scene
    with pytest.raises(ResusError, match=r"RasterPattern\.passes must be at least 1, got 0"):
        raster_sweep(phantom, config.phantom_to_base, passes=0)
    with pytest.raises(ResusError, match=r"MultipassPattern\.offset must be a non-zero"):
        multipass_sweep(phantom, config.phantom_to_base, offset=0.0)
    with pytest.raises(ResusError, match=r"FanPattern\.fan_deg must lie in \(0, 180\)"):
        fan_sweep(phantom, config.phantom_to_base, fan_deg=200)
    with pytest.raises(ResusError, match=r"LinearPattern\.speed must be positive, got -1"):
        LinearPattern(speed=-1)
    with pytest.raises(ResusError, match=r"LinearPattern\.length must be positive, got 0"):
        LinearPattern(length=0)
    with pytest.raises(ResusError, match="leaves the phantom's skin"):
        linear_sweep(phantom, config.phantom_to_base, start=(0.0, 0.05), length=0.2)
    trajectory = linear_sweep(phantom, config.phantom_to_base)
    with pytest.raises(ResusError, match="imaging_segments"):
        Trajectory(waypoints=trajectory.waypoints, imaging_segments=((0.05, 0.01),))
