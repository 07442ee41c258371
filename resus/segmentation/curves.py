"""Training curves as a PNG: losses on the left, validation IoU on the right."""

from __future__ import annotations

from collections.abc import Sequence
from pathlib import Path
from typing import TYPE_CHECKING

from resus.segmentation.metrics import IOU_METRICS

if TYPE_CHECKING:  # the curves need matplotlib only, not torch
    from resus.segmentation.averaging import WeightAverageRecord
    from resus.segmentation.train import EpochRecord


def plot_training_curves(
    history: Sequence[EpochRecord],
    best_epoch: int,
    path: Path,
    title: str = "",
    averaged: WeightAverageRecord | None = None,
) -> None:
    """Train/validation loss and validation IoU (artery, vein, mean) per epoch; the best
    epoch marked, or the epochs whose weights were `averaged` shaded."""
    from matplotlib.figure import Figure

    epochs = [record.epoch for record in history]
    figure = Figure(figsize=(10, 4))
    losses, ious = figure.subplots(1, 2)
    losses.plot(epochs, [r.train_loss for r in history], "o-", label="train")
    losses.plot(epochs, [r.validation_loss for r in history], "o-", label="validation")
    losses.set(xlabel="epoch", ylabel="loss", title="loss")
    for name in IOU_METRICS:
        values = [r.validation_iou.to_dict()[name] for r in history]
        ious.plot(epochs, values, "o-", label=name)
    ious.set(xlabel="epoch", ylabel="IoU", title="validation IoU", ylim=(0, 1))
    for axes in (losses, ious):
        if averaged is None:
            axes.axvline(best_epoch, color="grey", linestyle="--", label="best epoch")
        else:
            window = (averaged.first_epoch - 0.5, averaged.last_epoch + 0.5)
            axes.axvspan(*window, color="grey", alpha=0.2, label="weights averaged")
        axes.legend()
        axes.grid(alpha=0.3)
    figure.suptitle(title)
    figure.tight_layout()
    path = Path(path)
    path.parent.mkdir(parents=True, exist_ok=True)
    figure.savefig(path, dpi=100)
