"""Fitting one U-Net: seeded, early-stopped on validation loss, best epoch kept.

Adam on Dice (+ cross-entropy), one pass over the shuffled training images per epoch, then
validation loss and pooled IoU on the validation images. Training stops after `patience`
epochs without a lower validation loss, and the model returned (and checkpointed) is the one
from the best epoch; with `TrainingPreset.weight_averaging_epochs`, every epoch runs and the
model is the mean of the weights over the last ones' steps (`resus.segmentation.averaging`).
With the same seed, data and device, two runs give the same weights.
"""

from __future__ import annotations

import random
import time
from collections.abc import Callable, Mapping, Sequence
from dataclasses import asdict, dataclass
from pathlib import Path

import numpy as np
import torch
from torch import nn
from torch.utils.data import DataLoader
from tqdm import tqdm

from resus.errors import ResusError
from resus.segmentation.augment import build_augmentation
from resus.segmentation.averaging import WeightAverage, WeightAverageRecord
from resus.segmentation.checkpoint import save_checkpoint
from resus.segmentation.data import LabelledImages, SegmentationDataset
from resus.segmentation.inference import class_argmax
from resus.segmentation.losses import SegmentationLoss
from resus.segmentation.metrics import VesselIoU, intersection_and_union, no_counts
from resus.segmentation.model import build_model, resolve_device
from resus.segmentation.presets import TrainingPreset


@dataclass(frozen=True)
class EpochRecord:
    """What one epoch achieved."""

    epoch: int
    train_loss: float
    validation_loss: float
    validation_iou: VesselIoU
    images_per_second: float
    """Training throughput of the epoch (forward, backward, step and data loading)."""

    def to_dict(self) -> dict:
        return {**asdict(self), "validation_iou": self.validation_iou.to_dict()}

    @classmethod
    def from_dict(cls, data: dict) -> EpochRecord:
        """Inverse of `to_dict`."""
        return cls(**{**data, "validation_iou": VesselIoU.from_dict(data["validation_iou"])})


@dataclass(frozen=True)
class TrainingSummary:
    """How a training run went: its best epoch and the whole history (metrics files)."""

    best_epoch: int
    epochs_run: int
    stopped_early: bool
    best_validation_loss: float
    best_validation_iou: VesselIoU
    images_per_second: float
    """Mean training throughput over all epochs."""
    history: tuple[EpochRecord, ...]
    weight_average: WeightAverageRecord | None = None
    """The averaged network's steps and validation scores, when it is the model."""

    def to_dict(self) -> dict:
        """JSON-able form, as metrics.json stores it."""
        average = self.weight_average
        return {
            **asdict(self),
            "best_validation_iou": self.best_validation_iou.to_dict(),
            "history": [record.to_dict() for record in self.history],
            "weight_average": None if average is None else average.to_dict(),
        }

    @classmethod
    def from_dict(cls, data: dict) -> TrainingSummary:
        """Inverse of `to_dict` (a record from before weight averaging has no average)."""
        average = data.get("weight_average")
        return cls(
            **{
                **data,
                "best_validation_iou": VesselIoU.from_dict(data["best_validation_iou"]),
                "history": tuple(EpochRecord.from_dict(record) for record in data["history"]),
                "weight_average": None
                if average is None
                else WeightAverageRecord.from_dict(average),
            }
        )


@dataclass
class TrainingResult:
    """The model (the best epoch's, or the weight average), its checkpoint config and the
    per-epoch history."""

    model: nn.Module
    config: dict
    history: list[EpochRecord]
    best_epoch: int
    stopped_early: bool
    weight_average: WeightAverageRecord | None = None
    """Set when the model is the mean of the last epochs' weights, not the best epoch's."""

    @property
    def images_per_second(self) -> float:
        """Mean training throughput over all epochs."""
        return float(np.mean([record.images_per_second for record in self.history]))

    @property
    def best(self) -> EpochRecord:
        """The record of the best epoch (the one whose model this is, unless averaged)."""
        return self.history[self.best_epoch - 1]

    def summary(self) -> TrainingSummary:
        """The run's summary for metrics files (`.to_dict()` for JSON)."""
        return TrainingSummary(
            best_epoch=self.best_epoch,
            epochs_run=len(self.history),
            stopped_early=self.stopped_early,
            best_validation_loss=self.best.validation_loss,
            best_validation_iou=self.best.validation_iou,
            images_per_second=self.images_per_second,
            history=tuple(self.history),
            weight_average=self.weight_average,
        )


