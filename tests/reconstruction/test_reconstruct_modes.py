"""Insertion and compounding modes, live == batch, labels, and bad input."""

import numba
import numpy as np
import pytest
from scipy.spatial.transform import Rotation

from resus.errors import ResusError
from resus.reconstruction.compounding import (
    ReconstructionSettings,
    Reconstructor,
    argmax_labels,
    reconstruct,
)
from resus.reconstruction.grid import VolumeGrid, aabb_grid
from sim.transforms import make_pose
from sim.ultrasound.probe import LinearProbe

VOXEL = 0.5e-3
# A calibration whose pixel centres fall exactly on voxel centres: col -> +x, row -> +z.
ALIGNED = np.array([[VOXEL, 0, 0, 0], [0, 0, -VOXEL, 0], [0, VOXEL, 0, 0], [0, 0, 0, 1.0]])
GRID = aabb_grid(VOXEL, bounds=((0, 0, 0), (15 * VOXEL, 9 * VOXEL, 11 * VOXEL)))


def aligned_pose(slice_index: int) -> np.ndarray:
    return make_pose(np.eye(3), (0.0, slice_index * VOXEL, 0.0))


@pytest.mark.parametrize("method", ["nn", "linear", "sdw"])
def test_a_frame_on_voxel_centres_is_copied_exactly(method: str) -> None:
    frame = np.random.default_rng(0).integers(0, 256, size=(12, 16), dtype=np.uint8)
    settings = ReconstructionSettings(method=method, radius=0.9, fill_passes=0)
    result = reconstruct([frame], [aligned_pose(4)], ALIGNED, GRID, settings)
    np.testing.assert_allclose(result.volume[:, 4, :], frame.T, atol=1e-4)
    assert result.observed[:, 4, :].all()
    assert not np.delete(result.observed, 4, axis=1).any()


@pytest.mark.parametrize("method", ["nn", "linear"])
def test_mean_averages_and_maximum_keeps_the_brightest(method: str) -> None:
    dark = np.full((12, 16), 40, dtype=np.uint8)
    bright = np.full((12, 16), 200, dtype=np.uint8)
    poses = [aligned_pose(3), aligned_pose(3)]
    mean = reconstruct(
        [dark, bright], poses, ALIGNED, GRID, ReconstructionSettings(method=method, fill_passes=0)
    )
    peak = reconstruct(
        [bright, dark],
        poses,
        ALIGNED,
        GRID,
        ReconstructionSettings(method=method, compounding="max", fill_passes=0),
    )
    np.testing.assert_allclose(mean.volume[:, 3, :], 120.0)
    np.testing.assert_allclose(peak.volume[:, 3, :], 200.0)


def test_linear_splits_a_pixel_between_voxels_by_trilinear_weights() -> None:
    frame = np.full((12, 16), 100, dtype=np.uint8)
    pose = make_pose(np.eye(3), (0.0, 3.25 * VOXEL, 0.0))  # a quarter of the way from slice 3 to 4
    result = reconstruct(
        [frame], [pose], ALIGNED, GRID, ReconstructionSettings(method="linear", fill_passes=0)
    )
    reconstructor = Reconstructor(
        GRID, ALIGNED, ReconstructionSettings(method="linear", fill_passes=0)
    )
    reconstructor.add_frame(frame, pose)
    np.testing.assert_allclose(reconstructor.weight[:, 3, :], 0.75)
    np.testing.assert_allclose(reconstructor.weight[:, 4, :], 0.25)
    np.testing.assert_allclose(result.volume[:, 3:5, :], 100.0, rtol=1e-6)


def sweep(n: int = 30) -> tuple[np.ndarray, np.ndarray, np.ndarray, np.ndarray]:
    probe = LinearProbe(width=0.02, depth=0.02, cols=64, rows=48)
    rng = np.random.default_rng(7)
    tilt = Rotation.from_euler("xz", [6, -3], degrees=True).as_matrix()
    start = np.array([0.0, 0.002, 0.0])
    # advance along the frame normal (probe y), so every frame has the same in-plane coordinates
    poses = np.array([make_pose(tilt, start + i * 0.3e-3 * tilt[:, 1]) for i in range(n)])
    frames = rng.integers(0, 256, size=(n, 48, 64), dtype=np.uint8)
    labels = np.zeros((n, 48, 64), dtype=np.uint8)
    labels[:, 10:30, 5:25] = 1
    labels[:, 20:40, 40:60] = 2
    return frames, poses, probe.image_to_probe(), labels


SWEEP_GRID = aabb_grid(0.4e-3, bounds=((-0.011, 0.0, -0.001), (0.011, 0.014, 0.021)))


