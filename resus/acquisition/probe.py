"""The abstract probe (frame source): timestamped images with their calibration."""

from __future__ import annotations

from abc import ABC, abstractmethod
from dataclasses import dataclass

import numpy as np


@dataclass(frozen=True)
class Frame:
    """One image as the probe delivered it; `timestamp` is on the probe's own clock (s)."""

    timestamp: float
    image: np.ndarray
    label: np.ndarray | None = None


class Probe(ABC):
    """A source of B-mode frames with a fixed `image_to_probe` calibration (metres per pixel
    included). Frames arrive late and on their own clock; the scanner aligns them."""

    image_to_probe: np.ndarray
    shape: tuple[int, int]
    """(rows, cols) of every frame."""
    has_labels: bool = False
    """Whether frames come with ground-truth label images (simulation only)."""

    @abstractmethod
    def poll(self) -> list[Frame]:
        """Frames captured since the last call, oldest first (possibly none)."""

    def close(self) -> None:  # noqa: B027 - optional hook, nothing to release by default
        """Release the device."""
