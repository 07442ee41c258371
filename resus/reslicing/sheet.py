"""A PNG contact sheet of reslices with their labels overlaid (artery red, vein blue)."""

from __future__ import annotations

from pathlib import Path

import numpy as np

from resus.errors import ResusError
from resus.reconstruction.io import LABEL_COLOURS
from resus.reslicing.reslice import Reslice

OVERLAY_ALPHA = 0.4


def overlay_labels(image: np.ndarray, label: np.ndarray) -> np.ndarray:
    """RGB uint8 picture: grey levels with each class > 0 tinted in its colour
    (1 artery red, 2 vein blue, as `volume_io.LABEL_COLOURS`)."""
    grey = np.repeat(image[..., None].astype(np.float32), 3, axis=-1)
    colours = LABEL_COLOURS[np.minimum(label, len(LABEL_COLOURS) - 1)].astype(np.float32)
    tinted = np.where(
        (label > 0)[..., None], (1 - OVERLAY_ALPHA) * grey + OVERLAY_ALPHA * colours, grey
    )
    return np.clip(np.rint(tinted), 0, 255).astype(np.uint8)


def save_contact_sheet(
    path: str | Path, reslices: list[Reslice], columns: int = 6, title: str = ""
) -> Path:
    """Write a grid of reslices (each titled with its angles and slice index) as a PNG."""
    import matplotlib

    matplotlib.use("Agg")
    import matplotlib.pyplot as plt

    path = Path(path)
    if path.suffix.lower() != ".png":
        raise ResusError("contact sheets must end in .png", path)
    if not reslices:
        raise ResusError("no reslices to draw: nothing passed the non-zero threshold", path)
    columns = min(columns, len(reslices))
    rows = -(-len(reslices) // columns)
    figure, panels = plt.subplots(rows, columns, figsize=(2.2 * columns, 2.4 * rows), squeeze=False)
    for panel in panels.ravel():
        panel.axis("off")
    for panel, reslice in zip(panels.ravel(), reslices, strict=False):
        panel.imshow(overlay_labels(reslice.image, reslice.label))
        angle_x, angle_y = reslice.angles_deg
        caption = f"x {angle_x:+.0f}°, y {angle_y:+.0f}°, z {reslice.slice_index}"
        panel.set_title(caption, fontsize=8)
    figure.suptitle(title or f"{len(reslices)} reslices (artery red, vein blue)")
    figure.tight_layout()
    path.parent.mkdir(parents=True, exist_ok=True)
    figure.savefig(path, dpi=80)
    plt.close(figure)
    return path


def evenly_spaced(count: int, total: int) -> list[int]:
    """Up to `count` indices spread evenly over `range(total)`, first and last included."""
    if total <= count:
        return list(range(total))
    return sorted({round(i) for i in np.linspace(0, total - 1, count)})
