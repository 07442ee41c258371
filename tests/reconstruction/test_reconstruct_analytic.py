"""SDW compounding against known answers: frames cut from a known 3D field at known poses.

Error budget. The SDW value at a voxel is the weighted mean of the field at the pixels within
r. For a linear field it is the field at the pixels' weighted centroid, which a dense sweep
puts within a few micrometres of the voxel centre: error ~0.03 grey levels. For a curved field
the weighted mean also picks up the second-order term, about (E[d^2]/6) * laplacian(f), with
E[d^2] < r^2: a bias that grows as r^2 (measured here: 0.31, 0.55, 0.95 grey levels RMS at
r = 1, 1.5, 2 voxels for this field), which no weighting of samples on one side of a curved
surface can remove; it is the price of the kernel's smoothing. Uint8 frames add at most half a
grey level of rounding, averaged down by compounding.
"""

import numpy as np
import pytest
from reconstruct_reference import sdw_accumulate_numpy
from scipy.spatial.transform import Rotation

from resus.reconstruction.compounding import ReconstructionSettings, reconstruct
from resus.reconstruction.grid import aabb_grid
from sim.transforms import make_pose
from sim.ultrasound.probe import LinearProbe

PROBE = LinearProbe(width=0.024, depth=0.024, cols=96, rows=96)  # 0.25 mm pixels
TILT = Rotation.from_euler("xz", [8, 4], degrees=True).as_matrix()
POSES = np.array([make_pose(TILT, (0.0, -0.002 + i * 0.25e-3, -0.002)) for i in range(100)])
GRID = aabb_grid(0.5e-3, bounds=((-0.008, 0.004, 0.004), (0.008, 0.016, 0.018)))
NO_FILL = {"fill_passes": 0}


def smooth_field(points: np.ndarray) -> np.ndarray:
    x, y, z = points[..., 0], points[..., 1], points[..., 2]
    return (
        128
        + 60 * np.sin(2 * np.pi * x / 0.012) * np.cos(2 * np.pi * z / 0.015)
        + 30 * np.sin(2 * np.pi * y / 0.010)
    )


def linear_field(points: np.ndarray) -> np.ndarray:
    return 100 + points @ np.array([2000.0, -3000.0, 1500.0])


def cut_frames(field, dtype=np.float32) -> np.ndarray:
    pixels = PROBE.pixel_points()
    frames = np.array([field(pixels @ pose[:3, :3].T + pose[:3, 3]) for pose in POSES])
    return np.rint(frames).astype(dtype) if dtype == np.uint8 else frames.astype(dtype)


def voxel_truth(field) -> np.ndarray:
    indices = np.stack(np.meshgrid(*[np.arange(n) for n in GRID.shape], indexing="ij"), axis=-1)
    return field(GRID.to_world(indices))


def errors(field, dtype=np.float32, **settings) -> np.ndarray:
    result = reconstruct(
        cut_frames(field, dtype),
        POSES,
        PROBE.image_to_probe(),
        GRID,
        ReconstructionSettings(**settings),
    )
    assert result.observed.all()  # the dense sweep covers the whole grid
    return (result.volume - voxel_truth(field))[result.observed]


def test_constant_field_is_reproduced_exactly() -> None:
    assert np.abs(errors(lambda p: np.full(p.shape[:-1], 77.0), **NO_FILL)).max() < 1e-3


def test_linear_field_error_is_the_centroid_offset_only() -> None:
    error = errors(linear_field, **NO_FILL)
    # gradient 3.9 grey levels per mm: a 0.05 grey level error is a 13 micrometre centroid offset
    assert np.abs(error).max() < 0.05
    assert np.sqrt(np.mean(error**2)) < 0.02


@pytest.mark.parametrize(
    ("radius", "rms_limit", "max_limit"), [(1.0, 0.35, 1.0), (1.5, 0.6, 1.6), (2.0, 1.0, 2.7)]
)
def test_smooth_field_error_is_the_curvature_bias(
    radius: float, rms_limit: float, max_limit: float
) -> None:
    error = errors(smooth_field, radius=radius, **NO_FILL)
    assert np.sqrt(np.mean(error**2)) < rms_limit
    assert np.abs(error).max() < max_limit
    # bound: half the largest Hessian norm times r^2 (second-order Taylor term)
    r = radius * 0.5e-3
    hessian_bound = (
        60 * (2 * np.pi) ** 2 * (1 / 0.012**2 + 1 / 0.015**2) + 30 * (2 * np.pi / 0.010) ** 2
    )
    assert np.abs(error).max() < 0.5 * hessian_bound * r**2


def test_uint8_frames_add_only_rounding_noise() -> None:
    float_error = errors(smooth_field, **NO_FILL)
    uint8_error = errors(smooth_field, dtype=np.uint8, **NO_FILL)
    assert np.abs(uint8_error - float_error).max() < 0.5


def test_kernel_matches_plain_numpy_formula() -> None:
    frames = np.random.default_rng(3).integers(0, 256, size=(4, 96, 96), dtype=np.uint8)
    poses = POSES[::25].copy()
    poses[2, :3, :3] = Rotation.from_euler("y", 30, degrees=True).as_matrix() @ poses[2, :3, :3]
    settings = ReconstructionSettings(radius=1.7, alpha=0.3, fill_passes=0)
    result = reconstruct(frames, poses, PROBE.image_to_probe(), GRID, settings)
    value, weight = np.zeros(GRID.shape), np.zeros(GRID.shape)
    for frame, pose in zip(frames, poses, strict=True):
        sdw_accumulate_numpy(
            frame, pose, PROBE.image_to_probe(), GRID, 1.7 * 0.5e-3, 0.3 * 0.5e-3, value, weight
        )
    np.testing.assert_array_equal(result.observed, weight > 0)
    observed = weight > 0
    np.testing.assert_allclose(
        result.volume[observed], (value / np.where(observed, weight, 1))[observed], rtol=1e-5
    )
