"""Training regimes and leave-one-subject-out (LOSO) evaluation.

The four regimes of the paper:

- `us`: ultrasound frames only, encoder from random weights;
- `imagenet`: frames only, encoder from local ImageNet ResNet weights (not run without them);
- `aug`: frames only, with random flips, noise, sharpening and brightness/contrast;
- `resus`: frames plus reslices of the training subjects' volumes (not run without reslices).

For each subject in turn, a model is trained on the other subjects and scored on that
subject's frames. The test subject's reslices are cut out by subject id in `make_split`, and
`Split` refuses any training or validation set of the test subject, so a reslice of the test
volume can never reach training. Regimes are compared by paired t-tests across subjects.
"""

from __future__ import annotations

import itertools
from collections.abc import Callable, Sequence
from dataclasses import dataclass, field
from pathlib import Path

import numpy as np
import torch
from tqdm import tqdm

from resus.errors import ResusError
from resus.segmentation.curves import plot_training_curves
from resus.segmentation.data import LabelledImages
from resus.segmentation.inference import predict
from resus.segmentation.metrics import (
    IOU_METRICS,
    VesselIoU,
    intersection_and_union,
    no_counts,
)
from resus.segmentation.model import resolve_device
from resus.segmentation.presets import TrainingPreset
from resus.segmentation.stats import PairedTest, paired_t_test
from resus.segmentation.train import TrainingResult, train_model

REGIMES: tuple[str, ...] = ("us", "imagenet", "aug", "resus")


@dataclass(frozen=True)
class Split:
    """Images for one training run; `test_subject` None means train on every subject."""

    test_subject: str | None
    train: tuple[LabelledImages, ...]
    validation: tuple[LabelledImages, ...]
    test: tuple[LabelledImages, ...] = ()
    reslices: tuple[LabelledImages, ...] = ()
    """Reslices of the training subjects' volumes (used by the `resus` regime only)."""

    def __post_init__(self) -> None:
        roles = (
            ("training", self.train),
            ("validation", self.validation),
            ("reslices", self.reslices),
        )
        for role, sets in roles:
            leaked = [s.source or s.subject for s in sets if s.subject == self.test_subject]
            if leaked:
                raise ResusError(
                    f"test subject {self.test_subject!r} must not be in {role}: {leaked[0]}"
                )
        strangers = [s.subject for s in self.test if s.subject != self.test_subject]
        if strangers:
            raise ResusError(f"test set holds subject {strangers[0]!r}, not {self.test_subject!r}")


def subjects_of(frames: Sequence[LabelledImages]) -> list[str]:
    """Sorted subject ids of frame sets."""
    return sorted({s.subject for s in frames})


def hold_out_tail(
    sets: Sequence[LabelledImages], fraction: float
) -> tuple[list[LabelledImages], list[LabelledImages]]:
    """Split every set into (first part for training, last `fraction` for validation).

    A set of one image stays whole in training. The validation block is contiguous, so
    neighbouring sweep frames, which look alike, seldom fall on both sides.
    """
    train, validation = [], []
    for images in sets:
        held = min(max(1, round(fraction * len(images))), len(images) - 1)
        if held > 0:
            validation.append(images.take(slice(len(images) - held, None)))
        train.append(images.take(slice(0, len(images) - held)))
    return train, validation


def make_split(
    frames: Sequence[LabelledImages],
    reslices: Sequence[LabelledImages],
    test_subject: str | None,
    validation_fraction: float,
) -> Split:
    """Train on the other subjects' frames (and reslices), test on `test_subject`'s frames.

    Validation is the tail of each training frame set. Reslices are kept only when their
    subject id is not the test subject's, and only ever for training.
    """
    subjects = subjects_of(frames)
    if test_subject is not None and test_subject not in subjects:
        raise ResusError(f"test subject {test_subject!r} has no frames; subjects: {subjects}")
    orphans = sorted({s.subject for s in reslices} - set(subjects))
    if orphans:
        raise ResusError(
            f"reslices of subject {orphans[0]!r} match no frames; subjects: {subjects}"
        )
    train, validation = hold_out_tail(
        [s for s in frames if s.subject != test_subject], validation_fraction
    )
    test = tuple(s for s in frames if s.subject == test_subject)
    kept_reslices = tuple(s for s in reslices if s.subject != test_subject)
    return Split(test_subject, tuple(train), tuple(validation), test, kept_reslices)


