"""The two sides of the comparison: grey images with their vessel masks, and their imaged area.

Imaged area. Scanners pad the B-mode picture with black margins (above and below a shallow
image, beside a narrow one) and the simulator leaves columns without skin contact black. A
border row or column is margin when at least `blank_fraction` of its pixels are exactly 0 (a
logo or a depth scale's tick marks in the margin do not make it imaged): margins are stripped
from each side inwards (rows first, then columns over the rows left) and the imaged area is
the rectangle that remains. Dark tissue, even a deep shadow, is almost never exactly 0 along a
whole line, so it stays in.
"""

from __future__ import annotations

from collections.abc import Sequence
from dataclasses import dataclass
from pathlib import Path

import numpy as np

from resus.errors import ResusError
from resus.indices import evenly_spaced
from sim.labels import VESSEL_CLASSES
from sim.ultrasound.settings import UltrasoundSettings

REAL_CREDIT = "real: tmkand/usgra-seg (CC BY 4.0)"
"""The real images' licence asks for this credit wherever they or figures of them are shown."""
SIMULATOR_DYNAMIC_RANGE_DB = UltrasoundSettings().dynamic_range_db
"""The simulator's default display dynamic range, for sweeps whose provenance lacks theirs."""


@dataclass(frozen=True)
class ImageSet:
    """One side of the comparison: grey images, their vessel masks and where each came from."""

    name: str
    images: tuple[np.ndarray, ...]
    """2-D uint8 grey images, any sizes."""
    vessels: tuple[np.ndarray, ...]
    """Bool masks of the vessel lumens, one per image, same shape."""
    sources: tuple[str, ...]
    """Where each image came from ("sweep.h5 #12", "0003.png")."""
    dynamic_range_db: float | None = None
    """The display dynamic range when it is known (simulated images), for the Rayleigh
    reference; real images do not record it."""

    def __post_init__(self) -> None:
        if not self.images:
            raise ResusError(f"the {self.name} image set is empty")
        if not len(self.images) == len(self.vessels) == len(self.sources):
            raise ResusError(
                f"the {self.name} image set has {len(self.images)} images, "
                f"{len(self.vessels)} masks and {len(self.sources)} sources"
            )
        for image, vessel, source in zip(self.images, self.vessels, self.sources, strict=True):
            if image.dtype != np.uint8 or image.ndim != 2:
                raise ResusError(f"{source}: expected a 2-D uint8 grey image, got {image.shape}")
            if vessel.dtype != np.bool_ or vessel.shape != image.shape:
                raise ResusError(f"{source}: expected a bool mask of shape {image.shape}")

    def __len__(self) -> int:
        return len(self.images)


def read_sweep_set(
    paths: Sequence[str | Path],
    frames: int | None = None,
    dynamic_range_db: float | None = None,
    name: str = "simulated",
) -> ImageSet:
    """`frames` evenly spaced labelled frames of each sweep (all of them when None); the
    vessel mask is every class of the sweep's vocabulary that is a vessel (artery, vein).
    `dynamic_range_db` (None: the sweeps' own, from their provenance, or the simulator's
    default for sweeps without one; unknown when the sweeps differ) sets the Rayleigh
    reference."""
    from resus.sweep.io import SweepReader

    images: list[np.ndarray] = []
    vessels: list[np.ndarray] = []
    sources: list[str] = []
    ranges: set[object] = set()
    for path in map(Path, paths):
        with SweepReader(path) as reader:
            if not reader.has_labels:
                raise ResusError("the sweep has no labels (realism needs its vessels)", path)
            if len(reader) == 0:
                raise ResusError("the sweep holds no frames", path)
            ranges.add(reader.provenance.get("dynamic_range_db", SIMULATOR_DYNAMIC_RANGE_DB))
            values = [v for v, label in enumerate(reader.label_names) if label in VESSEL_CLASSES]
            for index in evenly_spaced(len(reader), frames or len(reader)):
                frame = reader.frame(index)
                assert frame.label is not None  # the reader has labels (checked above)
                images.append(frame.image)
                vessels.append(np.isin(frame.label, values))
                sources.append(f"{path.name} #{index}")
    if dynamic_range_db is None and len(ranges) == 1:
        only = ranges.pop()
        dynamic_range_db = float(only) if isinstance(only, int | float) else None
    return ImageSet(name, tuple(images), tuple(vessels), tuple(sources), dynamic_range_db)


def read_image_folder(folder: str | Path, name: str = "real") -> ImageSet:
    """Every image of `folder/images` with its `folder/masks` namesake (nonzero = vessel),
    read by `resus.segmentation.folders.read_data_set` like a training set."""
    from resus.segmentation.folders import read_data_set

    data = read_data_set(Path(folder))
    vessels = tuple(labels > 0 for labels in data.labels)
    return ImageSet(name, data.images, vessels, data.names)


def imaged_region(image: np.ndarray, blank_fraction: float = 0.95) -> tuple[slice, slice]:
    """(rows, cols) slices of the imaged rectangle: border rows, then border columns, with at
    least `blank_fraction` of their pixels exactly 0 stripped from each side inwards."""
    black = np.asarray(image) == 0
    rows = _inner_span(black.mean(axis=1) >= blank_fraction)
    if rows.stop == rows.start:
        return rows, rows
    return rows, _inner_span(black[rows].mean(axis=0) >= blank_fraction)


def _inner_span(blank: np.ndarray) -> slice:
    """The lines from the first to the last that is not blank (empty when all are)."""
    kept = np.flatnonzero(~blank)
    return slice(int(kept[0]), int(kept[-1]) + 1) if kept.size else slice(0, 0)
