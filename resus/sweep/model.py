"""The Sweep: one tracked ultrasound scan, the record every pipeline stage exchanges.

A `Sweep` holds N frames with the probe pose and time of each, the image-to-probe
calibration and optional labels, wrench and joint positions. It checks itself on creation,
so code that receives one can trust it: shapes agree, poses are rigid, nothing is NaN,
time runs forward. The `check_*` functions hold those rules once; the HDF5 writer and reader
(`resus.sweep.io`) apply the same rules frame by frame and to files.
"""

from __future__ import annotations

import json
from collections.abc import Mapping
from dataclasses import dataclass, field
from datetime import datetime
from typing import NamedTuple, Protocol

import numpy as np

from resus.errors import ResusError
from resus.sweep.timestamps import now_iso
from sim.labels import LABEL_NAMES
from sim.transforms import is_rigid, rigidity_error

SOURCES: tuple[str, ...] = ("sim", "real", "plus")
PER_FRAME = ("frames", "labels", "probe_to_base", "timestamps", "wrench", "joint_positions")


class SweepError(ResusError):
    """A sweep (in memory or in a file) that breaks the `resus.sweep/1` rules."""


def check_uint8(array: np.ndarray, name: str, ndim: int) -> np.ndarray:
    """`array` as a uint8 array of `ndim` dimensions (no lossy conversion from other types)."""
    array = np.asarray(array)
    if array.dtype != np.uint8:
        raise SweepError(f"{name} must be uint8, got {array.dtype}")
    if array.ndim != ndim:
        raise SweepError(f"{name} must have {ndim} dimensions, got shape {array.shape}")
    return array


def check_finite(array: np.ndarray, name: str, shape: tuple[int | None, ...]) -> np.ndarray:
    """`array` as float64 of `shape` (None matches any length) with no NaN or infinity."""
    try:
        array = np.asarray(array, dtype=np.float64)
    except (TypeError, ValueError):
        raise SweepError(f"{name} must be numbers") from None
    if array.ndim != len(shape) or any(
        want is not None and got != want for got, want in zip(array.shape, shape, strict=True)
    ):
        wanted = "(" + ", ".join("N" if n is None else str(n) for n in shape) + ")"
        raise SweepError(f"{name} must have shape {wanted}, got {array.shape}")
    bad = np.argwhere(~np.isfinite(array))
    if len(bad):
        where = "".join(f"[{i}]" for i in bad[0])
        raise SweepError(f"{name}{where} is {array[tuple(bad[0])]} (must be finite)")
    return array


def check_poses(poses: np.ndarray, name: str = "probe_to_base", start: int = 0) -> np.ndarray:
    """(N, 4, 4) finite rigid transforms; `start` numbers the first pose in messages."""
    poses = check_finite(poses, name, (None, 4, 4))
    rigid = is_rigid(poses)
    if not rigid.all():
        index = int(np.argmin(rigid))
        error = float(rigidity_error(poses[index]))
        raise SweepError(f"{name}[{start + index}] is not a rigid transform (error {error:.1e})")
    return poses


def check_timestamps(timestamps: np.ndarray, start: int = 0, after: float = -np.inf) -> np.ndarray:
    """(N,) finite seconds, strictly increasing and later than `after`."""
    timestamps = check_finite(timestamps, "timestamps", (None,))
    previous = np.concatenate([[after], timestamps[:-1]])
    not_later = np.flatnonzero(timestamps <= previous)
    if len(not_later):
        i = int(not_later[0])
        raise SweepError(
            f"timestamps[{start + i}] = {timestamps[i]!r} s is not after the previous "
            f"frame's {previous[i]!r} s (time must increase)"
        )
    return timestamps


def check_calibration(image_to_probe: np.ndarray) -> np.ndarray:
    """A finite, invertible 4x4 image-to-probe matrix with bottom row (0, 0, 0, 1)."""
    matrix = check_finite(image_to_probe, "image_to_probe", (4, 4))
    if not np.array_equal(matrix[3], [0.0, 0.0, 0.0, 1.0]):
        raise SweepError(f"image_to_probe bottom row must be (0, 0, 0, 1), got {matrix[3]}")
    condition = np.linalg.cond(matrix[:3, :3])
    if not condition < 1e12:
        raise SweepError(f"image_to_probe is not invertible (condition number {condition:.1e})")
    return matrix