def seed_everything(seed: int) -> None:
    """Seed Python, numpy and torch (and ask cuDNN for deterministic kernels)."""
    random.seed(seed)
    np.random.seed(seed)
    torch.manual_seed(seed)
    torch.backends.cudnn.deterministic = True
    torch.backends.cudnn.benchmark = False


def train_model(
    train_sets: Sequence[LabelledImages],
    validation_sets: Sequence[LabelledImages],
    preset: TrainingPreset,
    *,
    seed: int = 0,
    device: str | torch.device | None = None,
    augment: bool = False,
    encoder_weights: Path | None = None,
    initial_state: Mapping[str, torch.Tensor] | None = None,
    checkpoint_path: Path | None = None,
    run_info: dict | None = None,
    progress: bool = True,
) -> TrainingResult:
    """Train a U-Net on `train_sets`, early-stopping on `validation_sets`.

    `augment` turns on the preset's random transforms; `encoder_weights` starts the encoder
    from a local torchvision ResNet file; `initial_state` starts the whole network from a
    trained one of the preset's architecture (fine-tuning). The best model is written to
    `checkpoint_path` (when given) each time the validation loss improves, or with weight
    averaging the averaged one at the end; `run_info` is added to its config.
    """
    device = device if isinstance(device, torch.device) else resolve_device(device)
    seed_everything(seed)
    size = preset.model.image_size
    augmentation = (
        build_augmentation(preset.augmentation, seed, preset.model.image_size) if augment else None
    )
    train_data = SegmentationDataset(train_sets, size, augmentation)
    if not sum(len(s) for s in validation_sets):
        raise ResusError("no validation images: a training subject needs at least 2 frames")
    validation_data = SegmentationDataset(validation_sets, size)
    model = build_model(preset.model, encoder_weights).to(device)
    if initial_state is not None:
        model.load_state_dict(initial_state)
    loader = DataLoader(
        train_data,
        batch_size=preset.batch_size,
        shuffle=True,
        generator=torch.Generator().manual_seed(seed),
    )
    loss_function = SegmentationLoss(preset.cross_entropy).to(device)
    optimiser = torch.optim.Adam(model.parameters(), lr=preset.learning_rate)
    schedule = learning_rate_schedule(optimiser, preset, len(loader))
    config = {
        "model": preset.model.to_dict(),
        "preset": preset.to_dict(),
        "seed": seed,
        "augment": augment,
        "encoder_weights": None if encoder_weights is None else str(encoder_weights),
        "train_subjects": list(train_data.subjects),
        "train_images": len(train_data),
        "validation_images": len(validation_data),
        **(run_info or {}),
    }

    averaged_epochs = preset.weight_averaging_epochs
    average = (
        WeightAverage(model, preset.max_epochs - averaged_epochs + 1) if averaged_epochs else None
    )
    history: list[EpochRecord] = []
    best_loss, best_epoch, best_state = float("inf"), 0, None
    with TrainingProgress(preset.max_epochs, len(loader), progress) as bar:
        for epoch in range(1, preset.max_epochs + 1):
            averaging = average if average is not None and average.covers(epoch) else None
            train_loss, seconds = train_one_epoch(
                model, loader, loss_function, optimiser, device, bar.batch_done, schedule,
                averaging,
            )  # fmt: skip
            validation_loss, validation_iou = evaluate(
                model, validation_data, loss_function, preset.evaluation_batch_size
            )
            history.append(
                EpochRecord(
                    epoch, train_loss, validation_loss, validation_iou, len(train_data) / seconds
                )
            )
            bar.epoch_done(history[-1])
            if not np.isfinite(validation_loss):
                raise ResusError(
                    f"training diverged: validation loss {validation_loss} at epoch {epoch} "
                    "(lower TrainingPreset.learning_rate)"
                )
            if validation_loss < best_loss:
                best_loss, best_epoch = validation_loss, epoch
                if average is None:
                    best_state = {
                        key: value.detach().clone() for key, value in model.state_dict().items()
                    }
                    config["best_epoch"] = epoch
                    if checkpoint_path is not None:
                        save_checkpoint(checkpoint_path, model, config)
            elif average is None and epoch - best_epoch >= preset.patience:
                break
    stopped_early = len(history) < preset.max_epochs
    if average is None:
        model.load_state_dict(best_state)
        return TrainingResult(model.eval(), config, history, best_epoch, stopped_early)
    model = average.network(loader, device)
    validation_loss, validation_iou = evaluate(
        model, validation_data, loss_function, preset.evaluation_batch_size
    )
    record = WeightAverageRecord(
        average.first_epoch, len(history), average.steps, validation_loss, validation_iou
    )
    config["weight_average"] = record.to_dict()
    if checkpoint_path is not None:
        save_checkpoint(checkpoint_path, model, config)
    return TrainingResult(model.eval(), config, history, best_epoch, stopped_early, record)


