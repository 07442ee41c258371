"""The few-label curve: real labels fine-tuning a U-Net from simulation or from scratch.

For each of `splits` seeded random splits of the real images into a pool of
`max(label_counts)` images and a test set (all the others), a U-Net is fine-tuned on the first
k images of the pool, once from the simulation-only weights and once from random weights, and
scored on the split's test set. Every k of a split shares one test set, so the curve compares
like with like. From simulation, k = 0 is the simulation-only model itself (member 0, the
network the fine-tunings start from); from scratch, k = 0 has nothing to learn from and is not
reported.

Every run of a fine-tuning sees the same number of images (`fine_tune_epochs` x
`fine_tune_epoch_images`: the k images repeated, each repeat augmented afresh), so a small k is
not also a short training, and from either start the same, long enough for a network from
random weights to learn (see `Sim2RealSettings.fine_tune_epochs`). A fine-tuning from
simulation spends part of that budget on simulated frames (`rehearsal_images` a epoch, in
fewer epochs): rehearsal, so that a few real labels refine what simulation taught instead of
overwriting it. With k labels there are none to spare for validation: the best epoch is
chosen on the k training images themselves, and the test images are never looked at before
scoring.
"""

from __future__ import annotations

import dataclasses
import math
from collections.abc import Sequence
from contextlib import ExitStack
from dataclasses import dataclass
from pathlib import Path
from typing import TYPE_CHECKING

import numpy as np
import torch

from resus.errors import ResusError
from resus.execution import Executor
from resus.experiments.sim2real.settings import Sim2RealSettings
from resus.segmentation.data import LabelledImages
from resus.segmentation.evaluate import Evaluation, score_labels
from resus.segmentation.folders import FolderImages
from resus.segmentation.presets import TrainingPreset
from resus.segmentation.trained_model import Segmenter, TrainedModel

if TYPE_CHECKING:
    from resus.experiments.sim2real.units import SimOnlyUnit
    from resus.sweep import SweepFrame

FROM_SIMULATION, FROM_SCRATCH = "simulation", "scratch"
INITIALISATIONS = (FROM_SIMULATION, FROM_SCRATCH)
"""Where a fine-tuning starts: the simulation-only weights, or random ones."""
REAL_SUBJECT = "real"
"""Subject id of the real images when they train (fine-tuning only)."""
REHEARSAL_STREAM = 0x4EAE
"""Mixed into a fine-tuning's seed to draw its rehearsal frames (`rehearsal_frames`)."""


@dataclass(frozen=True)
class RealSplit:
    """One random split of the real images: a fine-tuning pool and a test set."""

    index: int
    pool: tuple[int, ...]
    """Indices of the pool; a fine-tuning with k labels takes its first k."""
    test: tuple[int, ...]


def real_splits(count: int, settings: Sim2RealSettings, seed: int) -> list[RealSplit]:
    """`settings.splits` seeded permutations of `count` real images, each cut into the pool
    (the largest k) and the test set (the rest); too few images is a ResusError."""
    needed = settings.pool_size + settings.minimum_test_images
    if count < needed:
        raise ResusError(
            f"{count} real images: the few-label curve needs {settings.pool_size} for the "
            f"largest k and {settings.minimum_test_images} to test on (label_counts, "
            "minimum_test_images)"
        )
    splits = []
    for index in range(settings.splits):
        order = np.random.default_rng([seed, index, 0x5112]).permutation(count)
        pool, test = order[: settings.pool_size], order[settings.pool_size :]
        splits.append(RealSplit(index, tuple(map(int, pool)), tuple(sorted(map(int, test)))))
    return splits


@dataclass(frozen=True)
class CurvePoint:
    """One fine-tuning of the curve: where it started, how many labels, which split, and its
    pooled vessel IoU and Dice on that split's test set."""

    initialisation: str
    labels: int
    split: int
    iou: float
    dice: float


