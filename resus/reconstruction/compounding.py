"""Volume reconstruction: tracked frames (and labels) compounded onto a voxel grid.

The RESUS method is squared-distance-weighted compounding (Huang et al. 2005): every pixel
adds `W * I` and `W` to every voxel centre within radius `r`, `W = 1 / (d + alpha)^2`, `d` the
pixel-to-voxel-centre distance; the volume is their ratio and a voxel no pixel reached is a
hole. Holes are then filled in passes of growing radius from voxels that pixels filled (never
from other holes). Label images are reconstructed as one 0/1 channel per class with the same
weights and turned into a label volume by argmax (background where nothing was seen).

PLUS's pixel-based modes are here too, for comparison with its reference volumes:
nearest-neighbour and trilinear insertion with MEAN or MAXIMUM compounding.

Frames are added one at a time (`Reconstructor.add_frame`), so a volume grows live during a
scan; memory is the accumulators on the grid plus one frame. Batch reconstruction
(`reconstruct`) is the same loop, so both give identical volumes.
"""

from __future__ import annotations

import math
from collections.abc import Iterable
from dataclasses import dataclass
from itertools import product

import numpy as np
from scipy import ndimage

from resus.errors import ResusError, check_choice
from resus.reconstruction import kernels
from resus.reconstruction.grid import VolumeGrid, ensure_memory

METHODS = {"sdw": kernels.SDW, "nn": kernels.NEAREST, "linear": kernels.LINEAR}
COMPOUNDINGS = {"mean": kernels.MEAN, "max": kernels.MAXIMUM}


@dataclass(frozen=True)
class ReconstructionSettings:
    """Every knob of the reconstruction, PLUS-style, with its default.

    Lengths are in voxels: multiples of the grid's smallest voxel spacing.
    """

    method: str = "sdw"
    """Pixel insertion: "sdw" (squared-distance weighted, the paper's), "nn" (PLUS
    NEAREST_NEIGHBOR), "linear" (PLUS LINEAR, trilinear splat)."""
    compounding: str = "mean"
    """How overlapping contributions combine: "mean" (weighted mean) or "max" (PLUS MAXIMUM)."""
    radius: float = 1.5
    """SDW kernel radius r (voxels): a pixel reaches every voxel centre within it."""
    alpha: float = 0.1
    """SDW weight offset (voxels) in 1/(d + alpha)^2: keeps the weight finite at d = 0; smaller
    favours the nearest pixel, larger averages more evenly."""
    fill_passes: int = 3
    """Hole-filling passes (0: none). Pass p uses radius p * fill_radius_step."""
    fill_radius_step: float = 1.0
    """Radius growth per hole-filling pass (voxels); the last pass's radius is the limit."""
    fill_alpha: float = 0.1
    """Weight offset (voxels) of hole filling's 1/(d + alpha)^2 voxel weights."""

    def __post_init__(self) -> None:
        check_choice("ReconstructionSettings.method", self.method, METHODS)
        check_choice("ReconstructionSettings.compounding", self.compounding, COMPOUNDINGS)
        for name in ("radius", "alpha", "fill_radius_step", "fill_alpha"):
            if not (math.isfinite(getattr(self, name)) and getattr(self, name) > 0):
                raise ResusError(
                    f"ReconstructionSettings.{name} must be positive, got {getattr(self, name)}"
                )
        if self.fill_passes < 0:
            raise ResusError(
                f"ReconstructionSettings.fill_passes must be >= 0, got {self.fill_passes}"
            )


@dataclass
class ReconstructedVolume:
    """A reconstruction on its grid: intensities, labels and which voxels hold data."""

    grid: VolumeGrid
    volume: np.ndarray
    """Intensity (nx, ny, nz) float32; 0 in holes that filling did not reach."""
    observed: np.ndarray
    """Voxels that pixels reached (bool)."""
    filled: np.ndarray
    """Voxels with a value: observed or filled by hole filling (bool)."""
    labels: np.ndarray | None = None
    """Label volume (nx, ny, nz) uint8 by argmax of the class channels; 0 where unfilled."""


def cell_diagonal(grid: VolumeGrid) -> float:
    """Longest diagonal of one voxel cell (m)."""
    signs = np.array(list(product((-1.0, 1.0), repeat=3)))
    return float(np.linalg.norm(signs @ grid.axes, axis=1).max())


