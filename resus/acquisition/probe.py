"""The abstract probe (frame source): timestamped images with their calibration."""

from __future__ import annotations

from abc import ABC, abstractmethod
from dataclasses import dataclass

import numpy as np

from sim.ultrasound.probe import LinearProbe


@dataclass(frozen=True)
class Frame:
    """One image as the probe delivered it; `timestamp` is on the probe's own clock (s)."""

    timestamp: float
    image: np.ndarray
    label: np.ndarray | None = None


class Probe(ABC):
    """A source of B-mode frames with a fixed `image_to_probe` calibration (metres per pixel
    included). Frames arrive late and on their own clock; the scanner aligns them."""

    has_labels: bool = False
    """Whether frames come with ground-truth label images (simulation only)."""

    @property
    @abstractmethod
    def image_to_probe(self) -> np.ndarray:
        """(4, 4) map of a pixel `(col, row, 0, 1)` to the probe's TCP frame in metres."""

    @property
    @abstractmethod
    def shape(self) -> tuple[int, int]:
        """(rows, cols) of every frame."""

    @abstractmethod
    def poll(self) -> list[Frame]:
        """Frames captured since the last call, oldest first (possibly none)."""

    def close(self) -> None:  # noqa: B027 - optional hook, nothing to release by default
        """Release the device."""


class SyntheticProbe(Probe):
    """A probe whose images the simulator renders: its geometry is a `LinearProbe`'s."""

    has_labels = True
    geometry: LinearProbe
    """The simulated transducer: array width, depth, pixel grid."""

    @property
    def image_to_probe(self) -> np.ndarray:
        return self.geometry.image_to_probe()

    @property
    def shape(self) -> tuple[int, int]:
        return self.geometry.rows, self.geometry.cols