@dataclass(frozen=True)
class Spread:
    """Mean and sample standard deviation over splits (0 for one split)."""

    mean: float
    std: float
    runs: int

    @classmethod
    def of(cls, values: Sequence[float]) -> Spread:
        values = [float(v) for v in values]
        std = float(np.std(values, ddof=1)) if len(values) > 1 else 0.0
        return cls(float(np.mean(values)), std, len(values))


def curve_summary(points: Sequence[CurvePoint]) -> dict[str, dict[int, Spread]]:
    """IoU over splits per initialisation and k."""
    summary: dict[str, dict[int, Spread]] = {}
    for initialisation in INITIALISATIONS:
        mine = [p for p in points if p.initialisation == initialisation]
        summary[initialisation] = {
            k: Spread.of([p.iou for p in mine if p.labels == k])
            for k in sorted({p.labels for p in mine})
        }
    return summary


def vessel_scores(model: Segmenter, real: FolderImages) -> tuple[Evaluation, list[np.ndarray]]:
    """`model` on every image of `real`, scored as one vessel class (artery or vein), and
    its labels."""
    predicted = model.predict(list(real.images))
    return score_labels(real.names, predicted, real.labels, separates_classes=False), predicted


def example_indices(images: FolderImages, count: int) -> list[int]:
    """`count` evenly chosen images that show a vessel (all of them when fewer)."""
    from resus.indices import evenly_spaced

    with_vessels = [i for i, labels in enumerate(images.labels) if labels.any()]
    return [with_vessels[i] for i in evenly_spaced(len(with_vessels), count)]


def repeated_to(sets: Sequence[LabelledImages], count: int) -> list[LabelledImages]:
    """`sets` repeated whole until they hold at least `count` images (once at least)."""
    total = sum(len(s) for s in sets)
    return list(sets) * max(1, math.ceil(count / total))


def fine_tune(
    real: FolderImages,
    initial: TrainedModel | None,
    preset: TrainingPreset,
    settings: Sim2RealSettings,
    *,
    seed: int,
    device: torch.device,
    rehearsal: Sequence[LabelledImages] = (),
) -> TrainedModel:
    """A U-Net trained on the labelled real images `real`, starting from `initial`'s weights
    (None: random ones), for the settings' fixed budget of images; `rehearsal` (simulated
    frames, `rehearsal_frames`) joins every epoch."""
    from resus.segmentation.train import train_model

    sets = real.labelled_sets(REAL_SUBJECT)
    epochs = settings.fine_tuning_epochs(bool(rehearsal))
    budget = dataclasses.replace(preset, max_epochs=epochs, patience=epochs)
    result = train_model(
        repeated_to(sets, settings.fine_tune_epoch_images) + list(rehearsal),
        sets,  # no labels to spare: the epoch is chosen on the training images (module doc)
        budget,
        seed=seed,
        device=device,
        augment=settings.regime == "aug",
        initial_state=None if initial is None else initial.network.state_dict(),
        run_info={"fine_tuned_from": None if initial is None else str(initial.path)},
        progress=False,
    )
    return TrainedModel(result.model, result.config)


def rehearsal_frames(
    sweeps: Sequence[Path], count: int, seed: int, one_vessel_class: bool
) -> list[LabelledImages]:
    """`count` labelled frames drawn without replacement (seeded) from all of `sweeps`'
    frames, one set per frame size; with `one_vessel_class` every vessel is label 1, as in
    masks that do not tell artery from vein. Only the frames drawn are read from disk."""
    from resus.segmentation.loaders import check_label_names, expand_paths
    from resus.sweep.io import SweepReader

    with ExitStack() as stack:
        readers = [stack.enter_context(SweepReader(p)) for p in expand_paths(sweeps, "sweep")]
        for reader in readers:
            if not reader.has_labels:
                raise ResusError(
                    "sweep has no labels: rehearsal needs labelled frames", reader.path
                )
            check_label_names(reader.label_names, reader.path)
        frames = [(r, i) for r, reader in enumerate(readers) for i in range(len(reader))]
        if count > len(frames):
            raise ResusError(
                f"Sim2RealSettings.rehearsal_images is {count}, but the sweeps hold "
                f"{len(frames)} frames"
            )
        rng = np.random.default_rng([seed, REHEARSAL_STREAM])
        by_shape: dict[tuple[int, ...], list[SweepFrame]] = {}
        for j in sorted(rng.choice(len(frames), count, replace=False)):
            r, i = frames[j]
            by_shape.setdefault(readers[r].frame_shape, []).append(readers[r].frame(i))
    rehearsal = []
    for picked in by_shape.values():
        labels = np.stack([frame.label for frame in picked])
        rehearsal.append(
            LabelledImages(
                np.stack([frame.image for frame in picked]),
                (labels > 0).astype(np.uint8) if one_vessel_class else labels,
                "simulated",
                "rehearsal",
            )
        )
    return rehearsal


