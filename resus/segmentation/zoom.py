"""Scanner zoom: a window of a simulated frame enlarged to the whole frame.

Every scanner has a zoom (and a depth control that does much the same to what is shown): the
sonographer enlarges the part of the image that holds the vessels, so real exports show
vessels larger, and cut by the image's edges, more often than a simulated sweep at a fixed
field of view does (usgra-seg: vessels median 0.23 of the imaged height across, against 0.20
in the `femoral` sweeps before framing shrinks them). This transform, part of the `aug`
regime, cuts a random window (a random magnification, aspect ratio within `zoom_aspect`,
random place) and resizes it to the frame's size; the label map follows with nearest-neighbour
resizing.
"""

from __future__ import annotations

from dataclasses import dataclass

import cv2
import numpy as np

from resus.segmentation.framing import random_window
from resus.segmentation.presets import AugmentationConfig


@dataclass
class ScannerZoom:
    """`zoom(image=, mask=) -> {"image", "mask"}` on (H, W) uint8 arrays, drawing from `rng`."""

    config: AugmentationConfig
    rng: np.random.Generator

    def __call__(self, *, image: np.ndarray, mask: np.ndarray) -> dict[str, np.ndarray]:
        config = self.config
        if self.rng.random() >= config.zoom_p:
            return {"image": image, "mask": mask}
        rows, cols = image.shape
        magnification = self.rng.uniform(*config.zoom_range)
        aspect = np.exp(self.rng.uniform(*np.log(config.zoom_aspect)))
        height = min(rows, max(2, round(rows / magnification * np.sqrt(aspect))))
        width = min(cols, max(2, round(cols / magnification / np.sqrt(aspect))))
        window = random_window(self.rng, image.shape, height, width)
        return {
            "image": cv2.resize(image[window], (cols, rows), interpolation=cv2.INTER_LINEAR),
            "mask": cv2.resize(mask[window], (cols, rows), interpolation=cv2.INTER_NEAREST),
        }