def unavailable_reason(
    regime: str, reslices: Sequence[LabelledImages], encoder_weights: Path | None
) -> str | None:
    """Why `regime` cannot run with these inputs, or None when it can."""
    if regime not in REGIMES:
        raise ResusError(f"unknown regime {regime!r}; choose one of {', '.join(REGIMES)}")
    if regime == "imagenet" and encoder_weights is None:
        return "no ImageNet encoder weights file given (encoder_weights is None)"
    if regime == "resus" and not reslices:
        return "no reslices given"
    return None


@dataclass
class RegimeRun:
    """One trained model and, when the split has a test subject, its test IoU."""

    regime: str
    split: Split
    training: TrainingResult
    test_iou: VesselIoU | None


def run_regime(
    split: Split,
    regime: str,
    preset: TrainingPreset,
    *,
    seed: int = 0,
    device: str | torch.device | None = None,
    encoder_weights: Path | None = None,
    out_dir: Path | None = None,
    progress: bool = True,
) -> RegimeRun:
    """Train `regime` on `split` and score it on the split's test frames at their own size.

    With `out_dir`, the best checkpoint (`checkpoint.pt`) and curves (`curves.png`) go there.
    """
    reason = unavailable_reason(regime, split.reslices, encoder_weights)
    if reason is not None:
        raise ResusError(f"regime {regime} cannot run: {reason}")
    training = train_model(
        split.train + (split.reslices if regime == "resus" else ()),
        split.validation,
        preset,
        seed=seed,
        device=device,
        augment=regime == "aug",
        encoder_weights=encoder_weights if regime == "imagenet" else None,
        checkpoint_path=None if out_dir is None else Path(out_dir) / "checkpoint.pt",
        run_info={"regime": regime, "test_subject": split.test_subject},
        progress=progress,
    )
    if out_dir is not None:
        title = f"{regime}, test subject {split.test_subject}"
        plot_training_curves(
            training.history,
            training.best_epoch,
            Path(out_dir) / "curves.png",
            title,
            training.weight_average,
        )
    test_iou = pooled_iou(training.model, split.test, preset) if split.test else None
    return RegimeRun(regime, split, training, test_iou)


def pooled_iou(
    model: torch.nn.Module, sets: Sequence[LabelledImages], preset: TrainingPreset
) -> VesselIoU:
    """Vessel IoU of `model` over every image of `sets` (counts summed, then divided)."""
    counts = no_counts()
    for images in sets:
        predicted = predict(
            model,
            images.images,
            image_size=preset.model.image_size,
            batch_size=preset.evaluation_batch_size,
        )
        counts += intersection_and_union(predicted, images.labels)
    return VesselIoU.from_counts(counts)


