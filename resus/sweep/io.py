"""The Sweep file (`resus.sweep/1`, HDF5): written frame by frame, read lazily, checked.

Crash safety. The writer uses HDF5's single-writer/multiple-reader mode (SWMR, file format
`libver="latest"`), in which the library orders its metadata writes so that the file on disk
is consistent after every flush, and a reader can open it while the writer is still running
or after it was killed. Each `append` writes the frame's rows of every dataset, flushes,
then writes its timestamp (the dataset's fill value is NaN) and flushes again: a finite
timestamp is the commit mark of a frame. A writer killed at any instant leaves a file whose
every committed frame reads back intact; at most one half-written row (present in some
datasets, or with a NaN timestamp) trails the committed ones, and the reader ignores it.
"""

from __future__ import annotations

import json
import os
import re
import struct
from collections.abc import Iterator, Mapping, Sequence
from contextlib import AbstractContextManager, contextmanager
from pathlib import Path
from typing import Any

import h5py
import numpy as np

from resus.sweep.model import (
    Sweep,
    SweepError,
    SweepFrame,
    check_calibration,
    check_created,
    check_finite,
    check_label_names,
    check_labels,
    check_poses,
    check_provenance,
    check_source,
    check_timestamps,
    check_uint8,
)
from resus.sweep.timestamps import now_iso
from sim.labels import LABEL_NAMES

SCHEMA = "resus.sweep/1"
IMAGE_DATASETS = ("frames", "labels")
VECTOR_DATASETS = ("wrench", "joint_positions")
LABEL_COMPRESSION = {"compression": "gzip", "compression_opts": 4}
"""Label images are mostly background and shrink about 60-fold. B-mode frames are stored as
they are: speckle gains only about 16 % from gzip, which costs 1.5 ms per 256 x 256 frame."""
HDF5_SIGNATURE = b"\x89HDF\r\n\x1a\n"


def error_summary(error: BaseException) -> str:
    """The one informative line of a library error (h5py, SimpleITK/ITK, OS)."""
    lines = [line.strip() for line in str(error).splitlines() if line.strip()]
    lines = [line for line in lines if not line.startswith("Exception thrown in")]
    if not lines:
        return type(error).__name__
    line = lines[0]
    if "ERROR: " in line:  # "ITK ERROR: MetaImageIO(0x5562): why" or "sitk::ERROR: why"
        line = line.split("ERROR: ", 1)[1]
        line = re.sub(r"^\w+\(0x[0-9a-f]+\): ", "", line)
    return line


@contextmanager
def file_errors(path: Path, action: str) -> Iterator[None]:
    """Turn problems inside the block into one-line `SweepError`s that name `path`."""
    try:
        yield
    except SweepError as error:
        if error.path is not None:
            raise
        raise SweepError(str(error), path) from None
    except (OSError, RuntimeError, KeyError, ValueError, TypeError) as error:
        raise SweepError(f"{action} failed ({error_summary(error)})", path) from None


