"""The experiments' training runs as independent, resumable units.

One unit trains one model: a regime, with one seed, on an experiment's training data, scored
on its test sets (the held-out subject's frames; phantom scan B's frames, and its frames plus
reslices). A unit reads its data from the prepared scans' files, so it runs wherever the
cache is visible (a worker process, a Ray node with the cache on a shared filesystem), and
writes `checkpoint.pt`, `curves.png` and `unit.json` to a folder of its own under
`DATA/training/`, named and keyed by everything its result depends on. A rerun skips every
unit whose `unit.json` holds the same key; the seed and torch's thread count are part of the
key, so a unit gives the same result whichever engine runs it.
"""

from __future__ import annotations

import hashlib
import json
import re
from collections.abc import Sequence
from dataclasses import asdict, dataclass, field, replace
from pathlib import Path
from typing import TYPE_CHECKING

from resus.execution import Executor, Resources, UnitRecord, file_digest, run_pending
from resus.experiments.data import SubjectData
from resus.segmentation.metrics import VesselIoU
from resus.segmentation.presets import TrainingPreset

if TYPE_CHECKING:  # torch is imported only where a unit trains or a model is loaded
    import torch
    from torch import nn

    from resus.segmentation.data import LabelledImages
    from resus.segmentation.loso import Split
    from resus.segmentation.train import TrainingSummary

TRAINING_FOLDER = "training"
"""Units' folders go to DATA/training/EXPERIMENT/."""
CHECKPOINT = "checkpoint.pt"
HELD_OUT_TEST = "held-out subject"
"""The subjects experiment's one test set: the held-out subject's frames."""
PHANTOM_TESTS = ("frames", "frames + reslices")
"""The phantom experiment's test sets, both of scan B."""
PHANTOM_TEST_SUBJECT = "scan B"
"""The phantom experiment's 'held-out subject': scan B, which trains nothing."""


@dataclass(frozen=True)
class TrainingUnit:
    """One training run of an experiment, and where its outputs go."""

    experiment: str
    """"subjects" (leave-one-subject-out) or "phantom" (scan A trains, scan B tests)."""
    regime: str
    held_out: str
    """Subject id the model never sees ("default/2"), or `PHANTOM_TEST_SUBJECT`."""
    seed: int
    data: tuple[SubjectData, ...]
    """The prepared scans (for "phantom": scan A, then scan B)."""
    data_settings: tuple[dict, ...]
    """What each scan's files were made with (`stage_settings`): the data part of the key."""
    training: TrainingPreset
    device: str
    """As asked ("auto", "cpu", "cuda"); resolved where the unit runs."""
    cpus: int
    """Torch threads (and the cores the engine reserves)."""
    cache: Path
    """The data folder; the unit's own folder is under DATA/training/."""
    encoder_weights: Path | None = None
    """Encoder weights file of the imagenet regime."""
    encoder_weights_digest: str | None = field(init=False)
    """Its content (`file_digest`), read once where the unit is made: a file replaced under
    the same name is another unit."""
    folder: Path = field(init=False)
    """DATA/training/EXPERIMENT/REGIME_SUBJECT_seedN_DIGEST: readable, and unique. Named
    once, where the unit is made, so its worker writes where its record says."""

    def __post_init__(self) -> None:
        weights = self.encoder_weights
        object.__setattr__(
            self, "encoder_weights_digest", None if weights is None else file_digest(weights)
        )
        digest = hashlib.sha256(json.dumps(self.key(), sort_keys=True).encode()).hexdigest()
        subject = re.sub(r"[^A-Za-z0-9]+", "-", self.held_out).strip("-")
        name = f"{self.regime}_{subject}_seed{self.seed}_{digest[:12]}"
        folder = Path(self.cache) / TRAINING_FOLDER / self.experiment / name
        object.__setattr__(self, "folder", folder)

    def key(self) -> dict:
        """Every setting the unit's result depends on (no paths: a moved cache still counts)."""
        weights = self.encoder_weights
        return {
            "experiment": self.experiment,
            "regime": self.regime,
            "held_out": self.held_out,
            "seed": self.seed,
            "data": list(self.data_settings),
            "training": self.training.to_dict(),
            "device": self.device,
            "torch_threads": self.cpus,
            "encoder_weights": (
                None
                if weights is None
                else {"name": weights.name, "sha256": self.encoder_weights_digest}
            ),
        }

    @property
    def checkpoint(self) -> Path:
        return self.folder / CHECKPOINT

    def record(self) -> UnitRecord:
        return UnitRecord(self.folder / "unit.json", self.key(), (self.checkpoint,))