@dataclass
class LosoResult:
    """IoU per regime and subject, the regimes that did not run, and paired t-tests."""

    subjects: list[str]
    iou: dict[str, dict[str, VesselIoU]] = field(default_factory=dict)
    not_run: dict[str, str] = field(default_factory=dict)
    comparisons: dict[tuple[str, str, str], PairedTest] = field(default_factory=dict)
    """(regime a, regime b, metric) -> paired t-test of a - b across subjects."""

    def admit(
        self,
        regimes: Sequence[str],
        reslices: Sequence[LabelledImages],
        encoder_weights: Path | None,
    ) -> list[str]:
        """The regimes that can run with these inputs; the others go to `not_run`, with why."""
        runnable = []
        for regime in regimes:
            reason = unavailable_reason(regime, reslices, encoder_weights)
            if reason is None:
                runnable.append(regime)
            else:
                self.not_run[regime] = reason
        return runnable

    def compare(self) -> None:
        """Paired t-tests of every pair of regimes that ran, on artery, vein and mean IoU."""
        self.comparisons = {}
        for a, b in itertools.combinations(self.iou, 2):
            for metric in IOU_METRICS:
                scores_a = [self.iou[a][s].to_dict()[metric] for s in self.subjects]
                scores_b = [self.iou[b][s].to_dict()[metric] for s in self.subjects]
                self.comparisons[(a, b, metric)] = paired_t_test(scores_a, scores_b)

    def to_dict(self) -> dict:
        """JSON-able form: per-regime IoU tables with means over subjects, and the tests."""
        regimes = {}
        for regime, per_subject in self.iou.items():
            table = {subject: iou.to_dict() for subject, iou in per_subject.items()}
            average = {
                metric: float(np.mean([row[metric] for row in table.values()]))
                for metric in IOU_METRICS
            }
            regimes[regime] = {"status": "run", "iou": table, "mean_over_subjects": average}
        for regime, reason in self.not_run.items():
            regimes[regime] = {"status": "not run", "reason": reason}
        tests = [
            {"a": a, "b": b, "metric": metric, **test.to_dict()}
            for (a, b, metric), test in self.comparisons.items()
        ]
        return {"subjects": self.subjects, "regimes": regimes, "paired_t_tests": tests}

    def markdown(self) -> str:
        """Mean vessel IoU per subject (rows) and regime (columns), then the mean-IoU tests."""
        regimes = list(self.iou)
        lines = [
            "| subject | " + " | ".join(regimes) + " |",
            "| --- |" + " --- |" * len(regimes),
        ]
        for subject in self.subjects:
            cells = [f"{self.iou[r][subject].mean:.3f}" for r in regimes]
            lines.append(f"| {subject} | " + " | ".join(cells) + " |")
        for (a, b, metric), test in self.comparisons.items():
            if metric == "mean":
                p = "n/a (" + test.note + ")" if test.p_value is None else f"{test.p_value:.3g}"
                lines.append(
                    f"\n{a} vs {b}: mean IoU difference {test.mean_difference:+.3f}, p = {p}"
                )
        for regime, reason in self.not_run.items():
            lines.append(f"\n{regime}: not run ({reason})")
        return "\n".join(lines)


def run_loso(
    frames: Sequence[LabelledImages],
    reslices: Sequence[LabelledImages],
    regimes: Sequence[str],
    preset: TrainingPreset,
    *,
    seed: int = 0,
    device: str | torch.device | None = None,
    encoder_weights: Path | None = None,
    out_dir: Path | None = None,
    progress: bool = True,
    on_run: Callable[[str, str, RegimeRun], None] | None = None,
) -> LosoResult:
    """Leave-one-subject-out over the subjects of `frames`, for each regime that can run.

    Every regime sees the same splits and seed, so per-subject scores pair up for the t-tests.
    Checkpoints and curves go to `out_dir/REGIME/SUBJECT/` when `out_dir` is given;
    `on_run(regime, subject, run)` sees each trained run (e.g. to keep curves or predictions).
    """
    subjects = subjects_of(frames)
    if len(subjects) < 2:
        raise ResusError(f"leave-one-subject-out needs at least 2 subjects, got {subjects}")
    device = resolve_device(device) if not isinstance(device, torch.device) else device
    result = LosoResult(subjects)
    runnable = result.admit(regimes, reslices, encoder_weights)
    splits = {s: make_split(frames, reslices, s, preset.validation_fraction) for s in subjects}
    folds = list(itertools.product(runnable, subjects))
    for regime, subject in tqdm(folds, desc="loso", unit="run", disable=not progress):
        run = run_regime(
            splits[subject],
            regime,
            preset,
            seed=seed,
            device=device,
            encoder_weights=encoder_weights,
            out_dir=None if out_dir is None else Path(out_dir) / regime / subject,
            progress=progress,
        )
        # the split tests a subject of `frames`, so it has test frames and a test IoU
        assert run.test_iou is not None
        result.iou.setdefault(regime, {})[subject] = run.test_iou
        if on_run is not None:
            on_run(regime, subject, run)
    result.compare()
    return result