class Reconstructor:
    """Compounds frames onto a grid one at a time; `result()` may be called at any point."""

    def __init__(
        self,
        grid: VolumeGrid,
        image_to_probe: np.ndarray,
        settings: ReconstructionSettings | None = None,
        n_classes: int = 0,
    ) -> None:
        """`n_classes` counts label classes including background 0 (0: no labels)."""
        self.grid = grid
        self.settings = settings or ReconstructionSettings()
        self.image_to_probe = _checked_matrix(image_to_probe, "image_to_probe")
        if n_classes == 1 or n_classes < 0 or n_classes > 255:
            raise ResusError(f"n_classes must be 0 (no labels) or 2..255, got {n_classes}")
        self.n_classes = n_classes
        n_label_channels = max(n_classes - 1, 0)
        # accumulators (value, weight, labels) + result (volume, label channels) + 3 masks
        ensure_memory(grid, 4 * (2 + n_label_channels) + 4 * (1 + n_label_channels) + 3)
        self.value = np.zeros(grid.shape, dtype=np.float32)
        self.weight = np.zeros(grid.shape, dtype=np.float32)
        self.label_weight = np.zeros((n_label_channels, *grid.shape), dtype=np.float32)
        unit = float(grid.spacing.min())
        self._radius = self.settings.radius * unit
        self._alpha = self.settings.alpha * unit
        self._method = METHODS[self.settings.method]
        self._compounding = COMPOUNDINGS[self.settings.compounding]
        self._reach = grid.reach(self._radius)
        self._gram = grid.gram
        self._frame_reach = {
            kernels.SDW: self._radius,
            kernels.NEAREST: 0.5 * cell_diagonal(grid),
            kernels.LINEAR: cell_diagonal(grid),
        }[self._method]
        self._band_rows: int | None = None
        self._frame_shape: tuple[int, int] | None = None
        self.n_frames = 0

    def _bands_for(self, frame_shape: tuple[int, int]) -> int:
        """Rows per band so that same-colour bands never reach a common voxel."""
        col_step, row_step = self.image_to_probe[:3, 0], self.image_to_probe[:3, 1]
        row_gap = np.linalg.norm(np.cross(col_step, row_step)) / np.linalg.norm(col_step)
        if not row_gap > 0:
            raise ResusError("image_to_probe maps rows and columns onto one line")
        return max(1, math.floor(2.0 * self._frame_reach / row_gap))

    def add_frame(
        self, frame: np.ndarray, pose: np.ndarray, label: np.ndarray | None = None
    ) -> None:
        """Compound one frame (H, W) taken at `pose` (probe_to_base, 4x4) and its label image."""
        frame = np.asarray(frame)
        if frame.ndim != 2 or frame.dtype.kind not in "uif":
            raise ResusError(f"a frame must be a 2D numeric image, got {frame.dtype} {frame.shape}")
        if self._frame_shape is None:
            self._frame_shape = frame.shape
            self._band_rows = self._bands_for(frame.shape)
        elif frame.shape != self._frame_shape:
            raise ResusError(
                f"frame {self.n_frames} is {frame.shape}, earlier frames {self._frame_shape}"
            )
        pose = _checked_matrix(pose, f"pose of frame {self.n_frames}")
        if label is None:
            labels = np.zeros((0, 0), dtype=np.uint8)
        else:
            labels = np.ascontiguousarray(label, dtype=np.uint8)
            if labels.shape != frame.shape:
                raise ResusError(f"label image {labels.shape} does not match frame {frame.shape}")
            if self.n_classes == 0:
                raise ResusError("labels given to a Reconstructor made without n_classes")
            if labels.max(initial=0) >= self.n_classes:
                raise ResusError(
                    f"label value {labels.max()} in frame {self.n_frames} "
                    f">= n_classes {self.n_classes}"
                )
        image_to_voxel = (self.grid.world_to_voxel @ pose @ self.image_to_probe)[:3]
        kernels.insert_frame(
            np.ascontiguousarray(frame), labels, np.ascontiguousarray(image_to_voxel), self._gram,
            self._reach, self._radius**2, self._alpha, self._method, self._compounding,
            self._band_rows, self.value, self.weight, self.label_weight,
        )  # fmt: skip
        self.n_frames += 1

    def result(self, fill_holes: bool = True) -> ReconstructedVolume:
        """The volume so far: normalised, hole-filled (if asked and set), labels by argmax."""
        observed = self.weight > 0
        channels = np.zeros((1 + len(self.label_weight), *self.grid.shape), dtype=np.float32)
        if self._compounding == kernels.MEAN:
            np.divide(self.value, self.weight, out=channels[0], where=observed)
        else:
            np.copyto(channels[0], self.value, where=observed)
        for c, class_weight in enumerate(self.label_weight):
            np.divide(class_weight, self.weight, out=channels[1 + c], where=observed)
        filled = observed.copy()
        if fill_holes and self.settings.fill_passes > 0:
            filled = fill_holes_in_passes(channels, observed, self.grid, self.settings)
        labels = None
        if self.n_classes:
            labels = argmax_labels(channels[1:], filled)
        return ReconstructedVolume(self.grid, channels[0], observed, filled, labels)