def check_labels(labels: np.ndarray, label_names: tuple[str, ...], start: int = 0) -> None:
    """Every label value names a class: less than `len(label_names)`."""
    too_big = np.flatnonzero(labels.reshape(len(labels), -1).max(axis=1) >= len(label_names))
    if len(too_big):
        i = int(too_big[0])
        raise SweepError(
            f"labels[{start + i}] holds value {int(labels[i].max())}, but there are only "
            f"{len(label_names)} label names {label_names}"
        )


def check_label_names(label_names: object) -> tuple[str, ...]:
    """A non-empty tuple of distinct, non-empty names."""
    names = tuple(
        n.decode() if isinstance(n, bytes) else str(n)
        for n in np.atleast_1d(np.asarray(label_names, dtype=object))
    )
    if not names or not all(names) or len(set(names)) != len(names):
        raise SweepError(f"label_names must be distinct non-empty names, got {names}")
    return names


def check_source(source: str) -> str:
    """One of `SOURCES`."""
    if source not in SOURCES:
        raise SweepError(f"source must be one of {', '.join(SOURCES)}, got {source!r}")
    return source


def check_created(created: str) -> str:
    """An ISO 8601 date-time string."""
    try:
        datetime.fromisoformat(str(created))
    except ValueError:
        raise SweepError(f"created must be an ISO 8601 date-time, got {created!r}") from None
    return str(created)


def check_provenance(provenance: object) -> dict:
    """A mapping with text keys that JSON can hold: what made the sweep (for a simulated one
    the phantom, subject, seed and scanner preset), so later stages rebuild the same truth."""
    if not isinstance(provenance, Mapping) or not all(isinstance(k, str) for k in provenance):
        raise SweepError("provenance must be a mapping with text keys")
    try:
        return json.loads(json.dumps(dict(provenance), allow_nan=False))
    except (TypeError, ValueError) as error:
        raise SweepError(f"provenance must hold only JSON values: {error}") from None


def pixel_spacing(image_to_probe: np.ndarray) -> tuple[float, float]:
    """(column, row) pixel size in metres: the norms of the calibration's first two columns."""
    norms = np.linalg.norm(np.asarray(image_to_probe)[:3, :2], axis=0)
    return float(norms[0]), float(norms[1])


def pixels_to_world(
    probe_to_base: np.ndarray, image_to_probe: np.ndarray, cols: np.ndarray, rows: np.ndarray
) -> np.ndarray:
    """World points (metres) of pixels `(cols, rows)` for one pose (4, 4) or a stack (N, 4, 4).

    `cols` and `rows` broadcast together to shape S; the result is S + (3,) for one pose and
    (N,) + S + (3,) for a stack.
    """
    cols, rows = np.broadcast_arrays(np.asarray(cols, float), np.asarray(rows, float))
    pixels = np.stack([cols, rows, np.zeros_like(cols), np.ones_like(cols)], axis=-1)
    image_to_base = np.asarray(probe_to_base) @ image_to_probe
    flat = pixels.reshape(-1, 4)
    world = np.einsum("...ij,pj->...pi", image_to_base[..., :3, :], flat)
    return world.reshape((*image_to_base.shape[:-2], *cols.shape, 3))


def frame_corners(frame_shape: tuple[int, int]) -> tuple[np.ndarray, np.ndarray]:
    """(cols, rows) of the four corner pixel centres, in order around the image."""
    rows, cols = frame_shape
    return np.array([0, cols - 1, cols - 1, 0]), np.array([0, 0, rows - 1, rows - 1])


class SweepFrame(NamedTuple):
    """One frame of a sweep with everything recorded with it."""

    index: int  # type: ignore[assignment]  # shadows tuple.index; `frame.index` is used everywhere
    image: np.ndarray
    probe_to_base: np.ndarray
    timestamp: float
    label: np.ndarray | None = None
    wrench: np.ndarray | None = None
    joint_positions: np.ndarray | None = None


class FrameSink(Protocol):
    """Anything that takes a scan's frames one by one, in order: the Sweep file writer, the
    live reconstruction, the rerun logger. `frame.index` counts from 0 in the scan."""

    def append(self, frame: SweepFrame) -> None: ...