class SweepWriter(AbstractContextManager):
    """Write a sweep to `path` one frame at a time; every appended frame survives a crash.

    Use as a context manager. `frame_shape` is (rows, cols); the `with_*` flags say which
    optional datasets the file has, and `append` then requires (or refuses) those arguments.
    """

    def __init__(
        self,
        path: str | Path,
        frame_shape: tuple[int, int],
        image_to_probe: np.ndarray,
        *,
        with_labels: bool = False,
        with_wrench: bool = False,
        with_joints: bool = False,
        source: str = "sim",
        subject: str = "",
        label_names: Sequence[str] = LABEL_NAMES,
        created: str | None = None,
        provenance: Mapping[str, object] | None = None,
    ) -> None:
        self.path = Path(path)
        with file_errors(self.path, "creating the sweep file"):
            rows, cols = (int(n) for n in frame_shape)
            if rows < 1 or cols < 1:
                raise SweepError(f"frame shape must be positive, got {tuple(frame_shape)}")
            self.frame_shape = (rows, cols)
            self.label_names = check_label_names(label_names)
            attributes = {
                "schema": SCHEMA,
                "image_to_probe": check_calibration(image_to_probe),
                "label_names": list(self.label_names),
                "source": check_source(source),
                "subject": str(subject),
                "created": check_created(now_iso() if created is None else created),
                "provenance": json.dumps(check_provenance(provenance or {})),
            }
            self._file = h5py.File(self.path, "w", libver="latest")
            try:
                self._datasets = self._create_datasets(with_labels, with_wrench, with_joints)
                self._file.attrs.update(attributes)
                self._file.swmr_mode = True
            except BaseException:
                self._file.close()
                raise
        self._count = 0
        self._last_time = -np.inf

    def _create_datasets(
        self, with_labels: bool, with_wrench: bool, with_joints: bool
    ) -> dict[str, h5py.Dataset]:
        """Empty resizable chunked datasets; `timestamps` last, as it commits each frame."""
        rows, cols = self.frame_shape
        wanted = {
            "frames": True,
            "labels": with_labels,
            "probe_to_base": True,
            "wrench": with_wrench,
            "joint_positions": with_joints,
        }
        layouts: dict[str, tuple[tuple[int, ...], type[np.generic], int, dict[str, Any]]] = {
            "frames": ((rows, cols), np.uint8, 1, {}),
            "labels": ((rows, cols), np.uint8, 1, LABEL_COMPRESSION),
            "probe_to_base": ((4, 4), np.float64, 256, {}),
            "wrench": ((6,), np.float64, 256, {}),
            "joint_positions": ((6,), np.float64, 256, {}),
            "timestamps": ((), np.float64, 1024, {"fillvalue": np.nan}),
        }
        datasets = {}
        for name, (shape, dtype, chunk, options) in layouts.items():
            if wanted.get(name, True):
                datasets[name] = self._file.create_dataset(
                    name,
                    shape=(0, *shape),
                    maxshape=(None, *shape),
                    dtype=dtype,
                    chunks=(chunk, *shape),
                    **options,
                )
        return datasets

    def __len__(self) -> int:
        return self._count

    def __exit__(self, *exc_info: object) -> None:
        self.close()

    def close(self) -> None:
        """Flush and close the file (safe to call twice)."""
        if self._file.id.valid:
            with file_errors(self.path, "closing the sweep file"):
                self._file.close()

    def append(self, frame: SweepFrame) -> None:
        """Check one frame and its data, write it, and flush it to disk."""
        n = self._count
        with file_errors(self.path, f"writing frame {n}"):
            if not self._file.id.valid:
                raise SweepError("the sweep writer is closed")
            if frame.index != n:
                raise SweepError(f"frame {frame.index} arrived where frame {n} was due")
            rows = {
                "frames": self._checked_image(frame.image, "frame", n),
                "probe_to_base": check_poses(np.asarray(frame.probe_to_base)[None], start=n)[0],
            }
            time = float(check_timestamps(np.atleast_1d(frame.timestamp), n, self._last_time)[0])
            optional = {
                "labels": frame.label,
                "wrench": frame.wrench,
                "joint_positions": frame.joint_positions,
            }
            for name, value in optional.items():
                if (value is not None) != (name in self._datasets):
                    has = "has" if name in self._datasets else "has no"
                    given = "given" if value is not None else "missing"
                    raise SweepError(f"frame {n}: {name} {given}, but the file {has} {name}")
                if value is None:
                    continue
                if name == "labels":
                    rows[name] = self._checked_image(value, "label", n)
                    check_labels(rows[name][None], self.label_names, start=n)
                else:
                    rows[name] = check_finite(value, f"{name}[{n}]", (6,))
            for name, row in rows.items():
                self._append_row(name, row)
            self._file.flush()
            self._append_row("timestamps", time)
            self._file.flush()
        self._count, self._last_time = n + 1, time

    def _checked_image(self, image: np.ndarray, name: str, index: int) -> np.ndarray:
        image = check_uint8(image, f"{name} {index}", 2)
        if image.shape != self.frame_shape:
            raise SweepError(
                f"{name} {index} has shape {image.shape}, the sweep's frames are {self.frame_shape}"
            )
        return image

    def _append_row(self, name: str, row: object) -> None:
        dataset = self._datasets[name]
        dataset.resize(self._count + 1, axis=0)
        dataset[self._count] = row


