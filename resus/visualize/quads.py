"""Images as textured quads in 3D: a frame, a reslice or a volume slice at its true place and size.

A quad spans the image's pixel EDGES, from pixel (-0.5, -0.5) to (W - 0.5, H - 0.5), so that
each texel of the texture sits exactly on its pixel centre `image_to_world @ (col, row, 0, 1)`.
Texture coordinates follow rerun's convention: (0, 0) is the image's top-left corner.
"""

from __future__ import annotations

import numpy as np
import rerun as rr

from resus.sweep.model import pixels_to_world
from sim.labels import tint_labels

QUAD_TEXCOORDS = np.array([[0.0, 0.0], [1.0, 0.0], [1.0, 1.0], [0.0, 1.0]])
QUAD_TRIANGLES = np.array([[0, 1, 2], [0, 2, 3]], dtype=np.uint32)
LABEL_TINT = 0.4
"""Opacity of label colours painted over a quad's grey levels."""


def quad_corners(image_to_world: np.ndarray, shape: tuple[int, int]) -> np.ndarray:
    """World corners (4, 3) of an image of `shape` (rows, cols) whose pixel `(col, row, 0, 1)`
    maps to `image_to_world @ (col, row, 0, 1)`: top-left, top-right, bottom-right,
    bottom-left pixel edges. A stack of matrices (N, 4, 4) gives (N, 4, 3)."""
    rows, cols = shape
    edge_cols = np.array([-0.5, cols - 0.5, cols - 0.5, -0.5])
    edge_rows = np.array([-0.5, -0.5, rows - 0.5, rows - 0.5])
    return pixels_to_world(image_to_world, np.eye(4), edge_cols, edge_rows)


def tinted_texture(image: np.ndarray, label: np.ndarray | None = None) -> np.ndarray:
    """(H, W, 3) uint8 RGB of a grey image, label colours blended in where label > 0.

    rerun's mesh textures must be RGB(A), so grey levels are repeated over three channels.
    """
    return tint_labels(image, label, LABEL_TINT)


def textured_quad(
    image_to_world: np.ndarray, image: np.ndarray, label: np.ndarray | None = None
) -> rr.Mesh3D:
    """A `Mesh3D` of two triangles showing `image` (and its labels) where it lies in 3D."""
    return rr.Mesh3D(
        vertex_positions=quad_corners(image_to_world, image.shape[:2]),
        triangle_indices=QUAD_TRIANGLES,
        vertex_texcoords=QUAD_TEXCOORDS,
        albedo_texture=tinted_texture(image, label),
    )