@dataclass(frozen=True, eq=False)
class Sweep:
    """A tracked ultrasound scan, checked on creation (raises `SweepError`).

    Pixel `(col, row)` of frame i lies in the world (robot base, metres) at
    `probe_to_base[i] @ image_to_probe @ (col, row, 0, 1)`.
    """

    frames: np.ndarray
    """(N, H, W) uint8 B-mode images."""
    probe_to_base: np.ndarray
    """(N, 4, 4) float64 rigid probe poses in the world frame."""
    timestamps: np.ndarray
    """(N,) float64 seconds, strictly increasing."""
    image_to_probe: np.ndarray
    """(4, 4) float64 calibration, pixel size included (metres per pixel)."""
    labels: np.ndarray | None = None
    """(N, H, W) uint8 class per pixel, values index `label_names`."""
    wrench: np.ndarray | None = None
    """(N, 6) float64 TCP force (N) and torque (N m)."""
    joint_positions: np.ndarray | None = None
    """(N, 6) float64 robot joint angles (rad)."""
    label_names: tuple[str, ...] = LABEL_NAMES
    source: str = "sim"
    """Where it came from: 'sim', 'real' or 'plus'."""
    subject: str = ""
    """Who or what was scanned (leave-one-subject-out evaluation groups by it)."""
    created: str = field(default_factory=now_iso)
    """When the scan was recorded, ISO 8601."""
    provenance: Mapping[str, object] = field(default_factory=dict)
    """What made it (JSON values): for a simulated sweep `phantom`, `subject`, `seed`,
    `scanner` and its `dynamic_range_db`, the `pattern` and `contact_force`, and
    `deformation` (whether the tissue deformed under the probe); empty when unknown."""

    def __post_init__(self) -> None:
        frames = check_uint8(self.frames, "frames", 3)
        n = len(frames)
        if n == 0:
            raise SweepError("a sweep needs at least one frame")
        label_names = check_label_names(self.label_names)
        checked: dict[str, np.ndarray | tuple[str, ...] | str | dict] = {
            "frames": frames,
            "probe_to_base": check_poses(self.probe_to_base),
            "timestamps": check_timestamps(self.timestamps),
            "image_to_probe": check_calibration(self.image_to_probe),
            "label_names": label_names,
            "source": check_source(self.source),
            "subject": str(self.subject),
            "created": check_created(self.created),
            "provenance": check_provenance(self.provenance),
        }
        if self.labels is not None:
            labels = check_uint8(self.labels, "labels", 3)
            if labels.shape != frames.shape:
                raise SweepError(f"labels shape {labels.shape} != frames shape {frames.shape}")
            check_labels(labels, label_names)
            checked["labels"] = labels
        for name in ("wrench", "joint_positions"):
            if getattr(self, name) is not None:
                checked[name] = check_finite(getattr(self, name), name, (None, 6))
        for name, array in checked.items():
            if name in PER_FRAME and len(array) != n:
                raise SweepError(f"{name} has {len(array)} rows but there are {n} frames")
            object.__setattr__(self, name, array)

    def __len__(self) -> int:
        return len(self.frames)

    @property
    def frame_shape(self) -> tuple[int, int]:
        """(rows, cols) of every frame."""
        return self.frames.shape[1], self.frames.shape[2]

    @property
    def pixel_spacing(self) -> tuple[float, float]:
        """(column, row) pixel size in metres."""
        return pixel_spacing(self.image_to_probe)

    @property
    def axial_force(self) -> np.ndarray | None:
        """(N,) force (N) the probe pressed along its own axis (into the tissue) in each
        frame, from the wrench; None for a sweep without one."""
        if self.wrench is None:
            return None
        return np.einsum("ni,ni->n", self.wrench[:, :3], self.probe_to_base[:, :3, 2])

    def frame(self, index: int) -> SweepFrame:
        """Frame `index` with its pose, time and optional data."""

        def row(array: np.ndarray | None) -> np.ndarray | None:
            return None if array is None else array[index]

        return SweepFrame(
            index,
            self.frames[index],
            self.probe_to_base[index],
            float(self.timestamps[index]),
            row(self.labels),
            row(self.wrench),
            row(self.joint_positions),
        )

    def pixel_to_world(self, index: int, cols: np.ndarray, rows: np.ndarray) -> np.ndarray:
        """World points (metres), shape S + (3,), of pixels `(cols, rows)` of frame `index`."""
        return pixels_to_world(self.probe_to_base[index], self.image_to_probe, cols, rows)

    def frame_corners_world(self) -> np.ndarray:
        """(N, 4, 3) world points of each frame's four corner pixel centres."""
        return pixels_to_world(
            self.probe_to_base, self.image_to_probe, *frame_corners(self.frame_shape)
        )
