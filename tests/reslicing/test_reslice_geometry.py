"""Reslice geometry: scipy's rotation reproduced, a cylinder's ellipse, poses back to voxels."""

from __future__ import annotations

from itertools import product

import numpy as np
import pytest
from reslice_volumes import cylinder_volume, grid_for, index_points
from scipy import ndimage

from resus.reconstruction.grid import VolumeGrid
from resus.reslicing.geometry import (
    X_AXIS_PLANE,
    Y_AXIS_PLANE,
    content_rotation,
    rotation_affine,
    scipy_rotation,
    slice_window,
)
from resus.reslicing.reslice import ResliceSettings, reslice_volume


@pytest.mark.parametrize(
    ("shape", "angle", "axes"),
    [
        ((9, 14, 11), 23.0, X_AXIS_PLANE),
        ((12, 7, 10), -30.0, Y_AXIS_PLANE),
        ((6, 8, 9), 10.0, (0, 1)),
    ],
)
def test_scipy_rotation_reproduces_ndimage_rotate(shape, angle, axes):
    volume = np.random.default_rng(3).random(shape)
    matrix, offset, out_shape = scipy_rotation(shape, angle, axes)
    rotated = ndimage.rotate(volume, angle, axes=axes, order=1)
    # a trilinear 3D transform that never mixes in the third axis is scipy's per-plane bilinear one
    mapped = ndimage.affine_transform(volume, matrix, offset, output_shape=out_shape, order=1)
    assert rotated.shape == out_shape
    np.testing.assert_allclose(mapped, rotated, atol=1e-12)


def test_two_rotations_turn_content_by_ry_rx():
    matrix, _, _ = rotation_affine((20, 30, 40), 20.0, -10.0)
    np.testing.assert_allclose(matrix, content_rotation(20.0, -10.0).T, atol=1e-12)
    # a right-hand turn about x by +90 degrees takes y to z
    np.testing.assert_allclose(content_rotation(90.0, 0.0) @ [0, 1, 0], [0, 0, 1], atol=1e-12)


@pytest.mark.parametrize(("angle_x", "angle_y"), [(30.0, 30.0), (-20.0, 10.0), (0.0, 0.0)])
def test_slice_window_holds_every_sample_inside_the_volume(angle_x, angle_y):
    shape = (15, 18, 21)
    matrix, offset, out_shape = rotation_affine(shape, angle_x, angle_y)
    i, j = np.mgrid[0 : out_shape[0], 0 : out_shape[1]]
    for k in range(out_shape[2]):
        points = np.stack([i, j, np.full_like(i, k)], axis=-1) @ matrix.T + offset
        inside = np.all((points >= 0) & (points <= np.array(shape) - 1), axis=-1)
        window = slice_window(matrix, offset, shape, out_shape, k)
        if not inside.any():
            continue
        i0, i1, j0, j1 = window
        rows, cols = np.nonzero(inside)
        assert i0 <= rows.min() and rows.max() < i1 and j0 <= cols.min() and cols.max() < j1


def _in_plane_ellipse(reslice, label: int = 1) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """(semi-axes (2,), major direction (3,), centre (3,)) in world metres of a label's pixels,
    from the second moments of a filled ellipse (variance = semi-axis^2 / 4)."""
    rows, cols = np.nonzero(reslice.label == label)
    pixels = np.stack([cols, rows, np.zeros_like(cols), np.ones_like(cols)], axis=-1)
    world = (pixels @ reslice.plane_to_world.T)[:, :3]
    centre = world.mean(axis=0)
    eigenvalues, eigenvectors = np.linalg.eigh(np.cov((world - centre).T))
    return 2 * np.sqrt(eigenvalues[1:][::-1]), eigenvectors[:, 2], centre