def fill_holes_in_passes(
    channels: np.ndarray, observed: np.ndarray, grid: VolumeGrid, settings: ReconstructionSettings
) -> np.ndarray:
    """Fill holes of `channels` in place, pass p with radius p * step; returns the filled mask.

    Only observed voxels feed the filling, so a value never propagates from hole to hole; each
    hole takes its value from the smallest radius that reaches observed voxels.
    """
    unit = float(grid.spacing.min())
    alpha = settings.fill_alpha * unit
    max_reach = grid.reach(settings.fill_passes * settings.fill_radius_step * unit)
    window = tuple(2 * math.floor(r) + 1 for r in max_reach)
    open_holes = ndimage.maximum_filter(observed.view(np.uint8), size=window).astype(bool)
    open_holes &= ~observed
    filled = observed.copy()
    newly_filled = np.zeros(grid.shape, dtype=bool)
    for fill_pass in range(1, settings.fill_passes + 1):
        if not open_holes.any():
            break
        radius = fill_pass * settings.fill_radius_step * unit
        newly_filled[:] = False
        kernels.fill_holes_pass(
            channels, observed, open_holes, grid.gram, grid.reach(radius), radius**2, alpha,
            newly_filled,
        )  # fmt: skip
        filled |= newly_filled
        open_holes &= ~newly_filled
    return filled


def argmax_labels(class_fractions: np.ndarray, filled: np.ndarray) -> np.ndarray:
    """Label volume: the class with the largest fraction (background = 1 - the others' sum)."""
    best = 1.0 - class_fractions.sum(axis=0)
    labels = np.zeros(filled.shape, dtype=np.uint8)
    for c, fraction in enumerate(class_fractions):
        better = fraction > best
        labels[better] = c + 1
        np.maximum(best, fraction, out=best)
    labels[~filled] = 0
    return labels


def reconstruct(
    frames: Iterable[np.ndarray],
    poses: Iterable[np.ndarray],
    image_to_probe: np.ndarray,
    grid: VolumeGrid,
    settings: ReconstructionSettings | None = None,
    labels: Iterable[np.ndarray] | None = None,
    n_classes: int = 0,
    progress: bool = False,
    total: int | None = None,
) -> ReconstructedVolume:
    """Batch reconstruction of a whole sweep (the live loop run to the end)."""
    from tqdm import tqdm

    reconstructor = Reconstructor(
        grid, image_to_probe, settings, n_classes if labels is not None else 0
    )
    label_iter = iter(labels) if labels is not None else None
    for frame, pose in tqdm(
        zip(frames, poses, strict=True),
        total=total,
        disable=not progress,
        desc="reconstruct",
        unit="frame",
    ):
        reconstructor.add_frame(frame, pose, None if label_iter is None else next(label_iter))
    return reconstructor.result()


def _checked_matrix(matrix: np.ndarray, name: str) -> np.ndarray:
    """A finite 4x4 float64 matrix with bottom row (0, 0, 0, 1), or a ResusError naming it."""
    matrix = np.asarray(matrix, dtype=np.float64)
    if matrix.shape != (4, 4) or not np.isfinite(matrix).all():
        raise ResusError(f"{name} must be a finite 4x4 matrix, got shape {matrix.shape}")
    if not np.allclose(matrix[3], (0.0, 0.0, 0.0, 1.0)):
        raise ResusError(f"{name} must have bottom row (0, 0, 0, 1)")
    return matrix
