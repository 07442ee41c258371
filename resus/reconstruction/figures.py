"""Pictures of a reconstructed volume: three orthogonal slices, drawn to scale, labels over them."""

from __future__ import annotations

from pathlib import Path

import numpy as np

from resus.errors import ResusError
from resus.reconstruction.grid import VolumeGrid
from sim.labels import label_overlay

MM = 1e3
LABEL_ALPHA = 0.45
"""Opacity of the label overlay."""


def save_slices_png(
    path: str | Path,
    volume: np.ndarray,
    grid: VolumeGrid,
    labels: np.ndarray | None = None,
    centre: tuple[int, int, int] | None = None,
    title: str = "",
) -> Path:
    """PNG of the three index-orthogonal slices through `centre` (default: the middle voxel),
    drawn to scale, with labels as coloured overlays when given."""
    from matplotlib.figure import Figure

    path = Path(path)
    if path.suffix.lower() != ".png":
        raise ResusError("slice pictures must end in .png", path)
    centre = centre or (grid.shape[0] // 2, grid.shape[1] // 2, grid.shape[2] // 2)
    spacing = grid.spacing * MM
    views = [(2, 0, 1), (1, 0, 2), (0, 1, 2)]  # (fixed axis, horizontal, vertical)
    figure = Figure(figsize=(15, 5.4))
    panels = figure.subplots(1, 3)
    low, high = np.percentile(volume, [1, 99.5]) if volume.size else (0, 1)
    for panel, (fixed, across, down) in zip(panels, views, strict=True):
        index: list[slice | int] = [slice(None)] * 3
        index[fixed] = centre[fixed]
        image = volume[tuple(index)]  # indexed [across, down]
        extent = (0, grid.shape[across] * spacing[across], grid.shape[down] * spacing[down], 0)
        panel.imshow(image.T, cmap="gray", vmin=low, vmax=max(high, low + 1e-6), extent=extent)
        if labels is not None:
            label_slice = labels[tuple(index)].T
            panel.imshow(label_overlay(label_slice, LABEL_ALPHA), extent=extent)
        name = "ijk"
        panel.set_title(f"{name[fixed]} = {centre[fixed]}")
        panel.set_xlabel(f"{name[across]} (mm)")
        panel.set_ylabel(f"{name[down]} (mm)")
    figure.suptitle(title or "reconstructed volume: three orthogonal slices")
    figure.tight_layout()
    path.parent.mkdir(parents=True, exist_ok=True)
    figure.savefig(path, dpi=90)
    return path