def few_label_curve(
    real: FolderImages,
    sim_only: TrainedModel,
    trained_by: SimOnlyUnit,
    settings: Sim2RealSettings,
    out: Path,
    *,
    seed: int,
    device: str,
    executor: Executor,
    example_count: int = 4,
    progress: bool = True,
) -> tuple[
    list[RealSplit], list[CurvePoint], FolderImages, dict[tuple[str, int], list[np.ndarray]]
]:
    """Every (split, initialisation, k) fine-tuning, a unit on `executor` (its folder under
    `out/few_label/`), scored; with `example_count` of the first split's test images
    (`example_indices`) and the labels each model gave them, for the figure. k = 0 from
    simulation is `sim_only` itself (a saved model: the units load it), scored here;
    `trained_by` is the unit that trained it: its sweeps are what the fine-tunings from it
    rehearse, and its key part of theirs."""
    from resus.execution import run_pending
    from resus.experiments.sim2real.units import (
        FEW_LABEL_FOLDER,
        FineTuneUnit,
        fine_tune_unit,
        images_digest,
        read_examples,
    )

    if sim_only.path is None:
        raise ResusError("few_label_curve: the simulation-only model must be a saved one")
    splits = real_splits(len(real), settings, seed)
    tests = [real.subset(split.test) for split in splits]
    shown = tuple(example_indices(tests[0], example_count))
    digest = images_digest(real)
    points: list[CurvePoint] = []
    examples: dict[tuple[str, int], list[np.ndarray]] = {}
    for split, test in zip(splits, tests, strict=True):
        if 0 not in settings.label_counts:
            break
        evaluation, predicted = vessel_scores(sim_only, test)
        pooled = evaluation.pooled()["vessel"]
        points.append(CurvePoint(FROM_SIMULATION, 0, split.index, pooled.iou, pooled.dice))
        if split.index == 0:
            examples[(FROM_SIMULATION, 0)] = [predicted[i] for i in shown]
    units = [
        FineTuneUnit(
            real.image_folder,
            real.mask_folder,
            digest,
            split,
            initialisation,
            k,
            settings,
            seed,
            device,
            sim_only.path,
            trained_by.sweeps,
            trained_by.key(),
            shown if split.index == 0 else (),
            out / FEW_LABEL_FOLDER / f"{initialisation}_k{k}_split{split.index}",
        )
        for split in splits
        for initialisation in INITIALISATIONS
        for k in settings.label_counts
        if k > 0
    ]
    scores = run_pending(
        executor,
        fine_tune_unit,
        units,
        "few-label",
        "run",
        settings.resources(),
        progress,
    )
    for unit, score in zip(units, scores, strict=True):
        points.append(CurvePoint(unit.initialisation, unit.labels, unit.split.index, **score))
        if unit.shown:
            examples[(unit.initialisation, unit.labels)] = read_examples(unit)
    order = {name: i for i, name in enumerate(INITIALISATIONS)}
    points.sort(key=lambda p: (p.split, order[p.initialisation], p.labels))
    return splits, points, tests[0].subset(shown), examples
