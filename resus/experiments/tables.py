"""The paper's two tables, in simulation.

- `run_phantom_experiment` (Table I): two scans of the nominal phantom (the gel block unless
  the preset's `ScanSettings.phantom` names another) from different start points and tilts.
  A U-Net is trained on scan A's frames, or on scan A's frames plus the reslices of scan A's
  volume, and scored on scan B's frames and on scan B's frames plus reslices: a 2 x 2 IoU
  table.
- `run_subjects_experiment` (Table II): leave-one-subject-out over simulated subjects for the
  regimes us / imagenet / aug / resus, IoU per subject and the average.

Every training run is repeated with the preset's `repeats` seeds (seed, seed + 1, ...): each
IoU is reported as its mean and sample standard deviation over them, and every comparison
of two models is a paired t-test over the seeds (and held-out subjects) with a verdict that
calls a difference within the seed spread "no difference" (`results.SeedComparison`).

An `ExperimentPreset` fixes data size and training together, and what one training run needs
(CPUs, a GPU share). Both experiments run their scans and their training runs as resumable
units on an executor (`RunOptions.executor`: local worker processes or Ray; the results are
the same on either) and write `report.md`, `results.json` and PNG figures to their output
folder (`experiment_report`).
"""

from __future__ import annotations

import dataclasses
import time
from collections.abc import Sequence
from dataclasses import dataclass, field
from pathlib import Path

import numpy as np

from resus.acquisition.patterns import LinearPattern
from resus.errors import ResusError
from resus.execution import Executor, Resources, make_executor
from resus.execution.executor import available_cores
from resus.experiments.data import (
    ScanSettings,
    SubjectData,
    placed_scan,
    prepare_scans,
    prepare_subjects,
    scan_record,
)
from resus.experiments.results import (
    MIN_SEEDS,
    GeneralisationCheck,
    IoUSummary,
    PhantomResults,
    RunRecord,
    ScanImages,
    SeededLoso,
    SubjectsResults,
    compare_models,
)
from resus.experiments.training_units import (
    HELD_OUT_TEST,
    PHANTOM_TEST_SUBJECT,
    PHANTOM_TESTS,
    TrainingOutcome,
    TrainingUnit,
    load_unit_model,
    phantom_images,
    phantom_split,
    run_training_units,
)
from resus.reslicing.reslice import ResliceSettings
from resus.segmentation.metrics import VesselIoU
from resus.segmentation.presets import PAPER, QUICK, TrainingPreset, pick_preset
from sim.labels import ARTERY, VEIN


@dataclass(frozen=True)
class ExperimentPreset:
    """Data size and training of an experiment run."""

    name: str
    training: TrainingPreset
    scans: ScanSettings
    subjects: tuple[int, ...]
    """Subjects of the leave-one-subject-out experiment."""
    phantom_scans: tuple[LinearPattern, LinearPattern]
    """Scan A (training) and scan B (test) of the phantom experiment."""
    repeats: int = 3
    """Training seeds of every training run (seed, seed + 1, ...): each IoU is a mean and a
    spread over them (at least `MIN_SEEDS`)."""
    training_cpus: int = 1
    """CPU cores of one training run, and its torch threads (part of what a run's result
    depends on, so the same whichever engine runs it)."""
    training_gpus: float = 0.0
    """GPU share of one training run under Ray (0.25: four runs share a GPU); the local
    engine leaves the GPU to `RunOptions.device`."""

    def __post_init__(self) -> None:
        try:
            self.training_resources()
        except ResusError as error:
            raise ResusError(f"ExperimentPreset {self.name!r}: {error}") from None
        if self.repeats < MIN_SEEDS:
            raise ResusError(
                f"ExperimentPreset.repeats must be at least {MIN_SEEDS} (a seed spread needs "
                f"two seeds), got {self.repeats}"
            )

    def seeds(self, first: int) -> tuple[int, ...]:
        """The training seeds of a run whose first seed is `first`."""
        return tuple(first + r for r in range(self.repeats))

    def training_resources(self) -> Resources:
        """What the executor reserves for one training run."""
        return Resources(self.training_cpus, self.training_gpus)

    def to_dict(self) -> dict:
        return {
            "name": self.name,
            "training": self.training.to_dict(),
            "scans": self.scans.to_dict(),
            "subjects": list(self.subjects),
            "phantom_scans": [dataclasses.asdict(s) for s in self.phantom_scans],
            "repeats": self.repeats,
            "training_cpus": self.training_cpus,
            "training_gpus": self.training_gpus,
        }


