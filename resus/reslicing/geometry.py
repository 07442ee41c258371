"""Where a reslice lies: rotations of the voxel array, oblique slice planes and their poses.

The paper rotates the reconstructed voxel array with `scipy.ndimage.rotate` (reshape on, so
the output grows to hold the whole rotated array) first about its x axis, then about its y
axis, and cuts the result perpendicular to z. Both rotations together are one affine map
from output indices to input indices, `input = A @ output + b`; `rotation_affine` computes
it exactly as scipy does (same output shape, same centring), so the slice `k` of the rotated
array is the plane `{A @ (i, j, k) + b}` of the original one. The fast path samples that
plane directly, and every reslice's `plane_to_world` is built from it.

Angles follow the right-hand rule about the voxel array's index axes: the content is turned
by `R = Ry(angle_y) @ Rx(angle_x)` (about x first, then about the fixed y axis), so
`A = R.T`. In world space this is a rotation only when voxels are cubic and the grid's axes
orthogonal; `plane_to_world` always holds the true world geometry.

Images: the slice `k` becomes an image with columns along the rotated array's i and rows
along its j, so pixel `(col, row)` is output voxel `(col, row, k)`.
"""

from __future__ import annotations

from itertools import product

import numpy as np
from scipy import special

X_AXIS_PLANE = (1, 2)
"""Index axes spanning the plane of a rotation about x (scipy's `axes` argument)."""
Y_AXIS_PLANE = (0, 2)
"""Index axes spanning the plane of a rotation about y; scipy turns z toward x here, so a
right-hand rotation by +angle about y is `scipy.ndimage.rotate(..., -angle, axes=(0, 2))`."""


def scipy_rotation(
    shape: tuple[int, int, int], angle_deg: float, axes: tuple[int, int]
) -> tuple[np.ndarray, np.ndarray, tuple[int, int, int]]:
    """`(matrix, offset, output_shape)` of `scipy.ndimage.rotate(array, angle_deg, axes,
    reshape=True)` on a 3D array: output index `o` samples the input at `matrix @ o + offset`."""
    first, second = sorted(axes)
    cos, sin = special.cosdg(angle_deg), special.sindg(angle_deg)
    plane_rotation = np.array([[cos, sin], [-sin, cos]])
    in_plane_shape = np.array([shape[first], shape[second]])
    rows, cols = in_plane_shape
    bounds = plane_rotation @ np.array([[0, 0, rows, rows], [0, cols, 0, cols]])
    out_plane_shape = (np.ptp(bounds, axis=1) + 0.5).astype(int)
    plane_offset = (in_plane_shape - 1) / 2 - plane_rotation @ ((out_plane_shape - 1) / 2)
    matrix, offset = np.eye(3), np.zeros(3)
    matrix[np.ix_([first, second], [first, second])] = plane_rotation
    offset[[first, second]] = plane_offset
    out_shape = list(shape)
    out_shape[first], out_shape[second] = (int(n) for n in out_plane_shape)
    return matrix, offset, (out_shape[0], out_shape[1], out_shape[2])


def rotation_affine(
    shape: tuple[int, int, int], angle_x_deg: float, angle_y_deg: float
) -> tuple[np.ndarray, np.ndarray, tuple[int, int, int]]:
    """`(A, b, output_shape)` of the paper's two rotations: about x by `angle_x_deg`, then
    about y by `angle_y_deg` (right-hand rule); output index `o` samples input `A @ o + b`."""
    matrix_x, offset_x, shape_x = scipy_rotation(shape, angle_x_deg, X_AXIS_PLANE)
    matrix_y, offset_y, shape_y = scipy_rotation(shape_x, -angle_y_deg, Y_AXIS_PLANE)
    return matrix_x @ matrix_y, matrix_x @ offset_y + offset_x, shape_y


def content_rotation(angle_x_deg: float, angle_y_deg: float) -> np.ndarray:
    """`Ry(angle_y) @ Rx(angle_x)`: how the paper's rotations turn the array's content."""
    ax, ay = np.radians(angle_x_deg), np.radians(angle_y_deg)
    rotate_x = np.array([[1, 0, 0], [0, np.cos(ax), -np.sin(ax)], [0, np.sin(ax), np.cos(ax)]])
    rotate_y = np.array([[np.cos(ay), 0, np.sin(ay)], [0, 1, 0], [-np.sin(ay), 0, np.cos(ay)]])
    return rotate_y @ rotate_x