def _check_not_truncated(path: Path) -> None:
    """Compare the end-of-file address in an HDF5 superblock with the file's size."""
    with open(path, "rb") as file:
        head = file.read(64)
    if not head.startswith(HDF5_SIGNATURE) or len(head) < 48:
        return
    version, offset_size = head[8], head[13] if head[8] < 2 else head[9]
    if offset_size != 8 or version not in (0, 2, 3):
        return
    eof_at = 40 if version == 0 else 28
    stored_eof = struct.unpack("<Q", head[eof_at : eof_at + 8])[0]
    size = os.path.getsize(path)
    if size < stored_eof:
        raise SweepError(f"HDF5 file is truncated ({size} of {stored_eof} bytes)", path)


def _open_hdf5(path: Path) -> h5py.File:
    """Open an HDF5 file for reading, also one left open by a running or killed SWMR writer."""
    if not path.exists():
        raise SweepError("no such file", path)
    if path.is_dir():
        raise SweepError("is a directory, not a sweep file", path)
    with file_errors(path, "reading the file"):
        if not h5py.is_hdf5(path):
            raise SweepError("not an HDF5 file, so not a resus sweep", path)
        _check_not_truncated(path)
    try:
        return h5py.File(path, "r")
    except OSError as error:
        if "already open for write" not in str(error):
            raise SweepError(f"damaged HDF5 file ({error_summary(error)})", path) from None
    try:  # a writer is still running, or was killed: only a SWMR reader may open it
        return h5py.File(path, "r", swmr=True)
    except OSError as error:
        raise SweepError(
            f"HDF5 file was left open by a writer and cannot be read ({error_summary(error)})",
            path,
        ) from None