def _phantom_scans(frame_rate: float) -> tuple[LinearPattern, LinearPattern]:
    """Scan A along the vessels from the proximal end; scan B shifted 4 mm laterally, starting
    5 mm further on, tilted 10 degrees about the array axis."""
    scan_a = LinearPattern(frame_rate=frame_rate)
    scan_b = LinearPattern(start=(0.004, -0.035), length=0.07, tilt_deg=10.0, frame_rate=frame_rate)
    return scan_a, scan_b


QUICK_EXPERIMENT = ExperimentPreset(
    name="quick",
    training=QUICK,
    scans=ScanSettings(
        cols=128,
        rows=128,
        sweep=LinearPattern(frame_rate=15.0),
        spacing=0.5e-3,
        reslice=ResliceSettings(angles_deg=(-30.0, -15.0, 0.0, 15.0, 30.0), step=10, size=128),
    ),
    subjects=(0, 1, 2, 3),
    phantom_scans=_phantom_scans(15.0),
    training_cpus=2,
)
"""2-core CPU in minutes: 128 x 128 frames (120 per 8 cm sweep), 0.5 mm voxels, reslices at
-30..30 degrees in 15 degree steps every 10 voxels at 128 x 128, 4 subjects, the tiny
64 x 64 U-Net, two cores (torch threads) per training run: one run at a time on a 2-core
machine, several side by side with more `--jobs` or on a Ray cluster."""

PAPER_EXPERIMENT = ExperimentPreset(
    name="paper",
    training=PAPER,
    scans=ScanSettings(spacing=0.3e-3),
    subjects=tuple(range(8)),
    phantom_scans=_phantom_scans(30.0),
    training_cpus=2,
    training_gpus=0.25,
)
"""The paper's sizes: 256 x 256 frames at 30 frames/s (240 per sweep), 0.3 mm voxels, the
paper's reslicing, 8 subjects, U-Net/ResNet34 at 256 x 256 (needs a GPU; under Ray, four
training runs share one, each with 2 CPU cores)."""

EXPERIMENT_PRESETS = {p.name: p for p in (QUICK_EXPERIMENT, PAPER_EXPERIMENT)}


def get_experiment_preset(name: str) -> ExperimentPreset:
    """The experiment preset called `name`, or a ResusError listing the choices."""
    return pick_preset(EXPERIMENT_PRESETS, name)


@dataclass(frozen=True)
class RunOptions:
    """What an experiment run needs besides its preset."""

    out: Path
    """Report folder: report.md, results.json, PNG figures."""
    data: Path
    """Scratch folder for sweeps, volumes and reslices (cached between runs)."""
    seed: int = 0
    """The first training seed (the preset's `repeats` seeds count on from it)."""
    device: str = "auto"
    jobs: int = 2
    """CPU cores of the local executor (its worker processes), or of a Ray started here."""
    command: str = ""
    """The command line, quoted in the report."""
    progress: bool = True
    executor: str = "local"
    """Where scans and training runs go: "local" (worker processes) or "ray"."""
    address: str | None = None
    """The Ray cluster's address (auto, ray://HOST:10001, HOST:6379); None: a Ray started
    here on 127.0.0.1 with `jobs` CPUs."""


@dataclass(frozen=True)
class Example:
    """One test image with its truth and each regime's prediction, for a figure."""

    title: str
    image: np.ndarray
    truth: np.ndarray
    predictions: dict[str, np.ndarray] = field(default_factory=dict)


def set_torch_threads() -> int:
    """Let torch use every core this process may run on (the units have finished)."""
    import torch

    torch.set_num_threads(available_cores())
    return torch.get_num_threads()


def example_index(labels: np.ndarray) -> int:
    """The image whose smaller vessel is largest (both vessels well in view)."""
    artery = (labels == ARTERY).reshape(len(labels), -1).sum(axis=1)
    vein = (labels == VEIN).reshape(len(labels), -1).sum(axis=1)
    return int(np.argmax(np.minimum(artery, vein)))


PHANTOM_TRAINING = {"us": "frames", "resus": "frames + reslices"}
"""Phantom table rows: regime -> what it trains on (scan A)."""


def _executor(options: RunOptions) -> Executor:
    """The run's executor (use it in a `with` block: a Ray it starts stops at the end)."""
    return make_executor(options.executor, options.jobs, options.address)


def _training_unit(
    experiment: str,
    regime: str,
    held_out: str,
    seed: int,
    data: list[SubjectData],
    preset: ExperimentPreset,
    options: RunOptions,
    encoder_weights: Path | None = None,
) -> TrainingUnit:
    """One training run of `experiment` on the prepared `data`; the encoder weights count
    only for the regime that uses them."""
    return TrainingUnit(
        experiment,
        regime,
        held_out,
        seed,
        tuple(data),
        tuple(scan_record(d) for d in data),
        preset.training,
        options.device,
        preset.training_cpus,
        options.data,
        encoder_weights if regime == "imagenet" else None,
    )


