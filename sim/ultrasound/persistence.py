"""Persistence: a scanner's frame averaging, applied to the stream of displayed images.

Scanners smooth the live image over time with a first-order recursive filter on the
log-compressed grey levels: displayed_n = p * displayed_(n-1) + (1 - p) * new_n. It lowers
the frame-to-frame flicker of electronic noise and speckle decorrelating under a moving probe,
and smears what moves. It is a property of the stream, not of one pose, so it lives here and
not in `UltrasoundSimulator.render` (which stays a function of the pose).
"""

from __future__ import annotations

import numpy as np


class Persistence:
    """The recursive filter of weight `weight` (`UltrasoundSettings.persistence`); 0 passes
    every image through unchanged."""

    def __init__(self, weight: float) -> None:
        if not 0 <= weight < 1:
            raise ValueError(f"persistence must be in [0, 1), got {weight}")
        self.weight = weight
        self._displayed: np.ndarray | None = None

    def __call__(self, image: np.ndarray) -> np.ndarray:
        """The displayed uint8 image once `image` (uint8) has arrived; the first image of a
        stream, or one of another size, starts the average afresh."""
        if self.weight == 0:
            return image
        new = image.astype(np.float32)
        if self._displayed is None or self._displayed.shape != new.shape:
            self._displayed = new
        else:
            self._displayed = self.weight * self._displayed + (1.0 - self.weight) * new
        return np.rint(self._displayed).astype(np.uint8)
