"""Reslicing (pipeline stage 3): views the probe cannot take, cut from a reconstructed volume.

The paper's procedure, for every combination of an angle about x and an angle about y
(default -30..30 degrees in 10 degree steps): rotate the volume (the output grows to hold it
all, zeros outside), cut slices perpendicular to z (every `step` voxels), keep a slice when
at least `min_nonzero` of its pixels are non-zero, crop its zero border, resize it to
`size` x `size`. Image and labels go through the same steps.

Two ways to get the same slices (`ResliceSettings.method`):

- "rotate", the faithful path: `scipy.ndimage.rotate` the whole volume twice (cubic spline,
  order 3, for intensities; nearest neighbour, order 0, for labels), then slice the arrays.
- "fast": sample each slice's plane of the original volume directly (one cubic B-spline
  prefilter of the volume, then `plane_sampling` on the part of each plane that meets the
  volume). The planes are the rotated arrays' slices exactly (`reslice_geometry`); the
  images differ only because the faithful path interpolates twice (once per rotation).

Labels use nearest neighbour, not per-class channels and argmax: classes stay exact, no
pixel gets a class that no voxel has, a label pixel is the label of a real voxel of the
volume, and one tap costs far less than interpolating one channel per class.

Grey levels are rounded and clipped to uint8 before the non-zero test, so "non-zero" means a
visible grey level, as in the saved images.
"""

from __future__ import annotations

from collections.abc import Iterator
from dataclasses import asdict, dataclass
from itertools import product
from pathlib import Path

import cv2
import numpy as np
from scipy import ndimage

from resus.errors import ResusError, check_choice
from resus.reconstruction.grid import VolumeGrid
from resus.reconstruction.io import intensity_to_uint8
from resus.reslicing.geometry import (
    X_AXIS_PLANE,
    Y_AXIS_PLANE,
    crop_resize_to_slice,
    rotation_affine,
    slice_plane_to_world,
    slice_window,
)
from resus.reslicing.sampling import SampledVolume

METHODS = ("fast", "rotate")
DEFAULT_ANGLES_DEG = (-30.0, -20.0, -10.0, 0.0, 10.0, 20.0, 30.0)
INTENSITY_ORDER = 3
"""Spline order for intensities (both paths): cubic, as scipy.ndimage.rotate's default."""
LABEL_ORDER = 0
"""Labels: nearest neighbour (both paths)."""


@dataclass(frozen=True)
class ResliceSettings:
    """Every knob of the paper's reslicing, with the paper's defaults."""

    angles_deg: tuple[float, ...] = DEFAULT_ANGLES_DEG
    """Rotation angles (degrees), used about x and about y; every (x, y) pair is resliced."""
    step: int = 5
    """Distance between kept slices along the rotated volume's z (voxels)."""
    min_nonzero: float = 0.4
    """Smallest fraction of non-zero pixels for a slice to be kept (0..1)."""
    size: int = 256
    """Side of the square output images (pixels)."""
    method: str = "fast"
    """"fast" (sample each plane) or "rotate" (rotate the whole volume, the paper's way)."""

    def __post_init__(self) -> None:
        object.__setattr__(self, "angles_deg", tuple(float(a) for a in self.angles_deg))
        if not self.angles_deg or not all(np.isfinite(self.angles_deg)):
            raise ResusError(
                f"ResliceSettings.angles_deg must be finite degrees, got {self.angles_deg}"
            )
        if self.step < 1:
            raise ResusError(f"ResliceSettings.step must be at least 1 voxel, got {self.step}")
        if not 0.0 <= self.min_nonzero <= 1.0:
            raise ResusError(
                f"ResliceSettings.min_nonzero must be a fraction in 0..1, got {self.min_nonzero}"
            )
        if self.size < 2:
            raise ResusError(f"ResliceSettings.size must be at least 2 pixels, got {self.size}")
        check_choice("ResliceSettings.method", self.method, METHODS)

    def angle_pairs(self) -> list[tuple[float, float]]:
        """Every (angle about x, angle about y) combination, in degrees."""
        return list(product(self.angles_deg, self.angles_deg))

    def as_attrs(self) -> dict[str, object]:
        """The settings as flat values for file attributes."""
        attrs = asdict(self)
        attrs["angles_deg"] = np.array(self.angles_deg)
        attrs["intensity_order"] = INTENSITY_ORDER
        attrs["label_order"] = LABEL_ORDER
        return attrs


@dataclass(frozen=True)
class Reslice:
    """One kept slice: images plus where it came from."""

    image: np.ndarray
    """(size, size) uint8 grey levels."""
    label: np.ndarray
    """(size, size) uint8 classes."""
    angles_deg: tuple[float, float]
    """Rotation about x, then about y (degrees)."""
    slice_index: int
    """z index of the slice in the rotated volume."""
    plane_to_world: np.ndarray
    """4x4: pixel `(col, row, 0, 1)` to world metres, pixel spacing included."""


def finish_slice(
    grey: np.ndarray,
    label: np.ndarray,
    col_offset: int,
    row_offset: int,
    full_area: int,
    settings: ResliceSettings,
) -> tuple[np.ndarray, np.ndarray, np.ndarray] | None:
    """Select, crop and resize one slice (or the window of it holding every non-zero pixel,
    which starts at `col_offset`, `row_offset` of a slice of `full_area` pixels).

    Returns `(image, label, image_to_slice)` or None when too few pixels are non-zero;
    `image_to_slice` (3x3) takes an output pixel `(col, row, 1)` to the whole slice's pixels.
    """
    nonzero = grey > 0
    count = int(np.count_nonzero(nonzero))
    if count == 0 or count < settings.min_nonzero * full_area:
        return None
    rows = np.flatnonzero(nonzero.any(axis=1))
    cols = np.flatnonzero(nonzero.any(axis=0))
    r0, r1, c0, c1 = rows[0], rows[-1] + 1, cols[0], cols[-1] + 1
    shape = (settings.size, settings.size)
    image = cv2.resize(grey[r0:r1, c0:c1], shape, interpolation=cv2.INTER_LINEAR)
    label = cv2.resize(label[r0:r1, c0:c1], shape, interpolation=cv2.INTER_NEAREST_EXACT)
    image_to_slice = crop_resize_to_slice(
        col_offset + c0, row_offset + r0, c1 - c0, r1 - r0, settings.size
    )
    return image, label, image_to_slice