def _run_record(
    options: RunOptions,
    executor: str,
    outcomes: list[TrainingOutcome],
    preset: ExperimentPreset,
    start: float,
    prepared: float,
) -> RunRecord:
    """How the run went: the devices the units trained on, data time from `start` to
    `prepared`, training (and scoring, figures) time until now."""
    return RunRecord(
        device=", ".join(sorted({outcome.device for outcome in outcomes})),
        torch_threads=preset.training_cpus,
        command=options.command,
        data_folder=str(options.data),
        data_seconds=round(prepared - start, 1),
        training_seconds=round(time.perf_counter() - prepared, 1),
        executor=executor,
    )


def run_phantom_experiment(preset: ExperimentPreset, options: RunOptions) -> PhantomResults:
    """Table I analogue; writes the report to `options.out` and returns what results.json
    holds (`.to_dict()`)."""
    from resus.experiments.report import ReportFigures, write_phantom_report
    from resus.segmentation.model import resolve_device

    start = time.perf_counter()
    scan_a, scan_b = preset.phantom_scans
    scans = [
        placed_scan("phantom_scan_a", None, preset.scans, scan_a),
        placed_scan("phantom_scan_b", None, preset.scans, scan_b),
    ]
    seeds = preset.seeds(options.seed)
    with _executor(options) as executor:
        data = prepare_scans(
            options.data, scans, preset.scans, progress=options.progress, executor=executor
        )
        prepared = time.perf_counter()
        units = {
            (regime, seed): _training_unit(
                "phantom", regime, PHANTOM_TEST_SUBJECT, seed, data, preset, options
            )
            for regime in PHANTOM_TRAINING
            for seed in seeds
        }
        outcomes = run_training_units(
            executor, list(units.values()), preset.training_resources(), options.progress
        )
        engine = executor.describe()
    outcome = dict(zip(units, outcomes, strict=True))
    set_torch_threads()
    device = resolve_device(options.device)
    frames, reslices = phantom_images(data)
    split, _ = phantom_split(frames, reslices, preset.training.validation_fraction)
    examples = [
        _example("scan B frame", frames["B"][0]),
        _example("scan B reslice", reslices["B"][0]),
    ]
    histories = {}
    for regime, trained_on in PHANTOM_TRAINING.items():
        first = (regime, seeds[0])
        histories[trained_on] = outcome[first].summary
        model = load_unit_model(units[first], device)
        _predict_examples(examples, trained_on, model, preset.training)
    iou = {
        trained_on: {
            test: IoUSummary.of([outcome[(regime, seed)].test_iou[test] for seed in seeds])
            for test in PHANTOM_TESTS
        }
        for regime, trained_on in PHANTOM_TRAINING.items()
    }
    with_reslices, frames_only = PHANTOM_TRAINING["resus"], PHANTOM_TRAINING["us"]
    results = PhantomResults(
        preset=preset,
        seeds=seeds,
        scans={
            name: ScanImages(
                d.subject, sum(len(s) for s in frames[name]), sum(len(s) for s in reslices[name])
            )
            for name, d in zip("AB", data, strict=True)
        },
        training_frames=len(split.train[0]),
        validation_frames=len(split.validation[0]),
        iou=iou,
        comparisons={
            test: compare_models(
                with_reslices, frames_only, [iou[with_reslices][test]], [iou[frames_only][test]]
            )
            for test in PHANTOM_TESTS
        },
        run=_run_record(options, engine, outcomes, preset, start, prepared),
    )
    write_phantom_report(options.out, results, ReportFigures(examples, histories))
    return results


def _example(title: str, images) -> Example:
    index = example_index(images.labels)
    return Example(f"{title} {index}", images.images[index], images.labels[index])


def _predict_examples(examples: list[Example], name: str, model, preset: TrainingPreset) -> None:
    from resus.segmentation.inference import predict

    for example in examples:
        example.predictions[name] = predict(
            model, example.image[None], image_size=preset.model.image_size
        )[0]