def learning_rate_schedule(
    optimiser: torch.optim.Optimizer, preset: TrainingPreset, steps_per_epoch: int
) -> torch.optim.lr_scheduler.LRScheduler | None:
    """The preset's per-step learning-rate schedule for `optimiser`, or None for a constant
    rate: with `cosine_decay`, a half cosine from the preset's rate to zero at the last step
    of `max_epochs` epochs of `steps_per_epoch` batches."""
    if not preset.cosine_decay:
        return None
    return torch.optim.lr_scheduler.CosineAnnealingLR(
        optimiser, T_max=preset.max_epochs * steps_per_epoch
    )


class TrainingProgress:
    """A bar over every training batch of a run, with its rate and the time left.

    The first batch (memory allocation, first calls of the kernels) takes many times longer
    than the others, so it is shown as a warm-up step of its own, and the batch bar starts
    after it. That bar's rate is the plain average since then (no smoothing, so the
    validation passes between epochs count too): the time left in the first epoch is not
    dominated by the warm-up, nor thrown about by the pause at each epoch's end.
    """

    def __init__(self, epochs: int, batches_per_epoch: int, enabled: bool = True) -> None:
        self._epochs = epochs
        self._total = epochs * batches_per_epoch
        self._enabled = enabled
        self._warmed_up = False
        self._bar = tqdm(total=1, desc="train warm-up", unit="batch", leave=False,
                         disable=not enabled)  # fmt: skip

    def batch_done(self) -> None:
        """Count one training batch; the first ends the warm-up."""
        self._bar.update()
        if self._warmed_up:
            return
        self._warmed_up = True
        self._bar.close()
        self._bar = tqdm(total=self._total, initial=1, desc="train", unit="batch", leave=False,
                         smoothing=0, disable=not self._enabled)  # fmt: skip

    def epoch_done(self, record: EpochRecord) -> None:
        """Show the epoch reached and its losses and validation IoU."""
        self._bar.set_postfix(
            epoch=f"{record.epoch}/{self._epochs}",
            train=f"{record.train_loss:.3f}",
            val=f"{record.validation_loss:.3f}",
            iou=f"{record.validation_iou.mean:.3f}",
        )

    def __enter__(self) -> TrainingProgress:
        return self

    def __exit__(self, *exc_info: object) -> None:
        self._bar.close()


def train_one_epoch(
    model: nn.Module,
    loader: DataLoader,
    loss_function: nn.Module,
    optimiser: torch.optim.Optimizer,
    device: torch.device,
    on_batch: Callable[[], None] | None = None,
    schedule: torch.optim.lr_scheduler.LRScheduler | None = None,
    average: WeightAverage | None = None,
) -> tuple[float, float]:
    """One pass over `loader`: (mean loss per image, seconds taken); `on_batch()` after each
    batch (a progress bar); `schedule` (if any) steps the learning rate after each batch, and
    each step's weights join `average` (if any)."""
    model.train()
    total, count = 0.0, 0
    start = time.perf_counter()
    for images, labels in loader:
        images, labels = images.to(device), labels.to(device)
        optimiser.zero_grad(set_to_none=True)
        loss = loss_function(model(images), labels)
        loss.backward()
        optimiser.step()
        if schedule is not None:
            schedule.step()
        if average is not None:
            average.add(model)
        total += loss.item() * len(images)
        count += len(images)
        if on_batch is not None:
            on_batch()
    return total / count, time.perf_counter() - start


@torch.no_grad()
def evaluate(
    model: nn.Module, dataset: SegmentationDataset, loss_function: nn.Module, batch_size: int
) -> tuple[float, VesselIoU]:
    """Mean loss per image and pooled vessel IoU of `model` on `dataset` (no augmentation)."""
    model.eval()
    device = next(model.parameters()).device
    total, counts = 0.0, no_counts()
    for images, labels in DataLoader(dataset, batch_size=batch_size):
        images, labels = images.to(device), labels.to(device)
        logits = model(images)
        total += loss_function(logits, labels).item() * len(images)
        counts += intersection_and_union(class_argmax(logits).cpu().numpy(), labels.cpu().numpy())
    return total / len(dataset), VesselIoU.from_counts(counts)
