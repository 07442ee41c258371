"""The label vocabulary: class values, names and display colours, defined once for everything.

A label image holds one class per pixel: 0 background, 1 artery, 2 vein (design.md). Sweeps,
label volumes and reslice datasets store the names beside the values; every figure and rerun
view colours the classes the same way: artery red, vein blue.
"""

from __future__ import annotations

import numpy as np

BACKGROUND = 0
ARTERY = 1
VEIN = 2

LABEL_NAMES: tuple[str, ...] = ("background", "artery", "vein")
"""Class names indexed by label value, as Sweeps, volumes and reslice datasets store them."""

VESSEL_CLASSES: dict[str, int] = {"artery": ARTERY, "vein": VEIN}
"""The vessel classes by name (the classes a segmentation is scored on)."""

LABEL_COLOURS: dict[str, tuple[int, int, int]] = {
    "background": (0, 0, 0),
    "artery": (230, 40, 40),
    "vein": (40, 90, 240),
}
"""8-bit RGB display colour of each named class."""

EXTRA_COLOURS: tuple[tuple[int, int, int], ...] = ((40, 200, 80), (240, 200, 40), (160, 60, 200))
"""Colours for classes beyond the vocabulary, in order of their label value."""


def label_colour(value: int, name: str | None = None) -> tuple[int, int, int]:
    """8-bit RGB colour of class `value` (named `name`): the vocabulary's, else a fixed extra."""
    if name is None and 0 <= value < len(LABEL_NAMES):
        name = LABEL_NAMES[value]
    if name in LABEL_COLOURS:
        return LABEL_COLOURS[name]
    return EXTRA_COLOURS[(value - len(LABEL_NAMES)) % len(EXTRA_COLOURS)]


def label_colour_unit(value: int, name: str | None = None) -> tuple[float, float, float]:
    """`label_colour` scaled to [0, 1], as matplotlib takes colours."""
    red, green, blue = label_colour(value, name)
    return red / 255.0, green / 255.0, blue / 255.0


def label_palette(count: int) -> np.ndarray:
    """(count, 3) uint8 colours of label values 0..count-1, to index with a label image."""
    return np.array([label_colour(value) for value in range(count)], dtype=np.uint8).reshape(-1, 3)


def label_overlay(
    label: np.ndarray, alpha: float, label_names: tuple[str, ...] = LABEL_NAMES
) -> np.ndarray:
    """(H, W, 4) float RGBA in [0, 1]: each class > 0 in its colour at `alpha`, background clear
    (to draw over a grey image with matplotlib)."""
    label = np.asarray(label)
    count = max(len(label_names), int(label.max(initial=0)) + 1)
    names = [*label_names, *([None] * (count - len(label_names)))]
    colours = np.array(
        [(*label_colour_unit(v, n), alpha if v else 0.0) for v, n in enumerate(names)]
    )
    return colours[label]


def tint_labels(image: np.ndarray, label: np.ndarray | None, alpha: float) -> np.ndarray:
    """(H, W, 3) uint8 RGB of a grey image with each class > 0 blended in its colour at `alpha`."""
    rgb = np.repeat(np.asarray(image, dtype=np.uint8)[..., None], 3, axis=-1)
    if label is None or not np.any(label):
        return rgb
    label = np.asarray(label)
    colours = label_palette(int(label.max()) + 1).astype(np.float32)
    tinted = (1 - alpha) * rgb + alpha * colours[label]
    return np.where((label > 0)[..., None], np.clip(np.rint(tinted), 0, 255), rgb).astype(np.uint8)