SliceWindows = Iterator[tuple[int, np.ndarray, np.ndarray, int, int]]
"""(k, grey, label, col_offset, row_offset) for each candidate slice of one angle pair."""


def slices_by_rotating(
    volume: np.ndarray, labels: np.ndarray, angle_x_deg: float, angle_y_deg: float, step: int
) -> SliceWindows:
    """The faithful path: rotate the whole volume and labels, then cut every `step`-th slice."""
    rotated = ndimage.rotate(volume, angle_x_deg, axes=X_AXIS_PLANE, order=INTENSITY_ORDER)
    rotated = ndimage.rotate(rotated, -angle_y_deg, axes=Y_AXIS_PLANE, order=INTENSITY_ORDER)
    rotated_labels = ndimage.rotate(labels, angle_x_deg, axes=X_AXIS_PLANE, order=LABEL_ORDER)
    rotated_labels = ndimage.rotate(
        rotated_labels, -angle_y_deg, axes=Y_AXIS_PLANE, order=LABEL_ORDER
    )
    for k in range(0, rotated.shape[2], step):
        grey = intensity_to_uint8(rotated[:, :, k].T)
        yield k, grey, np.ascontiguousarray(rotated_labels[:, :, k].T), 0, 0


def slices_by_sampling(
    sampled: SampledVolume,
    angle_x_deg: float,
    angle_y_deg: float,
    step: int,
    min_nonzero: float,
) -> SliceWindows:
    """The fast path: sample only the window of each slice's plane that meets the volume,
    skipping slices whose window is too small to be kept."""
    matrix, offset, out_shape = rotation_affine(sampled.shape, angle_x_deg, angle_y_deg)
    full_area = out_shape[0] * out_shape[1]
    for k in range(0, out_shape[2], step):
        window = slice_window(matrix, offset, sampled.shape, out_shape, k)
        if window is None:
            continue
        i0, i1, j0, j1 = window
        if (i1 - i0) * (j1 - j0) < min_nonzero * full_area:
            continue
        origin = matrix @ np.array([i0, j0, k], dtype=float) + offset
        image, label = sampled.sample(origin, matrix[:, 0], matrix[:, 1], j1 - j0, i1 - i0)
        if label is None:
            raise ValueError("slices_by_sampling needs a SampledVolume built with labels")
        yield k, intensity_to_uint8(image), label, i0, j0


def check_volume(
    volume: np.ndarray,
    labels: np.ndarray,
    grid: VolumeGrid,
    volume_path: str | Path | None = None,
    labels_path: str | Path | None = None,
) -> None:
    """ResusError (naming the file when given) unless volume and labels are 3D arrays on
    `grid` with finite intensities and integer classes 0..255."""
    if volume.ndim != 3 or volume.shape != grid.shape:
        raise ResusError(
            f"volume shape {volume.shape} does not match its grid {grid.shape}", volume_path
        )
    if not np.issubdtype(volume.dtype, np.number) or not np.isfinite(volume).all():
        raise ResusError("volume intensities must be finite numbers", volume_path)
    if labels.shape != volume.shape:
        raise ResusError(
            f"labels shape {labels.shape} differs from volume shape {volume.shape}", labels_path
        )
    if not np.issubdtype(labels.dtype, np.integer) or labels.min() < 0 or labels.max() > 255:
        raise ResusError("labels must be integer classes in 0..255", labels_path)


def reslice_volume(
    volume: np.ndarray,
    labels: np.ndarray,
    grid: VolumeGrid,
    settings: ResliceSettings | None = None,
    progress: bool = False,
) -> Iterator[Reslice]:
    """Every kept reslice of `volume` (grey levels 0..255, (nx, ny, nz) on `grid`) and its
    `labels`, angle pair after angle pair (a tqdm bar over the pairs when `progress`)."""
    from tqdm import tqdm

    settings = settings or ResliceSettings()
    check_volume(volume, labels, grid)
    labels = labels.astype(np.uint8, copy=False)
    if settings.method == "fast":
        sampled = SampledVolume(volume, labels)
    else:
        volume = np.asarray(volume, dtype=np.float32)
    pairs = settings.angle_pairs()
    for angle_x, angle_y in tqdm(pairs, disable=not progress, desc="reslice", unit="angle pair"):
        matrix, offset, out_shape = rotation_affine(volume.shape, angle_x, angle_y)
        if settings.method == "fast":
            windows = slices_by_sampling(
                sampled, angle_x, angle_y, settings.step, settings.min_nonzero
            )
        else:
            windows = slices_by_rotating(volume, labels, angle_x, angle_y, settings.step)
        for k, grey, label, col_offset, row_offset in windows:
            finished = finish_slice(
                grey, label, col_offset, row_offset, out_shape[0] * out_shape[1], settings
            )
            if finished is None:
                continue
            image, label_image, image_to_slice = finished
            yield Reslice(
                image=image,
                label=label_image,
                angles_deg=(angle_x, angle_y),
                slice_index=k,
                plane_to_world=slice_plane_to_world(
                    grid.voxel_to_world, matrix, offset, k, image_to_slice
                ),
            )
