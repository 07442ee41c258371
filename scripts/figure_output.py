"""What the figure scripts share: a B-mode panel with its label outlines, and writing a figure.

The scripts run as `python scripts/NAME.py`, which puts this folder on the import path.
"""

from __future__ import annotations

from pathlib import Path

import numpy as np
from matplotlib.axes import Axes
from matplotlib.figure import Figure


def outlined_bmode(
    axis: Axes, image: np.ndarray, labels: np.ndarray, title: str, aspect: str = "equal"
) -> None:
    """`image` in grey on 0-255 with every labelled structure outlined in yellow, titled,
    without axes (`aspect` "auto" fills the panel)."""
    axis.imshow(image, cmap="gray", vmin=0, vmax=255, aspect=aspect)
    axis.contour(labels > 0, [0.5], colors="yellow", linewidths=0.6)
    axis.set_title(title, fontsize=9)
    axis.axis("off")


def save_figure(figure: Figure, path: Path, dpi: int) -> None:
    """Lay `figure` out, write it to `path` (making its folder) and say where."""
    figure.tight_layout()
    path.parent.mkdir(parents=True, exist_ok=True)
    figure.savefig(path, dpi=dpi)
    print(f"wrote {path}")
