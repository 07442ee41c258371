"""8-bit grey images from whatever a scanner, a bag or a folder delivers.

B-mode is grey, but it reaches us as grey, BGR(A) (OpenCV's frame grabbers and PNG reader)
or RGB(A) (OpenIGTLink, ROS, Pillow), often with a tint; every path into a Sweep or a
training set converts here, by the ITU-R 601 luma, so they all agree on the grey levels.
"""

from __future__ import annotations

import numpy as np

from resus.errors import ResusError


def to_grey(image: np.ndarray, colour_order: str = "bgr", source: str = "the video") -> np.ndarray:
    """An 8-bit grey image from a grey, BGR(A) or (with `colour_order="rgb"`) RGB(A) one;
    `source` names what delivered it in the error for any other kind of array."""
    import cv2

    if image.dtype != np.uint8:
        raise ResusError(f"{source} delivers {image.dtype} frames; expected 8-bit images")
    if image.ndim == 2:
        return image
    if image.ndim == 3 and image.shape[2] == 1:
        return image[:, :, 0]
    if image.ndim == 3 and image.shape[2] in (3, 4):
        codes = {
            ("bgr", 3): cv2.COLOR_BGR2GRAY,
            ("bgr", 4): cv2.COLOR_BGRA2GRAY,
            ("rgb", 3): cv2.COLOR_RGB2GRAY,
            ("rgb", 4): cv2.COLOR_RGBA2GRAY,
        }
        return cv2.cvtColor(image, codes[colour_order, image.shape[2]])
    raise ResusError(f"{source} delivers frames of shape {image.shape}; expected an image")
