"""A contact sheet: a PNG of evenly chosen frames of a sweep, labels overlaid.

Artery red, vein blue (other classes from a qualitative palette), semi-transparent over the
B-mode image; each tile names its frame index and its time since the first frame.
"""

from __future__ import annotations

import math
from pathlib import Path
from typing import Protocol

import numpy as np
from matplotlib import colormaps
from matplotlib.backends.backend_agg import FigureCanvasAgg
from matplotlib.figure import Figure

from resus.sweep.io import file_errors
from resus.sweep.model import SweepFrame

LABEL_COLOURS: dict[str, tuple[float, float, float]] = {
    "artery": (1.0, 0.0, 0.0),
    "vein": (0.0, 0.3, 1.0),
}
OVERLAY_ALPHA = 0.45
TILE_WIDTH_INCHES = 3.0


class FrameSource(Protocol):
    """A `Sweep` or an open `SweepReader`: frames by index, and the names of the labels."""

    label_names: tuple[str, ...]

    def __len__(self) -> int: ...

    def frame(self, index: int) -> SweepFrame: ...


def evenly_chosen(total: int, count: int) -> np.ndarray:
    """Up to `count` distinct frame indices spread evenly from the first to the last."""
    return np.unique(np.linspace(0, total - 1, min(count, total)).round().astype(int))


def label_overlay(label: np.ndarray, label_names: tuple[str, ...]) -> np.ndarray:
    """(H, W, 4) RGBA image: each non-background class in its colour, background clear."""
    palette = colormaps["tab10"]
    colours = np.zeros((len(label_names), 4))
    for value, name in enumerate(label_names[1:], start=1):
        colours[value] = (*LABEL_COLOURS.get(name, palette(value % 10)[:3]), OVERLAY_ALPHA)
    return colours[label]


def save_contact_sheet(sweep: FrameSource, path: str | Path, count: int = 12) -> np.ndarray:
    """Draw `count` evenly chosen frames to the PNG `path`; returns the frame indices shown."""
    path = Path(path)
    indices = evenly_chosen(len(sweep), count)
    first_time = sweep.frame(0).timestamp
    columns = min(4, len(indices))
    rows = math.ceil(len(indices) / columns)
    tiles = [sweep.frame(int(index)) for index in indices]
    height, width = tiles[0].image.shape
    tile_height = TILE_WIDTH_INCHES * height / width
    figure = Figure(figsize=(columns * TILE_WIDTH_INCHES, rows * (tile_height + 0.3)))
    FigureCanvasAgg(figure)
    axes = figure.subplots(rows, columns, squeeze=False)
    for ax in axes.ravel():
        ax.set_axis_off()
    for ax, frame in zip(axes.ravel(), tiles, strict=False):
        ax.imshow(frame.image, cmap="gray", vmin=0, vmax=255, interpolation="nearest")
        if frame.label is not None:
            ax.imshow(label_overlay(frame.label, sweep.label_names), interpolation="nearest")
        ax.set_title(f"#{frame.index}   t = {frame.timestamp - first_time:.2f} s", fontsize=9)
    figure.tight_layout()
    with file_errors(path, "writing the preview"):
        figure.savefig(path, format="png", dpi=100)
    return indices