@dataclass(frozen=True)
class TrainingOutcome:
    """What a unit's unit.json holds: its scores and its training history."""

    test_iou: dict[str, VesselIoU]
    """Test set name -> pooled IoU of the best model on it."""
    validation_iou: VesselIoU
    """The best epoch's IoU on the training subjects' validation frames."""
    train_images: int
    summary: TrainingSummary
    device: str
    """The torch device it trained on ("cpu", "cuda:0")."""

    def to_dict(self) -> dict:
        return {
            **asdict(self),
            "test_iou": {name: iou.to_dict() for name, iou in self.test_iou.items()},
            "validation_iou": self.validation_iou.to_dict(),
            "summary": self.summary.to_dict(),
        }

    @classmethod
    def from_dict(cls, data: dict) -> TrainingOutcome:
        """Inverse of `to_dict` (JSON keeps every float exactly)."""
        from resus.segmentation.train import TrainingSummary

        return cls(
            **{
                **data,
                "test_iou": {
                    name: VesselIoU.from_dict(iou) for name, iou in data["test_iou"].items()
                },
                "validation_iou": VesselIoU.from_dict(data["validation_iou"]),
                "summary": TrainingSummary.from_dict(data["summary"]),
            }
        )


def relabelled(sets: Sequence[LabelledImages], subject: str) -> tuple[LabelledImages, ...]:
    """The sets with their subject id replaced (two scans of one phantom are two 'subjects')."""
    from resus.segmentation.data import LabelledImages

    return tuple(LabelledImages(s.images, s.labels, subject, s.source) for s in sets)


def phantom_images(
    data: Sequence[SubjectData],
) -> tuple[dict[str, tuple[LabelledImages, ...]], dict[str, tuple[LabelledImages, ...]]]:
    """Frames and reslices of phantom scans A and B (`data` in that order), by scan name."""
    from resus.segmentation.loaders import load_reslice_sets, load_sweep_frames

    frames, reslices = {}, {}
    for name, scan in zip("AB", data, strict=True):
        frames[name] = relabelled(load_sweep_frames([scan.sweep]), f"scan {name}")
        reslices[name] = relabelled(load_reslice_sets([scan.reslices]), f"scan {name}")
    return frames, reslices


def phantom_split(
    frames: dict[str, tuple[LabelledImages, ...]],
    reslices: dict[str, tuple[LabelledImages, ...]],
    validation_fraction: float,
) -> tuple[Split, dict[str, tuple[LabelledImages, ...]]]:
    """Scan A's frames (less a validation tail) and reslices to train on; scan B's frames,
    and its frames plus reslices, to test on."""
    from resus.segmentation.loso import Split, hold_out_tail

    train, validation = hold_out_tail(frames["A"], validation_fraction)
    split = Split(PHANTOM_TEST_SUBJECT, tuple(train), tuple(validation), reslices=reslices["A"])
    tests = dict(zip(PHANTOM_TESTS, (frames["B"], frames["B"] + reslices["B"]), strict=True))
    return split, tests


def _split_and_tests(
    unit: TrainingUnit,
) -> tuple[Split, dict[str, tuple[LabelledImages, ...]]]:
    """What `unit` trains on (a split without test frames) and what it is scored on."""
    from resus.segmentation.loaders import load_reslice_sets, load_sweep_frames
    from resus.segmentation.loso import make_split

    fraction = unit.training.validation_fraction
    if unit.experiment == "phantom":
        return phantom_split(*phantom_images(unit.data), fraction)
    frames = load_sweep_frames([d.sweep for d in unit.data])
    reslices = load_reslice_sets([d.reslices for d in unit.data])
    split = make_split(frames, reslices, unit.held_out, fraction)
    return replace(split, test=()), {HELD_OUT_TEST: split.test}


def train_unit(unit: TrainingUnit) -> dict:
    """Run one unit (in a worker): train, checkpoint, score; the outcome as a dict."""
    import torch

    from resus.segmentation.loso import pooled_iou, run_regime
    from resus.segmentation.model import resolve_device

    torch.set_num_threads(unit.cpus)
    device = resolve_device(unit.device)
    split, tests = _split_and_tests(unit)
    run = run_regime(
        split,
        unit.regime,
        unit.training,
        seed=unit.seed,
        device=device,
        encoder_weights=unit.encoder_weights,
        out_dir=unit.folder,
        progress=False,
    )
    model = run.training.model
    outcome = TrainingOutcome(
        {name: pooled_iou(model, sets, unit.training) for name, sets in tests.items()},
        run.training.best.validation_iou,
        run.training.config["train_images"],
        run.training.summary(),
        str(device),
    )
    return outcome.to_dict()


def run_training_units(
    executor: Executor,
    units: Sequence[TrainingUnit],
    resources: Resources,
    progress: bool = True,
) -> list[TrainingOutcome]:
    """Every unit's outcome, in order; only units without a finished record are trained."""
    results = run_pending(
        executor,
        train_unit,
        units,
        "training",
        "run",
        resources,
        progress,
    )
    return [TrainingOutcome.from_dict(result) for result in results]


def load_unit_model(unit: TrainingUnit, device: str | torch.device = "cpu") -> nn.Module:
    """The best model a finished unit checkpointed."""
    from resus.segmentation.checkpoint import load_checkpoint

    model, _ = load_checkpoint(unit.checkpoint, device)
    return model