def run_subjects_experiment(
    preset: ExperimentPreset,
    options: RunOptions,
    subjects: Sequence[int] | None = None,
    regimes: Sequence[str] = ("us", "imagenet", "aug", "resus"),
    encoder_weights: Path | None = None,
) -> SubjectsResults:
    """Table II analogue; writes the report to `options.out` and returns what results.json
    holds (`.to_dict()`)."""
    from resus.experiments.report import ReportFigures, write_subjects_report
    from resus.segmentation.loaders import load_reslice_sets, load_sweep_frames
    from resus.segmentation.loso import LosoResult, subjects_of
    from resus.segmentation.model import resolve_device

    subjects = tuple(preset.subjects if subjects is None else subjects)
    if len(subjects) < 2:
        raise ResusError(f"leave-one-subject-out needs at least 2 subjects, got {subjects}")
    if encoder_weights is not None and not Path(encoder_weights).is_file():
        raise ResusError("no such encoder weights file", encoder_weights)
    seeds = preset.seeds(options.seed)
    start = time.perf_counter()
    with _executor(options) as executor:
        data = prepare_subjects(
            options.data, subjects, preset.scans, progress=options.progress, executor=executor
        )
        prepared = time.perf_counter()
        frames = load_sweep_frames([d.sweep for d in data])
        reslices = load_reslice_sets([d.reslices for d in data])
        ids = subjects_of(frames)
        admitted = LosoResult(ids)
        units = [
            _training_unit(
                "subjects", regime, subject, seed, data, preset, options, encoder_weights
            )
            for regime in admitted.admit(regimes, reslices, encoder_weights)
            for subject in ids
            for seed in seeds
        ]
        outcomes = run_training_units(
            executor, units, preset.training_resources(), options.progress
        )
        engine = executor.describe()
    set_torch_threads()
    device = resolve_device(options.device)
    example_set = next(s for s in frames if s.subject == ids[0])
    examples = [_example(f"held-out subject {ids[0]}, frame", example_set)]
    test_runs: dict[str, dict[str, list[VesselIoU]]] = {}
    validation_runs: dict[str, dict[str, list[VesselIoU]]] = {}
    training_images: dict[str, dict[str, int]] = {}
    histories = {}
    for unit, outcome in zip(units, outcomes, strict=True):
        regime, subject = unit.regime, unit.held_out
        test_runs.setdefault(regime, {}).setdefault(subject, []).append(
            outcome.test_iou[HELD_OUT_TEST]
        )
        validation_runs.setdefault(regime, {}).setdefault(subject, []).append(
            outcome.validation_iou
        )
        training_images.setdefault(regime, {})[subject] = outcome.train_images
        if subject == ids[0] and unit.seed == seeds[0]:  # the first fold's curves, examples
            histories[regime] = outcome.summary
            _predict_examples(examples, regime, load_unit_model(unit, device), preset.training)
    loso = SeededLoso(tuple(ids), seeds, _summaries(test_runs), dict(admitted.not_run))
    validation_iou = _summaries(validation_runs)
    results = SubjectsResults(
        preset=preset,
        subject_numbers=subjects,
        images=tuple(
            ScanImages(s.subject, len(s), len(r)) for s, r in zip(frames, reslices, strict=True)
        ),
        loso=loso,
        validation_iou=validation_iou,
        training_images=training_images,
        generalisation=generalisation_check(loso, validation_iou),
        run=_run_record(options, engine, outcomes, preset, start, prepared),
    )
    write_subjects_report(options.out, results, ReportFigures(examples, histories))
    return results


def _summaries(
    runs: dict[str, dict[str, list[VesselIoU]]],
) -> dict[str, dict[str, IoUSummary]]:
    """Regime -> subject -> each seed's IoU, summarised over the seeds."""
    return {
        regime: {subject: IoUSummary.of(ious) for subject, ious in per_subject.items()}
        for regime, per_subject in runs.items()
    }


GAP_THRESHOLD = 0.05
"""Mean-IoU drop (or spread over subjects) above which subjects count as really different."""


def generalisation_check(
    loso: SeededLoso, validation_iou: dict[str, dict[str, IoUSummary]]
) -> GeneralisationCheck | None:
    """Do the subjects differ enough that generalising across them is a real problem?

    Compares the `us` regime's IoU (mean over seeds) on its training subjects' held-out
    validation frames (within-subject) with its IoU on the held-out subject, and the spread
    over subjects; None when the `us` regime did not run.
    """
    if "us" not in loso.iou:
        return None
    test = [cell.mean for cell in loso.iou["us"].values()]
    within = [cell.mean for cell in validation_iou["us"].values()]
    gap = float(np.mean(within) - np.mean(test))
    spread = float(np.std(test))
    return GeneralisationCheck(
        us_within_subject_iou=float(np.mean(within)),
        us_held_out_subject_iou=float(np.mean(test)),
        gap=gap,
        held_out_iou_std_over_subjects=spread,
        threshold=GAP_THRESHOLD,
        subjects_differ_enough=gap > GAP_THRESHOLD or spread > GAP_THRESHOLD,
    )