class SweepReader(AbstractContextManager):
    """A sweep file opened for reading: metadata and poses at once, frames on demand.

    Opening checks the schema, the datasets' shapes and types, the calibration, and that
    every pose is rigid and finite and time increases; frame images are read by `frame(i)`.
    """

    def __init__(self, path: str | Path) -> None:
        self.path = Path(path)
        self._file = _open_hdf5(self.path)
        try:
            with file_errors(self.path, "reading the sweep"):
                self._load()
        except SweepError:
            self._file.close()
            raise

    def _load(self) -> None:
        file = self._file
        schema = file.attrs.get("schema")
        if schema is None:
            raise SweepError(f"not a resus sweep (no 'schema' attribute; expected {SCHEMA!r})")
        schema = schema.decode() if isinstance(schema, bytes) else str(schema)
        if schema != SCHEMA:
            raise SweepError(f"schema is {schema!r}, expected {SCHEMA!r}")
        for name in ("frames", "probe_to_base", "timestamps"):
            if not isinstance(file.get(name), h5py.Dataset):
                raise SweepError(f"missing dataset {name!r}")
        for name in ("image_to_probe", "label_names", "source", "subject", "created"):
            if name not in file.attrs:
                raise SweepError(f"missing attribute {name!r}")
        # Timestamps first: a live writer appends a frame's rows before its timestamp, so every
        # dataset opened after the timestamps has at least as many rows (see _committed_count).
        names = ["timestamps", *(name for name in file if name != "timestamps")]
        present = {name: file[name] for name in names if isinstance(file[name], h5py.Dataset)}
        if file.swmr_mode:  # the checks above cached older shapes: reread them, in this order
            for dataset in present.values():
                dataset.refresh()
        self.count = self._committed_count(present)
        frames = present["frames"]
        if frames.dtype != np.uint8 or frames.ndim != 3:
            raise SweepError(f"frames must be (N, H, W) uint8, got {frames.shape} {frames.dtype}")
        self.frame_shape: tuple[int, int] = frames.shape[1:]
        labels = present.get("labels")
        if labels is not None and (
            labels.dtype != np.uint8 or labels.shape[1:] != frames.shape[1:]
        ):
            raise SweepError(
                f"labels must be (N, H, W) uint8 like frames {frames.shape}, "
                f"got {labels.shape} {labels.dtype}"
            )
        n = self.count
        self.image_to_probe = check_calibration(file.attrs["image_to_probe"])
        self.label_names = check_label_names(file.attrs["label_names"])
        self.source = check_source(_text(file.attrs["source"]))
        self.subject = _text(file.attrs["subject"])
        self.created = check_created(_text(file.attrs["created"]))
        self.provenance = _provenance(file.attrs.get("provenance"))
        self.timestamps = check_timestamps(present["timestamps"][:n])
        self.probe_to_base = check_poses(present["probe_to_base"][:n])
        self.wrench, self.joint_positions = (
            check_finite(present[name][:n], name, (None, 6)) if name in present else None
            for name in VECTOR_DATASETS
        )
        self._frames, self._labels = frames, labels

    @staticmethod
    def _committed_count(datasets: dict[str, h5py.Dataset]) -> int:
        """Frames whose timestamp was written. Other datasets may hold more rows (frames a
        live writer is still writing, or the one a killed writer left), never fewer."""
        stamps = datasets["timestamps"]
        count = len(stamps)
        if count and not np.isfinite(stamps[count - 1]):
            count -= 1
        for name, dataset in datasets.items():
            if dataset.ndim == 0 or len(dataset) < count:
                rows = "no rows" if dataset.ndim == 0 else f"{len(dataset)} rows"
                raise SweepError(
                    f"mismatched shapes: {name} has {rows} but timestamps has {len(stamps)}"
                )
        return count

    def __len__(self) -> int:
        return self.count

    def __exit__(self, *exc_info: object) -> None:
        self.close()

    def close(self) -> None:
        """Close the file (safe to call twice)."""
        if self._file.id.valid:
            self._file.close()

    @property
    def has_labels(self) -> bool:
        return self._labels is not None

    def frame(self, index: int) -> SweepFrame:
        """Frame `index` (0 <= index < len), read from disk now."""
        if not 0 <= index < self.count:
            raise SweepError(f"frame {index} out of range: the sweep has {self.count}", self.path)
        with file_errors(self.path, f"reading frame {index}"):
            label = None
            if self._labels is not None:
                label = self._labels[index]
                check_labels(label[None], self.label_names, start=index)
            return SweepFrame(
                index,
                self._frames[index],
                self.probe_to_base[index],
                float(self.timestamps[index]),
                label,
                None if self.wrench is None else self.wrench[index],
                None if self.joint_positions is None else self.joint_positions[index],
            )

    def iter_frames(self) -> Iterator[SweepFrame]:
        """Every frame in order, one read at a time."""
        for index in range(self.count):
            yield self.frame(index)

    def to_sweep(self) -> Sweep:
        """Load the whole sweep into memory as a checked `Sweep`."""
        if self.count == 0:
            raise SweepError("the sweep holds no frames", self.path)
        with file_errors(self.path, "reading the sweep"):
            return Sweep(
                frames=self._frames[: self.count],
                probe_to_base=self.probe_to_base,
                timestamps=self.timestamps,
                image_to_probe=self.image_to_probe,
                labels=None if self._labels is None else self._labels[: self.count],
                wrench=self.wrench,
                joint_positions=self.joint_positions,
                label_names=self.label_names,
                source=self.source,
                subject=self.subject,
                created=self.created,
                provenance=self.provenance,
            )


def _text(value: object) -> str:
    return value.decode() if isinstance(value, bytes) else str(value)


def _provenance(value: object) -> dict:
    """The `provenance` attribute (JSON); files written before it existed have none: {}."""
    if value is None:
        return {}
    try:
        return check_provenance(json.loads(_text(value)))
    except ValueError:
        raise SweepError("attribute 'provenance' is not JSON") from None


def read_sweep(path: str | Path) -> Sweep:
    """Read and check a whole sweep file."""
    with SweepReader(path) as reader:
        return reader.to_sweep()


def write_sweep(path: str | Path, sweep: Sweep) -> None:
    """Write `sweep` to `path` (replacing it) in the `resus.sweep/1` format."""
    with SweepWriter(
        path,
        sweep.frame_shape,
        sweep.image_to_probe,
        with_labels=sweep.labels is not None,
        with_wrench=sweep.wrench is not None,
        with_joints=sweep.joint_positions is not None,
        source=sweep.source,
        subject=sweep.subject,
        label_names=sweep.label_names,
        created=sweep.created,
        provenance=sweep.provenance,
    ) as writer:
        for index in range(len(sweep)):
            writer.append(sweep.frame(index))
