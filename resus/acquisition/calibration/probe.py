"""The probe calibration file: where the B-mode image sits in the grabbed video, and its scale.

A frame grabber delivers the scanner's whole screen; the ultrasound image is one rectangle of
it (`crop`), and `image_to_probe` maps a pixel `(col, row, 0, 1)` of that cropped image to the
probe's TCP frame in metres. YAML, schema `resus.probe/1`, with exactly one of:

    schema: resus.probe/1
    crop: [x, y, width, height]        # optional: pixels of the grabbed frame; default all of it
    pixel_spacing_mm: [0.15, 0.2]      # (column, row) size; or `pixel_spacing` in metres
    # or, from a spatial (PLUS-style) calibration:
    image_to_probe_mm: [[...4x4...]]   # PLUS ImageToProbe, millimetres; or `image_to_probe` (m)

With a pixel spacing the image is placed like the simulated linear probe: the top row at the
transducer face (the TCP), the middle column on the probe axis, columns along the probe's x.
"""

from __future__ import annotations

from collections.abc import Iterable
from dataclasses import dataclass
from pathlib import Path

import numpy as np

from resus.errors import ResusError
from resus.sweep.model import check_calibration
from resus.yaml_file import read_yaml
from sim.ultrasound.probe import LinearProbe

SCHEMA = "resus.probe/1"
MM = 1e-3
SCALE_KEYS = ("pixel_spacing", "pixel_spacing_mm", "image_to_probe", "image_to_probe_mm")


def parse_crop(values: object, name: str = "crop") -> tuple[int, int, int, int]:
    """(x, y, width, height) in pixels from four non-negative integers (width, height > 0)."""
    try:
        if not isinstance(values, Iterable):
            raise TypeError
        x, y, width, height = (int(v) for v in values)
    except (TypeError, ValueError):
        raise ResusError(
            f"{name}: expected four integers x, y, width, height, got {values!r}"
        ) from None
    if x < 0 or y < 0 or width < 1 or height < 1:
        raise ResusError(f"{name}: x, y must be >= 0 and width, height > 0, got {values!r}")
    return x, y, width, height


@dataclass(frozen=True)
class ProbeCalibration:
    """Crop rectangle and pixel-to-probe mapping of one probe on one scanner set-up."""

    crop: tuple[int, int, int, int] | None = None
    """(x, y, width, height) of the image in the grabbed frame; None: the whole frame."""
    pixel_spacing: tuple[float, float] | None = None
    """(column, row) pixel size (m), placing the image like the simulated linear probe."""
    matrix: np.ndarray | None = None
    """A full image_to_probe (4x4, m); exclusive with pixel_spacing."""

    def __post_init__(self) -> None:
        if (self.pixel_spacing is None) == (self.matrix is None):
            raise ResusError(
                "ProbeCalibration needs exactly one of pixel_spacing and matrix, got "
                f"{'both' if self.matrix is not None else 'neither'}"
            )
        if self.pixel_spacing is not None and not all(
            np.isfinite(s) and s > 0 for s in self.pixel_spacing
        ):
            raise ResusError(
                f"ProbeCalibration.pixel_spacing must be positive, got {self.pixel_spacing}"
            )
        if self.matrix is not None:
            object.__setattr__(self, "matrix", check_calibration(self.matrix))

    def image_to_probe(self, shape: tuple[int, int]) -> np.ndarray:
        """The 4x4 mapping for cropped images of `shape` (rows, cols)."""
        if self.matrix is not None:
            return self.matrix.copy()
        rows, cols = shape
        column_size, row_size = self.pixel_spacing  # type: ignore[misc]
        geometry = LinearProbe(
            width=cols * column_size, depth=rows * row_size, cols=cols, rows=rows
        )
        return geometry.image_to_probe()

    @classmethod
    def from_yaml(cls, path: str | Path) -> ProbeCalibration:
        """Read a calibration file; any problem is a one-line ResusError naming it."""
        path = Path(path)
        document = read_yaml(path, "probe calibration", SCHEMA)
        given = [key for key in SCALE_KEYS if document.get(key) is not None]
        if len(given) != 1:
            raise ResusError(f"give exactly one of {', '.join(SCALE_KEYS)}; got {given}", path)
        key = given[0]
        try:
            crop = document.get("crop")
            crop = None if crop is None else parse_crop(crop)
            value = np.asarray(document[key], dtype=np.float64)
            scale = MM if key.endswith("_mm") else 1.0
            if key.startswith("pixel_spacing"):
                if value.shape != (2,):
                    raise ResusError(f"{key} must be [column, row], got {document[key]!r}")
                return cls(crop=crop, pixel_spacing=(value[0] * scale, value[1] * scale))
            if value.shape != (4, 4):
                raise ResusError(f"{key} must be a 4x4 matrix, got shape {value.shape}")
            metres = np.diag([scale, scale, scale, 1.0]) @ value
            return cls(crop=crop, matrix=metres)
        except ResusError as error:
            raise ResusError(str(error), path) from None
        except (TypeError, ValueError) as error:
            raise ResusError(f"bad {key} ({error})", path) from None
