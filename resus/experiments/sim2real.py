"""The sim-to-real experiment: a U-Net trained on simulation only, scored on real images, and
what simulation pretraining is worth once a few real labels exist.

1. Simulation only. One sweep per subject of the in-vivo phantom, each imaged by its own
   randomised scanner preset (`sim.ultrasound.scanner.sweep_preset`), trains one U-Net; no
   real image enters that training. The model (`sim_only/checkpoint.pt`) is scored on every
   real image (`sim_only/evaluation/`: metrics.json and overlays, as `resus evaluate` writes).
   With `ensemble` > 1, members 1, 2, ... are the same run at the next seeds (subjects,
   scanners and training of their own, in `sim_only/member_M/` and `data/member_M/`), and
   the figure is their ensemble's (`resus.segmentation.load_ensemble`); each member is
   scored alone too.
2. The few-label curve. For each of `splits` seeded random splits of the real images into a
   pool of `max(label_counts)` images and a test set (all the others), a U-Net is fine-tuned
   on the first k images of the pool, once from the simulation-only weights and once from
   random weights, and scored on the split's test set. Every k of a split shares one test
   set, so the curve compares like with like. From simulation, k = 0 is the simulation-only
   model itself (member 0, the network the fine-tunings start from); from scratch, k = 0
   has nothing to learn from and is not reported.

The sweeps, the simulation-only training and every fine-tuning are units on an executor
(`resus.execution`: local worker processes or a Ray cluster; `sim2real_units`), each recorded
when it finishes, so a rerun resumes and the figures do not depend on the engine.

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
from dataclasses import dataclass, field
from pathlib import Path
from typing import TYPE_CHECKING

import numpy as np
import torch

from resus.acquisition.patterns import LinearPattern
from resus.errors import ResusError, check_choice, simulator_errors
from resus.execution import Executor, Resources, as_json, make_executor
from resus.experiments.vessel_targets import vessel_depth
from resus.segmentation.data import LabelledImages
from resus.segmentation.evaluate import Evaluation, score_labels
from resus.segmentation.folders import FolderImages
from resus.segmentation.presets import TrainingPreset, get_preset, pick_preset
from resus.segmentation.trained_model import Segmenter, TrainedModel
from sim.phantom import load_phantom
from sim.ultrasound.scanner import RANDOM_RANGES, sweep_preset

if TYPE_CHECKING:
    from resus.experiments.sim2real_units import SimOnlyUnit
    from resus.sweep import SweepFrame
    from sim.phantom import PhantomSpec
    from sim.ultrasound.scanner import ScannerPreset

SCHEMA = "resus.sim2real/1"
FROM_SIMULATION, FROM_SCRATCH = "simulation", "scratch"
INITIALISATIONS = (FROM_SIMULATION, FROM_SCRATCH)
"""Where a fine-tuning starts: the simulation-only weights, or random ones."""
SIM2REAL_REGIMES = ("us", "aug")
"""Regimes that need nothing but sweeps (no reslices, no ImageNet weights)."""
REAL_SUBJECT = "real"
"""Subject id of the real images when they train (fine-tuning only)."""
SIM_ONLY_FOLDER, CHECKPOINT = "sim_only", "checkpoint.pt"
"""The simulation-only model's folder in the output, and a trained unit's checkpoint."""

CURVE_SHAPE_FIELDS = ("label_counts", "splits", "minimum_test_images")
"""`Sim2RealSettings` fields that choose which fine-tunings the curve runs (its k, its splits
and their test sets, which each fine-tuning's key names itself), not what any one computes."""
REHEARSAL_STREAM = 0x4EAE
"""Mixed into a fine-tuning's seed to draw its rehearsal frames (`rehearsal_frames`)."""
CURVE_FIELDS = (
    *CURVE_SHAPE_FIELDS, "fine_tune_epochs", "fine_tune_epoch_images", "rehearsal_images"
)  # fmt: skip
"""`Sim2RealSettings` fields that only the few-label curve reads."""


@dataclass(frozen=True)
class Sim2RealSettings:
    """Everything the experiment does besides its real images, seed and device."""

    name: str
    subjects: tuple[int, ...]
    """Simulated subjects of `phantom`, one sweep each."""
    training: str
    """Segmentation training preset (`resus.segmentation.presets`) of every model."""
    phantom: str = "femoral"
    scanner: str = "random"
    """Scanner preset of every sweep: a name, a YAML file (`scanner_preset`), or `random`, one
    drawn per subject."""
    sweep: LinearPattern = field(
        default_factory=lambda: LinearPattern(start=(0.0, -0.04), length=0.06)
    )
    """The nominal sweep; each subject's is moved and tilted (`subject_sweep`)."""
    sweep_offset: float = 0.010
    """Each subject's sweep starts up to this far (m) to either side of the nominal start: a
    sonographer's probe does not centre the vessels in the image."""
    off_vessel_share: float = 0.0
    """Share of the subjects (rounded, drawn from the seed) whose sweep lies off the vessels,
    `off_vessel_offset` to either side of the nominal line: a sonographer's picture does not
    always hold a vessel (10 % of usgra-seg's images hold none), and the muscles and nerve
    beside the vessels are what a model must learn not to call vessel. A vessel that still
    reaches into the picture is labelled as ever."""
    off_vessel_offset: tuple[float, float] = (0.040, 0.050)
    """Range of such a sweep's sideways distance from the nominal line (m): with the 38 mm
    field, its edge 21-31 mm from the vessel pair's midline, past the vein's and the
    artery's far walls, where the bellies beside the pair lie."""
    sweep_tilt_deg: float = 10.0
    """Each subject's probe is tilted by up to this much (degrees) either way along the sweep."""
    contact_forces: tuple[float, float] = (1.5, 3.5)
    """Each subject's sweep holds a contact force drawn in this range (N): sonographers press
    differently, and the deformable phantom's veins go from round to oval. A vascular scan
    presses lightly, to keep the veins open: at 2-9 N (until 2026-12-04) 23 % of the vessel
    cross-sections in seed 0's training frames were over 3 times longer than wide (veins
    pressed to slits), against 3 % in the real images of usgra-seg; at 1.5-3.5 N, 10 %."""
    target_depth_fraction: tuple[float, float] | None = (0.25, 0.65)
    """The sonographer sets each sweep's displayed depth so that the vessels' centres lie at a
    fraction of it drawn in this range (`subject_preset`), within the depths linear presets
    span; None keeps the scanner preset's own depth, blind to the anatomy. In usgra-seg the
    vessels' centres lie at 0.25 / 0.45 / 0.74 of the imaged height (10th / 50th / 90th
    percentile, `resus realism`); 0.35-0.75 (until 2026-12-05) put seed 0's training vessels
    at 0.24 / 0.56 / 0.81, 0.25-0.65 puts them at 0.20 / 0.45 / 0.71, and their areas nearer
    the real ones' too (median 4.3 % of the image, now 3.6 %; real 3.1 %)."""
    ensemble: int = 1
    """Simulation-only models whose mean class probabilities give the simulation-only score:
    member m is the run at seed + m, with simulated subjects of its own, so runs at seeds
    fewer than `ensemble` apart share members. Networks trained apart err apart on real
    images (five 128 px members: 0.348 against 0.284 +- 0.062 alone, README Sim-to-real)."""
    regime: str = "aug"
    """Training regime of the simulation-only model and of every fine-tuning."""
    weight_averaging_epochs: int = 5
    """The simulation-only training runs at the preset's starting rate throughout and its
    model is the mean of the weights after every step of its last this many epochs
    (`TrainingPreset.weight_averaging_epochs`, `resus.segmentation.averaging`): a wider
    minimum of the simulated images' loss, which a shift to real images moves less (128 px,
    seeds 0-3 on usgra-seg: 0.462 -> 0.478 alone, 0.499 -> 0.508 as their ensemble; notebook
    "Weight averaging"). 0: the preset's own schedule and its best epoch. The fine-tunings
    keep the preset's."""
    export_framing_p: float = 0.5
    """Probability that the `aug` regime frames an image like a scanner's export
    (`resus.segmentation.framing`); real exports are not their imaged area."""
    zoom_p: float = 0.5
    """Probability that the `aug` regime zooms into an image (`resus.segmentation.zoom`):
    sonographers enlarge the vessels' part of the image."""
    elastic_p: float = 0.5
    """Probability that the `aug` regime warps an image and its labels elastically
    (`AugmentationConfig.elastic_p`): real veins are seldom ellipses (128 px, five seeds:
    0.319 +- 0.025 against 0.284 +- 0.062 without, README Sim-to-real)."""
    vertical_flip_p: float = 0.5
    """Probability that the `aug` regime turns an image upside down
    (`AugmentationConfig.vertical_flip_p`). No B-mode image is, yet without them the
    simulation-only model scored worse (128 px, five seeds: 0.245 +- 0.092 against 0.296 +-
    0.046, paired p = 0.11; README Sim-to-real)."""
    label_counts: tuple[int, ...] = (0, 5, 10, 25, 50, 100)
    """k: real labelled images a fine-tuning gets."""
    splits: int = 3
    """Random splits of the real images the curve is averaged over."""
    fine_tune_epochs: int = 80
    fine_tune_epoch_images: int = 64
    """Images per fine-tuning epoch: the k images repeated up to this count. Both starts get
    the same budget, long enough for either to converge: at 64 px on split 0 of usgra-seg, 100
    real labels from random weights give vessel IoU 0.000 / 0.002 / 0.302 / 0.402 after 6 /
    20 / 40 / 80 epochs (6 was the default until 2026-12-04: it compared a trained pretrained
    network with an untrained baseline), and from the simulation-only weights 0.352 after 6
    and 0.479 after 80."""
    rehearsal_images: int = 64
    """Simulated frames in every epoch of a fine-tuning from simulation (rehearsal), drawn
    once per fine-tuning (seeded) from the simulation-only model's own training sweeps, in
    the real masks' classes (one vessel class where they do not tell artery from vein); it
    runs fewer epochs so that both starts see the same number of images
    (`fine_tuning_epochs`). From scratch gets none: it is the curve's start without
    simulation. 0: none. Without it five real labels wrecked the start on one split of
    usgra-seg (0.467 -> 0.086; with 64: 0.481; README Sim-to-real)."""
    minimum_test_images: int = 20
    """The least the real set must leave for testing after the largest k."""
    training_cpus: int = 2
    """CPU cores of one training run, and its torch threads (part of what a run's result
    depends on, so the same whichever engine runs it)."""
    training_gpus: float = 0.0
    """GPU share of one training run under Ray (0.25: four runs share a GPU)."""

    def __post_init__(self) -> None:
        object.__setattr__(self, "subjects", tuple(int(k) for k in self.subjects))
        object.__setattr__(self, "label_counts", tuple(int(k) for k in self.label_counts))
        where = "Sim2RealSettings"
        if not self.subjects:
            raise ResusError(f"{where}.subjects is empty")
        check_choice(f"{where}.regime", self.regime, SIM2REAL_REGIMES)
        with simulator_errors(f"{where}.phantom"):
            load_phantom(self.phantom)
        with simulator_errors(f"{where}.scanner"):
            sweep_preset(self.scanner, 0, 0)
        counts = self.label_counts
        if not counts or list(counts) != sorted(set(counts)) or counts[0] < 0:
            raise ResusError(
                f"{where}.label_counts must be distinct, increasing and >= 0, got {counts}"
            )
        counted = (
            "ensemble",
            "splits",
            "fine_tune_epochs",
            "fine_tune_epoch_images",
            "minimum_test_images",
            "training_cpus",
        )
        for name in counted:
            if getattr(self, name) < 1:
                raise ResusError(f"{where}.{name} must be at least 1, got {getattr(self, name)}")
        if self.rehearsal_images < 0:
            raise ResusError(f"{where}.rehearsal_images must be >= 0, got {self.rehearsal_images}")
        if not (self.sweep_offset >= 0 and 0 <= self.sweep_tilt_deg < 45):
            raise ResusError(
                f"{where}.sweep_offset must be >= 0 and sweep_tilt_deg in [0, 45), got "
                f"{self.sweep_offset}, {self.sweep_tilt_deg}"
            )
        low, high = self.off_vessel_offset
        if not 0 <= low <= high:
            raise ResusError(
                f"{where}.off_vessel_offset must be (low, high) with 0 <= low <= high (m), "
                f"got {self.off_vessel_offset}"
            )
        low, high = self.contact_forces
        if not 0 < low <= high < 20:
            raise ResusError(
                f"{where}.contact_forces must be (low, high) with 0 < low <= high < 20 N (the "
                f"scanner's force limit), got {self.contact_forces}"
            )
        if self.target_depth_fraction is not None:
            low, high = self.target_depth_fraction
            if not 0 < low <= high < 1:
                raise ResusError(
                    f"{where}.target_depth_fraction must be (low, high) with 0 < low <= high "
                    f"< 1, got {self.target_depth_fraction}"
                )
        shares = ("off_vessel_share", "export_framing_p", "zoom_p", "elastic_p", "vertical_flip_p")
        for name in shares:
            if not 0 <= getattr(self, name) <= 1:
                raise ResusError(f"{where}.{name} must be in [0, 1], got {getattr(self, name)}")
        epochs = get_preset(self.training).max_epochs  # an unknown preset fails here
        if not 0 <= self.weight_averaging_epochs <= epochs:
            raise ResusError(
                f"{where}.weight_averaging_epochs must be in [0, {epochs}] (the max_epochs of "
                f"training preset {self.training!r}), got {self.weight_averaging_epochs}"
            )
        Resources(self.training_cpus, self.training_gpus)  # a bad GPU share fails here too

    def resources(self) -> Resources:
        """What one training run needs of the executor."""
        return Resources(self.training_cpus, self.training_gpus)

    def training_preset(self) -> TrainingPreset:
        """The `training` preset with the experiment's augmentation probabilities."""
        preset = get_preset(self.training)
        augmentation = dataclasses.replace(
            preset.augmentation,
            framing_p=self.export_framing_p,
            zoom_p=self.zoom_p,
            elastic_p=self.elastic_p,
            vertical_flip_p=self.vertical_flip_p,
        )
        return dataclasses.replace(preset, augmentation=augmentation)

    def simulation_training_preset(self) -> TrainingPreset:
        """The simulation-only model's preset: `training_preset`, weight-averaged over the last
        `weight_averaging_epochs` (`TrainingPreset.weight_averaged`)."""
        return self.training_preset().weight_averaged(self.weight_averaging_epochs)

    def fine_tuning_epochs(self, rehearsal: bool) -> int:
        """Epochs of a fine-tuning: `fine_tune_epochs`, or with rehearsal as many as keep its
        images (`fine_tune_epoch_images` real ones and `rehearsal_images` simulated a epoch)
        to the same total, at least one."""
        if not rehearsal or not self.rehearsal_images:
            return self.fine_tune_epochs
        images = self.fine_tune_epochs * self.fine_tune_epoch_images
        return max(1, round(images / (self.fine_tune_epoch_images + self.rehearsal_images)))

    @property
    def pool_size(self) -> int:
        """Real images set aside per split for fine-tuning (the largest k)."""
        return self.label_counts[-1]

    def to_dict(self) -> dict:
        """JSON-able form (tuples become lists)."""
        return as_json(dataclasses.asdict(self))

    def unit_key(self) -> dict:
        """`to_dict` without `ensemble`: what a fine-tuning's result depends on (a member is
        the same run whatever the ensemble's size)."""
        return {name: value for name, value in self.to_dict().items() if name != "ensemble"}

    def simulation_only_key(self) -> dict:
        """`unit_key` without the few-label curve's settings (`CURVE_FIELDS`): what the
        simulation-only training depends on, so that asking for another curve from the same
        simulation reuses its model instead of training it again."""
        return self._unit_key_without(CURVE_FIELDS)

    def fine_tuning_key(self) -> dict:
        """`unit_key` without the curve's shape (`CURVE_SHAPE_FIELDS`): what one fine-tuning
        depends on besides its split, k and start, so that a curve asked for with more k
        reuses the fine-tunings it shares with one run before."""
        return self._unit_key_without(CURVE_SHAPE_FIELDS)

    def _unit_key_without(self, fields: tuple[str, ...]) -> dict:
        """`unit_key` less `fields`."""
        return {name: v for name, v in self.unit_key().items() if name not in fields}


SIM2REAL_PRESETS: dict[str, Sim2RealSettings] = {
    # 36 subjects of 10 mm each, about the frames of six 60 mm sweeps (the training cost),
    # six times the anatomies and scanners: 18 of 20 mm against six of 60 mm, 64 px, 2
    # seeds: 0.237 +- 0.030 against 0.197 +- 0.087; 36 of 10 mm (centred where the 20 mm
    # ones were) against 18 of 20 mm, 128 px, 5 seeds: 0.410 +- 0.023 against 0.389 +- 0.025
    # an ensemble of three: five 128 px members in threes, 0.333 +- 0.021 against
    # 0.284 +- 0.062 for one (README Sim-to-real)
    "quick": Sim2RealSettings(
        name="quick",
        subjects=tuple(range(36)),
        training="cpu128",
        sweep=LinearPattern(start=(0.0, -0.035), length=0.01),
        ensemble=3,
    ),
    "paper": Sim2RealSettings(
        name="paper",
        subjects=tuple(range(24)),
        training="paper",
        ensemble=5,
        weight_averaging_epochs=0,  # not measured at 256 px; the preset's early stopping
        splits=5,
        fine_tune_epochs=40,
        fine_tune_epoch_images=160,
        training_gpus=0.25,
    ),
}
"""`quick`: 36 subjects of 10 mm, the 128 px CPU training preset (a model's training: about
15 minutes on 2 idle cores), weight averaging over its last 5 of 20 epochs; `paper`: 24
subjects at the paper's 256 px ResNet34 U-Net, 5 splits (a GPU), its best epoch (weight
averaging would run all 100 epochs, and was not measured there)."""


def get_sim2real_preset(name: str) -> Sim2RealSettings:
    """The sim-to-real preset called `name`, or a ResusError listing the choices."""
    return pick_preset(SIM2REAL_PRESETS, name)


# ---- splits and the curve ----------------------------------------------------------------


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
    from resus.experiments.sim2real_units import (
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
        [(unit, unit.record()) for unit in units],
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


# ---- the simulated side ----------------------------------------------------------------


def sweep_provenance(settings: Sim2RealSettings, subject: int, seed: int) -> dict:
    """What a subject's sweep of the experiment must have been made from to be reused
    (`resus.acquisition.simulation.sweep_provenance`)."""
    return _subject_scan(settings, subject, seed)[0]


def _subject_scan(
    settings: Sim2RealSettings, subject: int, seed: int
) -> tuple[dict, ScannerPreset | None]:
    """A subject's sweep provenance (`sweep_provenance`) and the scanner preset that makes
    it, from one draw of the subject's phantom."""
    from resus.acquisition.simulation import phantom_spec, resolve_scene
    from resus.acquisition.simulation import sweep_provenance as simulated_provenance
    from sim.phantom import Phantom

    scene = resolve_scene("default", settings.phantom, subject)
    spec = phantom_spec(scene, seed)
    preset = subject_preset(settings, spec, subject, seed)
    path = subject_sweep(settings, subject, seed).trajectory(Phantom(spec), scene.phantom_to_base)
    return simulated_provenance(scene, spec, preset, path), preset


def simulate_subjects(
    folder: Path,
    settings: Sim2RealSettings,
    seed: int,
    executor: Executor,
    *,
    progress: bool = True,
) -> list[Path]:
    """One sweep per subject in `folder/subject_KK.h5`, each a unit on `executor`; a sweep
    already there from the same phantom, subject, seed, scanner and simulator
    (`sweep_provenance`) is kept."""
    from resus.sweep.io import SweepReader

    folder.mkdir(parents=True, exist_ok=True)
    paths = [folder / f"subject_{k:02d}.h5" for k in settings.subjects]
    work = []
    for subject, path in zip(settings.subjects, paths, strict=True):
        wanted, preset = _subject_scan(settings, subject, seed)
        if path.is_file():
            with SweepReader(path) as reader:
                made_from = {key: reader.provenance.get(key) for key in wanted}
            if made_from == wanted:
                continue
        work.append((path, settings, subject, seed, preset))
    executor.map(_simulate_sweep, work, "simulate", "sweep", progress=progress)
    return paths


def off_vessel_subjects(settings: Sim2RealSettings, seed: int) -> frozenset[int]:
    """The subjects whose sweep lies off the vessels: `off_vessel_share` of them, rounded,
    drawn from the seed."""
    count = round(settings.off_vessel_share * len(settings.subjects))
    rng = np.random.default_rng([seed, 0x0FF5])
    return frozenset(int(k) for k in rng.choice(settings.subjects, count, replace=False))


def subject_sweep(settings: Sim2RealSettings, subject: int, seed: int) -> LinearPattern:
    """The nominal sweep moved sideways by up to `sweep_offset` (or, for the
    `off_vessel_subjects`, by `off_vessel_offset` to one side), tilted by up to
    `sweep_tilt_deg` and pressed with a force in `contact_forces`, drawn from (seed, subject):
    every subject is scanned its own way."""
    rng = np.random.default_rng([seed, subject, 0x5EE9])
    offset = rng.uniform(-settings.sweep_offset, settings.sweep_offset)
    tilt = rng.uniform(-settings.sweep_tilt_deg, settings.sweep_tilt_deg)
    force = rng.uniform(*settings.contact_forces)
    if subject in off_vessel_subjects(settings, seed):  # its own draw: the others' stay put
        aside = np.random.default_rng([seed, subject, 0x0FF5])
        offset = float(aside.choice((-1.0, 1.0)) * aside.uniform(*settings.off_vessel_offset))
    x, y = settings.sweep.start
    return dataclasses.replace(
        settings.sweep, start=(x + offset, y), tilt_deg=tilt, contact_force=float(force)
    )


def subject_preset(
    settings: Sim2RealSettings, spec: PhantomSpec, subject: int, seed: int
) -> ScannerPreset | None:
    """The scanner preset of a subject's sweep (`sweep_preset`), its displayed depth set, when
    `settings.target_depth_fraction` asks, so the vessels at the sweep's middle lie at a
    fraction of it drawn from (seed, subject)."""
    preset = sweep_preset(settings.scanner, seed, subject)
    if preset is None or settings.target_depth_fraction is None:
        return preset
    sweep = subject_sweep(settings, subject, seed)
    fraction = np.random.default_rng([seed, subject, 0xDE97]).uniform(
        *settings.target_depth_fraction
    )
    depth = vessel_depth(spec, float(sweep.middle[1])) / fraction
    return preset.at_depth(float(np.clip(depth, *RANDOM_RANGES["depth"])))


def _simulate_sweep(
    job: tuple[Path, Sim2RealSettings, int, int, ScannerPreset | None],
) -> None:
    """One subject's sweep with its scanner preset (`_subject_scan`'s; top level so worker
    processes can run it)."""
    from resus.acquisition.simulation import resolve_scene, simulate_sweep
    from resus.execution import limit_numba_threads

    limit_numba_threads()
    path, settings, subject, seed, preset = job
    scene = resolve_scene("default", settings.phantom, subject)
    partial = path.with_suffix(".partial.h5")
    sweep = subject_sweep(settings, subject, seed)
    simulate_sweep(partial, scene, sweep, seed=seed, preset=preset, progress=False)
    partial.replace(path)  # a killed run leaves no half sweep under the final name


# ---- the experiment ----------------------------------------------------------------------


@dataclass(frozen=True)
class Sim2RealResult:
    """What the experiment measured; `to_dict()` is results.json."""

    settings: Sim2RealSettings
    seed: int
    command: str
    real_folder: Path
    out: Path
    """The output folder: results.json names what lies under it relative to it, so a copied
    report still points at its own sweeps."""
    sweeps: tuple[Path, ...]
    sim_only: Evaluation
    """The simulation-only model (the ensemble, if more than one) on every real image,
    vessel = artery or vein."""
    members: tuple[Evaluation, ...]
    """Each member of an ensemble alone, likewise (empty for one model)."""
    splits: tuple[RealSplit, ...]
    points: tuple[CurvePoint, ...]

    def to_dict(self) -> dict:
        summary = curve_summary(self.points)
        return {
            "schema": SCHEMA,
            "command": self.command,
            "seed": self.seed,
            "settings": self.settings.to_dict(),
            "real_folder": str(self.real_folder),
            "sweeps": [str(path_in(self.out, path)) for path in self.sweeps],
            "sim_only": {
                "checkpoints": [
                    str(member_folder(Path(SIM_ONLY_FOLDER), m) / CHECKPOINT)
                    for m in range(self.settings.ensemble)
                ],
                "real_images": len(self.sim_only.names),
                **self.sim_only.to_dict(),
                "members": [
                    {"seed": self.seed + m, "pooled": member.to_dict()["pooled"]}
                    for m, member in enumerate(self.members)
                ],
            },
            "splits": [
                {"index": s.index, "pool": list(s.pool), "test": list(s.test)} for s in self.splits
            ],
            "curve": [dataclasses.asdict(point) for point in self.points],
            "curve_summary": {
                initialisation: {str(k): dataclasses.asdict(s) for k, s in by_k.items()}
                for initialisation, by_k in summary.items()
            },
        }


def path_in(folder: Path, path: Path) -> Path:
    """`path` relative to `folder` when it lies under it, else as it is."""
    return path.relative_to(folder) if path.is_relative_to(folder) else path


def member_folder(folder: Path, member: int) -> Path:
    """Where ensemble member `member` keeps what `folder` holds for a single model: member 0
    in `folder` itself (so a one-model run is laid out as before ensembles), the others in
    `folder/member_M`."""
    return folder if member == 0 else folder / f"member_{member}"


def run_sim2real(
    settings: Sim2RealSettings,
    real: FolderImages,
    out: Path,
    *,
    data: Path | None = None,
    seed: int = 0,
    device: str = "auto",
    executor: Executor | None = None,
    command: str = "",
    progress: bool = True,
) -> Sim2RealResult:
    """The whole experiment on the real images `real` (`read_folders`) into `out` (report.md,
    results.json, PNGs, sim_only/, few_label/, realism/); the sweeps go to `data` (default
    `out/data`). Sweeps and training runs are units on `executor` (default: two local
    worker processes); a rerun into the same folders redoes only the units not finished."""
    from resus.execution import run_pending
    from resus.experiments.realism import ImageSet, read_sweep_set, write_realism_report
    from resus.experiments.sim2real_report import EXAMPLE_IMAGES, write_sim2real_report
    from resus.experiments.sim2real_units import SimOnlyUnit, train_sim_only
    from resus.segmentation.evaluate import evaluate_folder
    from resus.segmentation.model import resolve_device
    from resus.segmentation.trained_model import ModelEnsemble, load_model

    out, real_folder = Path(out), real.image_folder.parent
    real_splits(len(real), settings, seed)  # too few real images fails before any work
    torch_device = resolve_device(device)
    engine = executor or make_executor("local", 2)
    units, sweeps = [], []
    for member in range(settings.ensemble):
        member_seed = seed + member
        member_sweeps = simulate_subjects(
            member_folder(Path(data or out / "data"), member) / "sweeps",
            settings,
            member_seed,
            engine,
            progress=progress,
        )
        sweeps += member_sweeps
        units.append(
            SimOnlyUnit(
                tuple(member_sweeps),
                tuple(sweep_provenance(settings, k, member_seed) for k in settings.subjects),
                settings,
                member_seed,
                device,
                member_folder(out / SIM_ONLY_FOLDER, member),
                progress=progress and engine.name == "local",
            )
        )
    run_pending(
        engine, train_sim_only, [(unit, unit.record()) for unit in units], "simulation only",
        "run", settings.resources(), progress,
    )  # fmt: skip
    # scored here with the training runs' thread count: figures that do not depend on
    # which engine trained (torch's sums follow its threads)
    torch.set_num_threads(settings.training_cpus)
    members = [load_model(unit.checkpoint, torch_device) for unit in units]
    sim_only = members[0] if len(members) == 1 else ModelEnsemble(members)
    evaluate_folder(sim_only, real, out / SIM_ONLY_FOLDER / "evaluation", progress=progress)
    evaluation, _ = vessel_scores(sim_only, real)
    member_scores = (
        tuple(vessel_scores(member, real)[0] for member in members) if len(members) > 1 else ()
    )
    splits, points, shown, examples = few_label_curve(
        real,
        members[0],
        units[0],
        settings,
        out,
        seed=seed,
        device=device,
        executor=engine,
        example_count=EXAMPLE_IMAGES,
        progress=progress,
    )
    result = Sim2RealResult(
        settings,
        seed,
        command,
        real_folder,
        out,
        tuple(sweeps),
        evaluation,
        member_scores,
        tuple(splits),
        tuple(points),
    )
    real_set = ImageSet("real", real.images, tuple(m > 0 for m in real.labels), real.names)
    comparison = write_realism_report(
        out / "realism",
        read_sweep_set(sweeps, 32),
        real_set,
        sources={"sweeps": f"{len(sweeps)} simulated subjects", "real": str(real_folder)},
    )
    write_sim2real_report(out, result, comparison, shown, examples)
    return result
