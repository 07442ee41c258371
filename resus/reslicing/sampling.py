"""Sampling a volume on a plane: cubic B-spline intensities and nearest-neighbour labels.

`SampledVolume` prefilters the intensity volume once (cubic B-spline coefficients, as
`scipy.ndimage` computes them) and then samples any plane of pixels with a numba kernel that
reproduces `scipy.ndimage.map_coordinates(order=3, mode="constant")` (taps mirrored at the
edges, zero outside `[0, n - 1]` per axis) and, for labels, `order=0` (nearest voxel, so
classes stay exact). Sampling only the pixels of a plane instead of resampling a whole
rotated volume is what makes the fast reslicing path fast.
"""

from __future__ import annotations

import numba
import numpy as np
from scipy import ndimage

EDGE_TOLERANCE = 1e-6
"""Points this close outside the volume (voxels) count as on its edge, so that rounding in a
plane's arithmetic never drops a row of edge voxels."""


@numba.njit(cache=True, inline="always")
def _mirror(index: int, n: int) -> int:
    """Tap index reflected about the edge samples (scipy's "mirror")."""
    if 0 <= index < n:
        return index
    if n == 1:
        return 0
    period = 2 * (n - 1)
    index = abs(index) % period
    return period - index if index > n - 1 else index


@numba.njit(cache=True, inline="always")
def _cubic_weights(t: float) -> tuple[float, float, float, float]:
    """Cubic B-spline weights of the four taps around a point `t` in [0, 1) past a sample."""
    s = 1.0 - t
    t2 = t * t
    t3 = t2 * t
    return (
        s * s * s / 6.0,
        (3.0 * t3 - 6.0 * t2 + 4.0) / 6.0,
        (-3.0 * t3 + 3.0 * t2 + 3.0 * t + 1.0) / 6.0,
        t3 / 6.0,
    )


@numba.njit(cache=True, inline="always")
def _taps(first: int, n: int) -> tuple[int, int, int, int]:
    """The four tap indices from `first`, mirrored into `[0, n - 1]`."""
    return _mirror(first, n), _mirror(first + 1, n), _mirror(first + 2, n), _mirror(first + 3, n)


@numba.njit(cache=True)
def _sample_plane(
    coefficients: np.ndarray,
    labels: np.ndarray,
    origin: np.ndarray,
    col_step: np.ndarray,
    row_step: np.ndarray,
    image: np.ndarray,
    label_image: np.ndarray,
) -> None:
    """Fill `image` (rows, cols) and, when `labels` is not empty, `label_image` with the volume
    at voxel positions `origin + col * col_step + row * row_step`; `coefficients` and
    `labels` are stored [z, y, x]."""
    nz, ny, nx = coefficients.shape
    with_labels = labels.size > 0
    rows, cols = image.shape
    for row in range(rows):
        for col in range(cols):
            x = origin[0] + col * col_step[0] + row * row_step[0]
            y = origin[1] + col * col_step[1] + row * row_step[1]
            z = origin[2] + col * col_step[2] + row * row_step[2]
            if not (
                -EDGE_TOLERANCE <= x <= nx - 1 + EDGE_TOLERANCE
                and -EDGE_TOLERANCE <= y <= ny - 1 + EDGE_TOLERANCE
                and -EDGE_TOLERANCE <= z <= nz - 1 + EDGE_TOLERANCE
            ):
                image[row, col] = 0.0
                if with_labels:
                    label_image[row, col] = 0
                continue
            fx, fy, fz = int(x), int(y), int(z)  # floor, as coordinates are > -1 here
            wx0, wx1, wx2, wx3 = _cubic_weights(x - fx)
            wy = _cubic_weights(y - fy)
            wz = _cubic_weights(z - fz)
            x0, x1, x2, x3 = _taps(fx - 1, nx)
            ty = _taps(fy - 1, ny)
            tz = _taps(fz - 1, nz)
            total = 0.0
            for c in range(4):
                plane_sum = 0.0
                for b in range(4):
                    line = coefficients[tz[c], ty[b]]
                    plane_sum += wy[b] * (
                        wx0 * line[x0] + wx1 * line[x1] + wx2 * line[x2] + wx3 * line[x3]
                    )
                total += wz[c] * plane_sum
            image[row, col] = total
            if with_labels:
                label_image[row, col] = labels[int(z + 0.5), int(y + 0.5), int(x + 0.5)]


class SampledVolume:
    """An intensity volume (and optional label volume) ready to be sampled on planes."""

    def __init__(self, volume: np.ndarray, labels: np.ndarray | None = None) -> None:
        """Prefilter `volume` (nx, ny, nz) once; `labels` must have the same shape."""
        if volume.ndim != 3:
            raise ValueError(f"volume must be 3D, got shape {volume.shape}")
        if labels is not None and labels.shape != volume.shape:
            raise ValueError(f"labels shape {labels.shape} differs from volume {volume.shape}")
        self.shape: tuple[int, int, int] = volume.shape
        # stored [z, y, x] (x fastest in memory): slice planes run mostly along x and y, so
        # neighbouring pixels then share cache lines
        self.coefficients = ndimage.spline_filter(
            np.asarray(volume, dtype=np.float32).T, order=3, output=np.float32, mode="mirror"
        )
        self.labels = (
            np.zeros((0, 0, 0), np.uint8)
            if labels is None
            else np.ascontiguousarray(np.asarray(labels, dtype=np.uint8).T)
        )

    @property
    def has_labels(self) -> bool:
        """Whether a label volume was given."""
        return self.labels.size > 0

    def sample(
        self,
        origin: np.ndarray,
        col_step: np.ndarray,
        row_step: np.ndarray,
        rows: int,
        cols: int,
    ) -> tuple[np.ndarray, np.ndarray | None]:
        """Intensity (rows, cols) float32 and labels (uint8, or None) at voxel positions
        `origin + col * col_step + row * row_step`; zero outside the volume."""
        image = np.empty((rows, cols), dtype=np.float32)
        label_image = np.empty((rows, cols) if self.has_labels else (0, 0), dtype=np.uint8)
        _sample_plane(
            self.coefficients,
            self.labels,
            np.asarray(origin, dtype=np.float64),
            np.asarray(col_step, dtype=np.float64),
            np.asarray(row_step, dtype=np.float64),
            image,
            label_image,
        )
        return image, label_image if self.has_labels else None