@pytest.mark.parametrize(
    ("method", "compounding"), [("sdw", "mean"), ("nn", "max"), ("linear", "mean")]
)
def test_live_frame_by_frame_equals_batch_and_any_thread_count(
    method: str, compounding: str
) -> None:
    frames, poses, image_to_probe, labels = sweep()
    settings = ReconstructionSettings(method=method, compounding=compounding)
    batch = reconstruct(
        frames, poses, image_to_probe, SWEEP_GRID, settings, labels=labels, n_classes=3
    )
    live = Reconstructor(SWEEP_GRID, image_to_probe, settings, n_classes=3)
    threads = numba.get_num_threads()
    for i, (frame, pose, label) in enumerate(zip(frames, poses, labels, strict=True)):
        numba.set_num_threads(1 + i % threads)
        live.add_frame(frame, pose, label)
        if i == len(frames) // 2:
            live.result()  # a live preview changes nothing
    numba.set_num_threads(threads)
    final = live.result()
    np.testing.assert_array_equal(final.volume, batch.volume)
    np.testing.assert_array_equal(final.labels, batch.labels)
    np.testing.assert_array_equal(final.filled, batch.filled)


def test_labels_are_reconstructed_where_they_were_drawn() -> None:
    frames, poses, image_to_probe, labels = sweep()
    result = reconstruct(
        frames,
        poses,
        image_to_probe,
        SWEEP_GRID,
        ReconstructionSettings(),
        labels=labels,
        n_classes=3,
    )
    # where each voxel centre falls in image coordinates (shared by every frame)
    indices = np.stack(
        np.meshgrid(*[np.arange(n) for n in SWEEP_GRID.shape], indexing="ij"), axis=-1
    )
    world = SWEEP_GRID.to_world(indices)
    image = np.linalg.inv(poses[15] @ image_to_probe)
    pixel = world @ image[:3, :3].T + image[:3, 3]
    col, row = pixel[..., 0], pixel[..., 1]
    inside_swept = result.observed
    artery = inside_swept & (row > 11) & (row < 28) & (col > 6) & (col < 23)
    vein = inside_swept & (row > 21) & (row < 38) & (col > 41) & (col < 58)
    tissue = (
        inside_swept
        & ((row < 8) | (row > 42))
        & ((col < 3) | (col > 27))
        & ((col < 38) | (col > 62))
    )
    assert artery.sum() > 100 and vein.sum() > 100 and tissue.sum() > 100
    assert (result.labels[artery] == 1).all()
    assert (result.labels[vein] == 2).all()
    assert (result.labels[tissue] == 0).all()
    assert (result.labels[~result.filled] == 0).all()


def test_argmax_counts_background_as_what_the_classes_leave() -> None:
    fractions = np.array([[[[0.3, 0.5, 0.1, 0.0]]], [[[0.4, 0.2, 0.1, 0.0]]]], dtype=np.float32)
    filled = np.array([[[True, True, True, False]]])
    np.testing.assert_array_equal(argmax_labels(fractions, filled)[0, 0], [2, 1, 0, 0])


def test_bad_input_is_refused_with_a_clear_message() -> None:
    frames, poses, image_to_probe, labels = sweep(2)
    reconstructor = Reconstructor(SWEEP_GRID, image_to_probe, n_classes=3)
    with pytest.raises(ResusError, match="2D numeric"):
        reconstructor.add_frame(frames[0, 0], poses[0])
    with pytest.raises(ResusError, match="4x4"):
        reconstructor.add_frame(frames[0], poses[0][:3])
    with pytest.raises(ResusError, match="label value 7"):
        reconstructor.add_frame(frames[0], poses[0], np.full_like(labels[0], 7))
    reconstructor.add_frame(frames[0], poses[0])
    with pytest.raises(ResusError, match="earlier frames"):
        reconstructor.add_frame(frames[0, :10], poses[0])
    with pytest.raises(ResusError, match="method"):
        ReconstructionSettings(method="cubic")
    with pytest.raises(ResusError, match="radius"):
        ReconstructionSettings(radius=0)
    with pytest.raises(ResusError, match="labels given"):
        Reconstructor(SWEEP_GRID, image_to_probe).add_frame(frames[0], poses[0], labels[0])


def test_a_grid_that_cannot_fit_in_memory_is_refused_before_allocating() -> None:
    huge = VolumeGrid(origin=np.zeros(3), axes=np.eye(3) * 1e-5, shape=(60_000, 60_000, 60_000))
    with pytest.raises(ResusError, match="GiB"):
        Reconstructor(huge, np.eye(4))
