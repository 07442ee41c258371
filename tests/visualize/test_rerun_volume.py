"""Volumes, reslices, the phantom and training curves in rerun, read back from .rrd."""

from __future__ import annotations

import numpy as np
import pytest
from rerun_readback import Recording

from resus.acquisition.simulation import phantom_spec, resolve_scene
from resus.errors import ResusError
from resus.reconstruction.grid import VolumeGrid
from resus.reslicing.reslice import Reslice
from resus.visualize import (
    log_phantom,
    log_reslices,
    log_training_curves,
    log_volume,
    open_recording,
)
from resus.visualize.quads import tinted_texture
from resus.visualize.volume import outline_segments, slice_to_world
from sim.phantom import Phantom

SHEARED = VolumeGrid(
    origin=[0.1, -0.2, 0.05],
    axes=[[1e-3, 0.0, 0.0], [2e-4, 1e-3, 0.0], [0.0, 1e-4, 2e-3]],
    shape=(6, 5, 4),
)
"""A non-orthogonal grid, like the RANSAC parallelepiped."""
BOX = VolumeGrid(origin=[0.0, 0.1, 0.2], axes=np.diag([1e-3, 2e-3, 5e-4]), shape=(6, 5, 4))


def volume_on(grid: VolumeGrid, seed: int = 0) -> tuple[np.ndarray, np.ndarray]:
    rng = np.random.default_rng(seed)
    return rng.uniform(0, 255, grid.shape), rng.integers(0, 3, grid.shape).astype(np.uint8)


def saved(tmp_path, log) -> Recording:
    path = tmp_path / "out.rrd"
    with open_recording("test", save=path) as session:
        log(session.stream)
    return Recording(path)


@pytest.mark.parametrize("axis", [0, 1, 2])
def test_slice_pixels_land_on_their_voxel_centres(axis):
    index = 2
    to_world = slice_to_world(SHEARED, axis, index)
    across, down = (a for a in range(3) if a != axis)
    for col, row in [(0, 0), (3, 1), (1, 2)]:
        voxel = np.zeros(3)
        voxel[[axis, across, down]] = index, col, row
        np.testing.assert_allclose(
            (to_world @ [col, row, 0, 1])[:3], SHEARED.to_world(voxel), atol=1e-15
        )


def test_volume_slices_outline_and_textures(tmp_path):
    volume, labels = volume_on(SHEARED)
    recording = saved(tmp_path, lambda stream: log_volume(stream, volume, SHEARED, labels))
    for axis, name in enumerate("ijk"):
        quad = recording.static[f"/world/volume/slices/{name}"]
        index = SHEARED.shape[axis] // 2
        grey = np.clip(np.rint(volume), 0, 255).astype(np.uint8).take(index, axis).T
        texture = np.array(quad["Mesh3D:albedo_texture_buffer"][0], dtype=np.uint8)
        expected = tinted_texture(grey, labels.take(index, axis).T)
        np.testing.assert_array_equal(texture.reshape(expected.shape), expected)
        corners = np.array(quad["Mesh3D:vertex_positions"])
        across, down = (a for a in range(3) if a != axis)
        first = np.zeros(3)
        first[[axis, across, down]] = index, -0.5, -0.5
        np.testing.assert_allclose(corners[0], SHEARED.to_world(first), atol=1e-7)
    segments = outline_segments(SHEARED)
    lengths = np.sort(np.linalg.norm(segments[:, 1] - segments[:, 0], axis=1))
    expected = np.sort(np.repeat(np.array(SHEARED.shape) * SHEARED.spacing, 4))
    np.testing.assert_allclose(lengths, expected)
    assert len(recording.static["/world/volume/outline"]["LineStrips3D:strips"]) == 12


def test_dense_volume_on_a_box_grid_and_refused_on_a_sheared_one(tmp_path):
    volume, _ = volume_on(BOX)
    recording = saved(tmp_path, lambda stream: log_volume(stream, volume, BOX, dense=True))
    dense = recording.static["/world/volume/dense"]
    translation = np.array(dense["Volume3D:translation"]).ravel()
    np.testing.assert_allclose(translation, BOX.origin - 0.5 * BOX.spacing, atol=1e-7)
    with pytest.raises(ResusError, match="orthogonal"):
        sheared, _ = volume_on(SHEARED)
        saved(tmp_path, lambda stream: log_volume(stream, sheared, SHEARED, dense=True))


def test_volume_must_match_its_grid(tmp_path):
    with pytest.raises(ResusError, match="match the grid"):
        saved(tmp_path, lambda stream: log_volume(stream, np.zeros((2, 2, 2)), BOX))


def test_reslices_are_planes_on_the_reslice_timeline(tmp_path):
    rng = np.random.default_rng(1)
    reslices = []
    for k in range(7):
        plane = np.eye(4)
        plane[:3, :3] *= 1e-3
        plane[:3, 3] = [0.0, 0.0, k * 1e-3]
        reslices.append(
            Reslice(
                image=rng.integers(0, 255, (8, 8), dtype=np.uint8),
                label=rng.integers(0, 3, (8, 8), dtype=np.uint8),
                angles_deg=(10.0 * k, 0.0),
                slice_index=k,
                plane_to_world=plane,
            )
        )
    names = ("background", "artery", "vein")
    count = []
    recording = saved(
        tmp_path, lambda stream: count.append(log_reslices(stream, reslices, names, limit=4))
    )
    assert count == [4]
    quads = recording.temporal["/world/reslices/plane"]
    assert [row["reslice"] for row in quads] == [0, 2, 4, 6]
    for row in quads:
        k = row["reslice"]
        corners = np.array(row["Mesh3D:vertex_positions"])
        np.testing.assert_allclose(corners[2], [7.5e-3, 7.5e-3, k * 1e-3], atol=1e-9)
    assert len(recording.temporal["/reslice/image"]) == 4


def test_phantom_is_placed_by_the_scene(tmp_path):
    scene = resolve_scene("default", None, None)
    phantom = Phantom(phantom_spec(scene))
    recording = saved(tmp_path, lambda stream: log_phantom(stream, scene, phantom))
    placed = recording.static["/world/phantom"]
    np.testing.assert_allclose(
        np.ravel(placed["Transform3D:translation"]), scene.phantom_to_base[:3, 3], atol=1e-7
    )
    body = recording.static["/world/phantom/body"]["LineStrips3D:strips"]
    assert len(body) == 12  # the box body's edges, no face diagonals
    for vessel in ("artery", "vein"):
        vertices = np.array(recording.static[f"/world/phantom/{vessel}"]["Mesh3D:vertex_positions"])
        assert len(vertices) > 100
        assert vertices[:, 2].max() < 0  # below the skin, in the phantom frame


def test_training_curves_per_epoch(tmp_path):
    history = [
        {
            "epoch": 1,
            "train_loss": 0.9,
            "validation_loss": 1.0,
            "validation_iou": {"artery": 0.1, "vein": 0.2, "mean": 0.15},
        },
        {
            "epoch": 2,
            "train_loss": 0.5,
            "validation_loss": 0.7,
            "validation_iou": {"artery": 0.4, "vein": 0.3, "mean": 0.35},
        },
    ]
    paths = []
    recording = saved(tmp_path, lambda stream: paths.extend(log_training_curves(stream, history)))
    assert "training/validation_iou/artery" in paths
    assert recording.times("/training/train_loss", "epoch").tolist() == [1, 2]
    assert recording.column("/training/validation_iou/vein", "Scalars:scalars") == [[0.2], [0.3]]
    with pytest.raises(ResusError, match="no training history"):
        saved(tmp_path, lambda stream: log_training_curves(stream, []))
