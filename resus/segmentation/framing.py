"""Export framing: a simulated frame made to look like a scanner's exported image.

A scanner's export is not its imaged area: the B-mode sector sits in a larger black canvas,
with margins above and below (a quarter to a third of a 512-row export), the depth scale's
dots beside it and text or a logo in a corner, and its aspect ratio is the scanner's, not the
simulator's. A network trained on frames filled edge to edge meets black margins, marks and a
squeezed anatomy in every real image. This transform, part of the `aug` regime, shrinks the
frame (both axes on their own: the aspect ratio changes) into a random place of a black
canvas of the network's size, and may draw depth dots and text blocks in the margins; the
label map follows the image and the margins are background.
"""

from __future__ import annotations

from dataclasses import dataclass

import cv2
import numpy as np

from resus.segmentation.presets import AugmentationConfig

DOT_SPACING_FRACTION = 0.1
"""Depth dots every tenth of the imaged height (a 1 cm scale on a 10 cm-class canvas)."""
TEXT_BLOCKS = (2, 6)
"""How many text-like blocks a corner's annotation has (fewest, most + 1)."""


def random_window(
    rng: np.random.Generator, shape: tuple[int, ...], height: int, width: int
) -> tuple[slice, slice]:
    """A `height` x `width` window at a uniformly drawn place inside an image of `shape`."""
    top = int(rng.integers(0, shape[0] - height + 1))
    left = int(rng.integers(0, shape[1] - width + 1))
    return slice(top, top + height), slice(left, left + width)


@dataclass
class ExportFraming:
    """`framing(image=, mask=) -> {"image", "mask"}` on (S, S) uint8 arrays, drawing from `rng`."""

    config: AugmentationConfig
    rng: np.random.Generator

    def __call__(self, *, image: np.ndarray, mask: np.ndarray) -> dict[str, np.ndarray]:
        config = self.config
        if self.rng.random() >= config.framing_p:
            return {"image": image, "mask": mask}
        rows, cols = image.shape
        height = max(2, round(rows * self.rng.uniform(*config.framing_height)))
        width = max(2, round(cols * self.rng.uniform(*config.framing_width)))
        inside = random_window(self.rng, image.shape, height, width)
        canvas = np.zeros_like(image)
        labels = np.zeros_like(mask)
        canvas[inside] = cv2.resize(image, (width, height), interpolation=cv2.INTER_AREA)
        labels[inside] = cv2.resize(mask, (width, height), interpolation=cv2.INTER_NEAREST)
        if self.rng.random() < config.framing_marks_p:
            self._depth_dots(canvas, inside)
            self._text(canvas, inside)
        return {"image": canvas, "mask": labels}

    def _depth_dots(self, canvas: np.ndarray, inside: tuple[slice, slice]) -> None:
        """Bright dots down one side of the imaged area, in the margin when there is one."""
        rows, columns = inside
        left_margin, right_margin = columns.start, canvas.shape[1] - columns.stop
        if max(left_margin, right_margin) >= 2:
            column = columns.start - 2 if left_margin >= right_margin else columns.stop + 1
        else:
            column = columns.stop - 2  # no margin: scanners draw the scale over the image
        step = max(2, round(DOT_SPACING_FRACTION * (rows.stop - rows.start)))
        grey = int(self.rng.integers(150, 256))
        for row in range(rows.start + step, rows.stop, step):
            canvas[row : row + 1, max(0, column) : column + 2] = grey

    def _text(self, canvas: np.ndarray, inside: tuple[slice, slice]) -> None:
        """A few small bright blocks in the top margin's left or right corner (preset name,
        depth, frequency, a logo), or over the image's corner when there is no top margin."""
        band = max(3, inside[0].start)
        size = canvas.shape[1]
        on_left = self.rng.random() < 0.5
        x = int(self.rng.integers(1, max(2, size // 8)))
        for _ in range(int(self.rng.integers(*TEXT_BLOCKS))):
            height = int(self.rng.integers(1, max(2, min(band, size // 20) + 1)))
            width = int(self.rng.integers(2, max(3, size // 10)))
            y = int(self.rng.integers(0, max(1, band - height)))
            start = x if on_left else size - x - width
            canvas[y : y + height, max(0, start) : max(0, start) + width] = int(
                self.rng.integers(120, 256)
            )
            x += width + int(self.rng.integers(1, 4))