@pytest.mark.parametrize("method", ["fast", "rotate"])
def test_tilted_cylinder_cuts_the_predicted_ellipse(method):
    shape, radius, spacing = (64, 64, 64), 10.0, 0.5e-3
    volume, labels, axis = cylinder_volume(shape, [0.3, -0.5, 1.0], radius)
    grid = grid_for(shape, spacing)
    settings = ResliceSettings(angles_deg=(20.0, -10.0), step=4, method=method)
    reslices = [
        r for r in reslice_volume(volume, labels, grid, settings) if r.angles_deg == (20.0, -10.0)
    ]
    assert reslices, "slices through a full volume must be kept"
    centre_world = grid.to_world((np.array(shape) - 1) / 2)
    closest = min(reslices, key=lambda r: abs(_signed_distance(r.plane_to_world, centre_world)))
    assert abs(_signed_distance(closest.plane_to_world, centre_world)) <= 2 * spacing

    rotation = grid.directions.T  # index directions to world, the grid being orthonormal here
    normal_world = rotation @ content_rotation(*closest.angles_deg).T @ [0.0, 0.0, 1.0]
    pose_normal = closest.plane_to_world[:3, 2] / np.linalg.norm(closest.plane_to_world[:3, 2])
    assert abs(pose_normal @ normal_world) > 1 - 1e-9
    axis_world = rotation @ axis
    cos_tilt = abs(normal_world @ axis_world)
    predicted = np.array([radius / cos_tilt, radius]) * spacing
    semi_axes, major, _ = _in_plane_ellipse(closest)
    np.testing.assert_allclose(semi_axes, predicted, atol=1.0 * spacing)
    along = axis_world - (axis_world @ normal_world) * normal_world
    assert abs(major @ along / np.linalg.norm(along)) > np.cos(np.radians(3))


def _signed_distance(plane_to_world: np.ndarray, point: np.ndarray) -> float:
    normal = plane_to_world[:3, 2] / np.linalg.norm(plane_to_world[:3, 2])
    return float((point - plane_to_world[:3, 3]) @ normal)


@pytest.mark.parametrize("method", ["fast", "rotate"])
def test_plane_poses_map_pixels_back_onto_their_voxels(method):
    """A linear ramp is reproduced exactly by cubic splines and bilinear resizing, so every
    interior pixel must equal the ramp at the voxel its pose points to; labels likewise."""
    shape = (30, 36, 40)
    axes = np.array([[0.4e-3, 0.05e-3, 0.0], [0.0, 0.3e-3, 0.1e-3], [0.02e-3, 0.0, 0.5e-3]])
    grid = VolumeGrid(origin=np.array([0.01, 0.02, -0.03]), axes=axes, shape=shape)
    gradient = np.array([2.0, 1.5, 1.0])
    volume = (20 + index_points(shape) @ gradient).astype(np.float32)
    labels = ((index_points(shape) - [15, 18, 20]) ** 2 @ [1, 1, 0] < 64).astype(np.uint8)
    settings = ResliceSettings(angles_deg=(-20.0, 10.0), step=7, size=64, method=method)
    checked = 0
    for reslice in reslice_volume(volume, labels, grid, settings):
        rows, cols = np.mgrid[0:64, 0:64]
        pixels = np.stack([cols, rows, 0 * cols, 1 + 0 * cols], axis=-1).astype(float)
        voxels = grid.to_voxel((pixels @ reslice.plane_to_world.T)[..., :3])
        margin = 3.0  # voxels: away from the volume's edges and the crop's border
        interior = np.all((voxels > margin) & (voxels < np.array(shape) - 1 - margin), axis=-1)
        error = np.abs(reslice.image[interior] - (20 + voxels[interior] @ gradient))
        assert error.max() <= 1.5 and error.mean() <= 0.5  # two roundings: slice, then resize
        # nearest voxel of the nearest slice pixel: a voxel next to the pixel's own position
        base = np.floor(voxels[interior]).astype(int)
        found = np.zeros(len(base), dtype=bool)
        for step in product(range(-1, 3), repeat=3):
            near = np.clip(base + step, 0, np.array(shape) - 1)
            found |= labels[near[:, 0], near[:, 1], near[:, 2]] == reslice.label[interior]
        assert found.all()
        nearest = np.rint(voxels[interior]).astype(int)
        direct = labels[nearest[:, 0], nearest[:, 1], nearest[:, 2]]
        assert (reslice.label[interior] == direct).mean() > 0.95
        checked += 1
    assert checked > 5
