"""Linear probe geometry and the image-to-probe calibration it implies.

Probe frame (the robot's TCP): origin at the centre of the transducer face, z pointing into
the tissue, x along the transducer array, y = z cross x (the elevation direction).

Image: pixel `(col, row)` has its centre at `x = (col - (cols - 1) / 2) * pixel_width` and
`z = (row + 0.5) * pixel_height`, so row 0 lies half a pixel below the face and the image is
centred on the array. `image_to_probe @ (col, row, 0, 1)` gives that point in metres; the
image's third axis maps to -y so that the 3x3 part is a scaled proper rotation.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np


@dataclass(frozen=True)
class LinearProbe:
    """A linear-array transducer (defaults: a 5-12 MHz vascular probe, 38 mm wide, 50 mm deep)."""

    width: float = 0.038
    """Field-of-view width along the array (m)."""
    depth: float = 0.050
    """Imaging depth below the transducer face (m)."""
    cols: int = 256
    """Image width in pixels (along the array)."""
    rows: int = 256
    """Image height in pixels (along depth)."""
    centre_frequency: float = 7.5e6
    """Transmit centre frequency (Hz)."""
    elevation_thickness: float = 0.001
    """Full width of the elevational slice at the focus (m)."""
    face_thickness: float = 0.010
    """Size of the transducer face along y (m), for contact checks and the MuJoCo body."""

    def __post_init__(self) -> None:
        for name in ("width", "depth", "centre_frequency", "elevation_thickness", "face_thickness"):
            if not getattr(self, name) > 0:
                raise ValueError(f"probe {name} must be positive, got {getattr(self, name)}")
        if self.cols < 2 or self.rows < 2:
            raise ValueError(
                f"probe image must be at least 2 x 2 pixels, got {self.cols} x {self.rows}"
            )

    @property
    def pixel_width(self) -> float:
        """Lateral pixel spacing (m)."""
        return self.width / self.cols

    @property
    def pixel_height(self) -> float:
        """Axial pixel spacing (m)."""
        return self.depth / self.rows

    def column_x(self) -> np.ndarray:
        """(cols,) lateral position (m) of each image column's centre, its element, across
        the face."""
        return (np.arange(self.cols) - (self.cols - 1) / 2) * self.pixel_width

    def image_to_probe(self) -> np.ndarray:
        """4x4 calibration mapping `(col, row, 0, 1)` to the probe frame in metres."""
        sx, sz = self.pixel_width, self.pixel_height
        return np.array(
            [
                [sx, 0.0, 0.0, -(self.cols - 1) / 2 * sx],
                [0.0, 0.0, -sx, 0.0],
                [0.0, sz, 0.0, 0.5 * sz],
                [0.0, 0.0, 0.0, 1.0],
            ]
        )

    def pixel_points(self) -> np.ndarray:
        """Probe-frame coordinates of every pixel centre, shape (rows, cols, 3)."""
        cols, rows = np.meshgrid(np.arange(self.cols), np.arange(self.rows))
        homogeneous = np.stack([cols, rows, np.zeros_like(cols), np.ones_like(cols)], axis=-1)
        return (homogeneous @ self.image_to_probe().T)[..., :3]