def slice_window(
    matrix: np.ndarray,
    offset: np.ndarray,
    in_shape: tuple[int, int, int],
    out_shape: tuple[int, int, int],
    k: int,
) -> tuple[int, int, int, int] | None:
    """Smallest `(i0, i1, j0, j1)` (half-open) of output slice `k` outside which the input
    array is never sampled: the bounding box of the plane's cut through the input's support
    `[0, n - 1]` per axis, one voxel of margin added; None where the plane misses it."""
    inverse = np.linalg.inv(matrix)
    corners = np.array(list(product(*[(0.0, n - 1.0) for n in in_shape])))
    out_corners = (corners - offset) @ inverse.T
    points = []
    for a, b in product(range(8), repeat=2):
        if a < b and bin(a ^ b).count("1") == 1:  # the 12 edges join corners one bit apart
            za, zb = out_corners[a, 2] - k, out_corners[b, 2] - k
            if za * zb <= 0 and za != zb:
                points.append(out_corners[a] + za / (za - zb) * (out_corners[b] - out_corners[a]))
            elif za == zb == 0:
                points.extend([out_corners[a], out_corners[b]])
    if not points:
        return None
    cut = np.array(points)
    i0, j0 = np.maximum(np.floor(cut[:, :2].min(axis=0)) - 1, 0).astype(int)
    i1, j1 = np.minimum(np.ceil(cut[:, :2].max(axis=0)) + 2, out_shape[:2]).astype(int)
    if i0 >= i1 or j0 >= j1:
        return None
    return int(i0), int(i1), int(j0), int(j1)


def crop_resize_to_slice(
    crop_col: int, crop_row: int, crop_width: int, crop_height: int, size: int
) -> np.ndarray:
    """3x3 affine taking a resized image's `(col, row, 1)` to the uncropped slice's pixels.

    Resizing here (OpenCV INTER_LINEAR / INTER_NEAREST_EXACT) aligns pixel centres: output
    pixel `u` samples the crop at `(u + 0.5) * crop / size - 0.5`.
    """
    scale_col, scale_row = crop_width / size, crop_height / size
    return np.array(
        [
            [scale_col, 0.0, crop_col + 0.5 * scale_col - 0.5],
            [0.0, scale_row, crop_row + 0.5 * scale_row - 0.5],
            [0.0, 0.0, 1.0],
        ]
    )


def plane_pose(origin: np.ndarray, col_step: np.ndarray, row_step: np.ndarray) -> np.ndarray:
    """4x4 `plane_to_world` mapping pixel `(col, row, 0, 1)` to a point, like `image_to_probe`.

    `origin` is pixel (0, 0) and `col_step` / `row_step` the moves of one pixel. The third
    column is the unit normal `col_step x row_step` scaled by the column spacing, so the 3x3
    block is a scaled rotation when pixels are square and the plane's axes orthogonal.
    """
    normal = np.cross(col_step, row_step)
    pose = np.eye(4)
    pose[:3, 0], pose[:3, 1], pose[:3, 3] = col_step, row_step, origin
    pose[:3, 2] = normal / np.linalg.norm(normal) * np.linalg.norm(col_step)
    return pose


def slice_plane_to_world(
    voxel_to_world: np.ndarray,
    matrix: np.ndarray,
    offset: np.ndarray,
    k: int,
    image_to_slice: np.ndarray,
) -> np.ndarray:
    """`plane_to_world` of a reslice: resized pixel -> slice pixel (`image_to_slice`, 3x3) ->
    output voxel `(col, row, k)` -> input voxel (`matrix`, `offset`) -> world metres."""
    slice_to_input = np.zeros((3, 3))
    slice_to_input[:, :2] = matrix[:, :2]
    slice_to_input[:, 2] = matrix[:, 2] * k + offset
    image_to_world = voxel_to_world[:3, :3] @ slice_to_input @ image_to_slice
    image_to_world[:, 2] += voxel_to_world[:3, 3]
    return plane_pose(image_to_world[:, 2], image_to_world[:, 0], image_to_world[:, 1])
