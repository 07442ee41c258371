"""A contact sheet: a PNG of evenly chosen frames of a sweep, labels overlaid.

Artery red, vein blue (other classes from a qualitative palette), semi-transparent over the
B-mode image; each tile names its frame index and its time since the first frame.
"""

from __future__ import annotations

import math
from pathlib import Path
from typing import Protocol

from resus.indices import evenly_spaced
from resus.sweep.io import file_errors
from resus.sweep.model import SweepFrame
from sim.labels import label_overlay

OVERLAY_ALPHA = 0.45
TILE_WIDTH_INCHES = 3.0


class FrameSource(Protocol):
    """A `Sweep` or an open `SweepReader`: frames by index, and the names of the labels."""

    label_names: tuple[str, ...]

    def __len__(self) -> int: ...

    def frame(self, index: int) -> SweepFrame: ...


def save_contact_sheet(sweep: FrameSource, path: str | Path, count: int = 12) -> list[int]:
    """Draw `count` evenly chosen frames to the PNG `path`; returns the frame indices shown."""
    from matplotlib.backends.backend_agg import FigureCanvasAgg  # `import resus.sweep` stays light
    from matplotlib.figure import Figure

    path = Path(path)
    indices = evenly_spaced(len(sweep), count)
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
            ax.imshow(
                label_overlay(frame.label, OVERLAY_ALPHA, sweep.label_names),
                interpolation="nearest",
            )
        ax.set_title(f"#{frame.index}   t = {frame.timestamp - first_time:.2f} s", fontsize=9)
    figure.tight_layout()
    with file_errors(path, "writing the preview"):
        figure.savefig(path, format="png", dpi=100)
    return indices
