"""The reslice dataset on disk (HDF5, schema `resus.reslices/1`) that training reads.

| dataset / attribute | shape, type | meaning |
| --- | --- | --- |
| `images` | (M, S, S) uint8 | resliced grey levels |
| `labels` | (M, S, S) uint8 | resliced classes |
| `angles_deg` | (M, 2) float64 | rotation about x, then about y (degrees) |
| `slice_index` | (M,) int32 | z index of the slice in the rotated volume |
| `plane_to_world` | (M, 4, 4) float64 | pixel `(col, row, 0, 1)` to world metres |
| attrs `schema`, `source_volume`, `subject`, `label_names`, `created` | | volume: path from here |
| attrs `angles_deg`, `step`, `min_nonzero`, `size`, `method` | | the settings |
| attrs `intensity_order`, `label_order` | | spline orders used (3 and 0) |

`ResliceWriter` appends reslices as they come (chunked, resizable datasets, flushed every
chunk), so a long run keeps memory flat and a crash loses at most the unflushed tail.
`ResliceDataset` reads one reslice or a batch at a time without loading the file.
"""

from __future__ import annotations

import os
from collections.abc import Iterable, Iterator
from contextlib import AbstractContextManager
from pathlib import Path

import h5py
import numpy as np

from resus.errors import ResusError
from resus.reslicing.reslice import Reslice, ResliceSettings
from resus.sweep.timestamps import now_iso
from sim.labels import LABEL_NAMES

SCHEMA = "resus.reslices/1"
FLUSH_EVERY = 64


class ResliceWriter(AbstractContextManager):
    """Streams reslices into a new HDF5 file; use as a context manager. `source_volume` is
    the volume file they were cut from, recorded relative to the new file's folder."""

    def __init__(
        self,
        path: str | Path,
        settings: ResliceSettings,
        source_volume: str | Path,
        subject: str = "",
        label_names: Iterable[str] = LABEL_NAMES,
    ) -> None:
        self.path = Path(path)
        self.path.parent.mkdir(parents=True, exist_ok=True)
        try:
            self._file = h5py.File(self.path, "w")
        except OSError as error:
            raise ResusError(f"cannot write reslice dataset ({error})", self.path) from error
        size = settings.size
        attrs = self._file.attrs
        attrs["schema"] = SCHEMA
        # relative to this file's folder: a folder moved or copied whole keeps it right
        attrs["source_volume"] = os.path.relpath(source_volume, self.path.parent)
        attrs["subject"] = subject
        attrs["label_names"] = list(label_names)
        attrs["created"] = now_iso()
        for name, value in settings.as_attrs().items():
            attrs[name] = value
        self._datasets = {
            "images": self._create("images", (size, size), np.uint8, compress=True),
            "labels": self._create("labels", (size, size), np.uint8, compress=True),
            "angles_deg": self._create("angles_deg", (2,), np.float64),
            "slice_index": self._create("slice_index", (), np.int32),
            "plane_to_world": self._create("plane_to_world", (4, 4), np.float64),
        }
        self.count = 0

    def _create(
        self, name: str, item_shape: tuple[int, ...], dtype: type, compress: bool = False
    ) -> h5py.Dataset:
        return self._file.create_dataset(
            name,
            shape=(0, *item_shape),
            maxshape=(None, *item_shape),
            dtype=dtype,
            chunks=(1 if compress else FLUSH_EVERY, *item_shape),
            compression="gzip" if compress else None,
            compression_opts=4 if compress else None,
        )

    def append(self, reslice: Reslice) -> None:
        """Add one reslice at the end of the file."""
        values = {
            "images": reslice.image,
            "labels": reslice.label,
            "angles_deg": np.asarray(reslice.angles_deg, dtype=np.float64),
            "slice_index": reslice.slice_index,
            "plane_to_world": reslice.plane_to_world,
        }
        for name, dataset in self._datasets.items():
            dataset.resize(self.count + 1, axis=0)
            dataset[self.count] = values[name]
        self.count += 1
        if self.count % FLUSH_EVERY == 0:
            self._file.flush()

    def close(self) -> None:
        """Flush and close the file."""
        if self._file.id.valid:
            self._file.close()

    def __exit__(self, *exc_info: object) -> None:
        self.close()


class ResliceDataset(AbstractContextManager):
    """Reads a `resus.reslices/1` file lazily: `len`, indexing and batches."""

    def __init__(self, path: str | Path) -> None:
        self.path = Path(path)
        if not self.path.is_file():
            raise ResusError("no such reslice dataset", self.path)
        try:
            self._file = h5py.File(self.path, "r")
        except OSError as error:
            raise ResusError(f"not an HDF5 file ({error})", self.path) from error
        schema = self._file.attrs.get("schema")
        if schema != SCHEMA:
            self._file.close()
            raise ResusError(f"schema is {schema!r}, expected {SCHEMA!r}", self.path)
        self.images: h5py.Dataset = self._file["images"]
        self.labels: h5py.Dataset = self._file["labels"]
        self.angles_deg: h5py.Dataset = self._file["angles_deg"]
        self.slice_index: h5py.Dataset = self._file["slice_index"]
        self.plane_to_world: h5py.Dataset = self._file["plane_to_world"]

    @property
    def attrs(self) -> dict[str, object]:
        """File attributes: provenance and the settings the reslices were made with."""
        return dict(self._file.attrs)

    @property
    def label_names(self) -> list[str]:
        """Class names, index = label value."""
        return [str(name) for name in self._file.attrs["label_names"]]

    def __len__(self) -> int:
        return self.images.shape[0]

    def __getitem__(self, index: int) -> Reslice:
        if not -len(self) <= index < len(self):
            raise IndexError(f"reslice {index} out of range for {len(self)} reslices")
        angle_x, angle_y = (float(a) for a in self.angles_deg[index])
        return Reslice(
            image=self.images[index],
            label=self.labels[index],
            angles_deg=(angle_x, angle_y),
            slice_index=int(self.slice_index[index]),
            plane_to_world=self.plane_to_world[index],
        )

    def __iter__(self) -> Iterator[Reslice]:
        for index in range(len(self)):
            yield self[index]

    def batches(self, batch_size: int) -> Iterator[tuple[np.ndarray, np.ndarray]]:
        """`(images, labels)` arrays of up to `batch_size` reslices, in file order."""
        if batch_size < 1:
            raise ResusError(f"batch_size must be at least 1, got {batch_size}")
        for start in range(0, len(self), batch_size):
            stop = min(start + batch_size, len(self))
            yield self.images[start:stop], self.labels[start:stop]

    def close(self) -> None:
        """Close the file."""
        self._file.close()

    def __exit__(self, *exc_info: object) -> None:
        self.close()
