"""The paper's two tables, in simulation.

- `run_phantom_experiment` (Table I): two scans of the gel-block phantom from different start
  points and tilts. A U-Net is trained on scan A's frames, or on scan A's frames plus the
  reslices of scan A's volume, and scored on scan B's frames and on scan B's frames plus
  reslices: a 2 x 2 IoU table (each cell the mean over `repeats` seeds).
- `run_subjects_experiment` (Table II): leave-one-subject-out over simulated subjects for the
  regimes us / imagenet / aug / resus, IoU per subject, the average, and paired t-tests.

An `ExperimentPreset` fixes data size and training together; both experiments write
`report.md`, `results.json` and PNG figures to their output folder (`experiment_report`).
"""

from __future__ import annotations

import dataclasses
import time
from collections.abc import Sequence
from dataclasses import dataclass, field
from pathlib import Path
from typing import TYPE_CHECKING

import numpy as np

from resus.acquisition.patterns import LinearPattern
from resus.errors import ResusError
from resus.experiments.data import Scan, ScanSettings, prepare_scans, prepare_subjects
from resus.experiments.results import (
    GeneralisationCheck,
    IoUSummary,
    PhantomResults,
    RunRecord,
    ScanImages,
    SubjectsResults,
)
from resus.reslicing.reslice import ResliceSettings
from resus.segmentation.metrics import VesselIoU
from resus.segmentation.presets import PAPER, QUICK, TrainingPreset
from resus.workers import available_cores
from sim.labels import ARTERY, VEIN

if TYPE_CHECKING:  # torch is imported only when training starts
    import torch

    from resus.segmentation.loso import LosoResult


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
    """Phantom experiment: training seeds per table cell (seed, seed + 1, ...)."""

    def to_dict(self) -> dict:
        return {
            "name": self.name,
            "training": self.training.to_dict(),
            "scans": self.scans.to_dict(),
            "subjects": list(self.subjects),
            "phantom_scans": [dataclasses.asdict(s) for s in self.phantom_scans],
            "repeats": self.repeats,
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
)
"""2-core CPU in minutes: 128 x 128 frames (120 per 8 cm sweep), 0.5 mm voxels, reslices at
-30..30 degrees in 15 degree steps every 10 voxels at 128 x 128, 4 subjects, the tiny
64 x 64 U-Net."""

PAPER_EXPERIMENT = ExperimentPreset(
    name="paper",
    training=PAPER,
    scans=ScanSettings(spacing=0.3e-3),
    subjects=tuple(range(8)),
    phantom_scans=_phantom_scans(30.0),
)
"""The paper's sizes: 256 x 256 frames at 30 frames/s (240 per sweep), 0.3 mm voxels, the
paper's reslicing, 8 subjects, U-Net/ResNet34 at 256 x 256 (needs a GPU)."""

EXPERIMENT_PRESETS = {p.name: p for p in (QUICK_EXPERIMENT, PAPER_EXPERIMENT)}


def get_experiment_preset(name: str) -> ExperimentPreset:
    """The experiment preset called `name`, or a ResusError listing the choices."""
    if name not in EXPERIMENT_PRESETS:
        raise ResusError(f"unknown preset {name!r}; choose one of {', '.join(EXPERIMENT_PRESETS)}")
    return EXPERIMENT_PRESETS[name]


@dataclass(frozen=True)
class RunOptions:
    """What an experiment run needs besides its preset."""

    out: Path
    """Report folder: report.md, results.json, PNG figures."""
    data: Path
    """Scratch folder for sweeps, volumes and reslices (cached between runs)."""
    seed: int = 0
    device: str = "auto"
    jobs: int = 2
    """Worker processes for data preparation."""
    command: str = ""
    """The command line, quoted in the report."""
    progress: bool = True


@dataclass(frozen=True)
class Example:
    """One test image with its truth and each regime's prediction, for a figure."""

    title: str
    image: np.ndarray
    truth: np.ndarray
    predictions: dict[str, np.ndarray] = field(default_factory=dict)


def set_torch_threads() -> int:
    """Let torch use every core this process may run on (data preparation has finished)."""
    import torch

    torch.set_num_threads(available_cores())
    return torch.get_num_threads()


def example_index(labels: np.ndarray) -> int:
    """The image whose smaller vessel is largest (both vessels well in view)."""
    artery = (labels == ARTERY).reshape(len(labels), -1).sum(axis=1)
    vein = (labels == VEIN).reshape(len(labels), -1).sum(axis=1)
    return int(np.argmax(np.minimum(artery, vein)))


def _relabelled(sets, subject: str):
    """The sets with their subject id replaced (two scans of one phantom are two 'subjects')."""
    from resus.segmentation.data import LabelledImages

    return tuple(LabelledImages(s.images, s.labels, subject, s.source) for s in sets)


PHANTOM_TRAINING = {"us": "frames", "resus": "frames + reslices"}
"""Phantom table rows: regime -> what it trains on (scan A)."""
PHANTOM_TESTS = ("frames", "frames + reslices")
"""Phantom table columns: what it is scored on (scan B)."""


def _run_record(
    options: RunOptions, device: torch.device, threads: int, start: float, prepared: float
) -> RunRecord:
    """How the run went: data time from `start` to `prepared`, training time until now."""
    return RunRecord(
        device=str(device),
        torch_threads=threads,
        command=options.command,
        data_folder=str(options.data),
        data_seconds=round(prepared - start, 1),
        training_seconds=round(time.perf_counter() - prepared, 1),
    )


def run_phantom_experiment(preset: ExperimentPreset, options: RunOptions) -> PhantomResults:
    """Table I analogue; writes the report to `options.out` and returns what results.json
    holds (`.to_dict()`)."""
    from resus.experiments.report import ReportFigures, write_phantom_report
    from resus.segmentation.loaders import load_reslice_sets, load_sweep_frames
    from resus.segmentation.loso import Split, hold_out_tail, pooled_iou, run_regime
    from resus.segmentation.model import resolve_device

    start = time.perf_counter()
    scan_a, scan_b = preset.phantom_scans
    scans = [Scan("phantom_scan_a", None, scan_a), Scan("phantom_scan_b", None, scan_b)]
    data = prepare_scans(
        options.data, scans, preset.scans, jobs=options.jobs, progress=options.progress
    )
    prepared = time.perf_counter()
    threads = set_torch_threads()
    device = resolve_device(options.device)
    frames = {
        name: _relabelled(load_sweep_frames([d.sweep]), f"scan {name}")
        for name, d in zip("AB", data, strict=True)
    }
    reslices = {
        name: _relabelled(load_reslice_sets([d.reslices]), f"scan {name}")
        for name, d in zip("AB", data, strict=True)
    }
    train, validation = hold_out_tail(frames["A"], preset.training.validation_fraction)
    split = Split("scan B", tuple(train), tuple(validation), reslices=reslices["A"])
    tests = {PHANTOM_TESTS[0]: frames["B"], PHANTOM_TESTS[1]: frames["B"] + reslices["B"]}
    frame_example, reslice_example = frames["B"][0], reslices["B"][0]
    examples = [
        _example("scan B frame", frame_example),
        _example("scan B reslice", reslice_example),
    ]
    table: dict[str, dict[str, list[VesselIoU]]] = {}
    histories = {}
    for regime, trained_on in PHANTOM_TRAINING.items():
        table[trained_on] = {test: [] for test in tests}
        for repeat in range(preset.repeats):
            run = run_regime(
                split,
                regime,
                preset.training,
                seed=options.seed + repeat,
                device=device,
                progress=options.progress,
            )
            for test, sets in tests.items():
                table[trained_on][test].append(
                    pooled_iou(run.training.model, sets, preset.training)
                )
            if repeat == 0:
                histories[trained_on] = run.training
                _predict_examples(examples, trained_on, run.training.model, preset.training)
    results = PhantomResults(
        preset=preset,
        seeds=tuple(options.seed + r for r in range(preset.repeats)),
        scans={
            name: ScanImages(
                d.subject, sum(len(s) for s in frames[name]), sum(len(s) for s in reslices[name])
            )
            for name, d in zip("AB", data, strict=True)
        },
        training_frames=len(train[0]),
        validation_frames=len(validation[0]),
        iou={
            trained_on: {test: IoUSummary.of(runs) for test, runs in row.items()}
            for trained_on, row in table.items()
        },
        run=_run_record(options, device, threads, start, prepared),
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
    from resus.segmentation.loso import RegimeRun, run_loso, subjects_of
    from resus.segmentation.model import resolve_device

    subjects = tuple(preset.subjects if subjects is None else subjects)
    if len(subjects) < 2:
        raise ResusError(f"leave-one-subject-out needs at least 2 subjects, got {subjects}")
    if encoder_weights is not None and not Path(encoder_weights).is_file():
        raise ResusError("no such encoder weights file", encoder_weights)
    start = time.perf_counter()
    data = prepare_subjects(
        options.data, subjects, preset.scans, jobs=options.jobs, progress=options.progress
    )
    prepared = time.perf_counter()
    threads = set_torch_threads()
    device = resolve_device(options.device)
    frames = load_sweep_frames([d.sweep for d in data])
    reslices = load_reslice_sets([d.reslices for d in data])
    ids = subjects_of(frames)
    training = preset.training
    example_set = next(s for s in frames if s.subject == ids[0])
    examples = [_example(f"held-out subject {ids[0]}, frame", example_set)]
    validation_iou: dict[str, dict[str, VesselIoU]] = {}
    training_images: dict[str, dict[str, int]] = {}
    histories = {}

    def record(regime: str, subject: str, run: RegimeRun) -> None:
        """Keep each run's best validation IoU and training size; curves and example
        predictions of the first held-out subject."""
        validation_iou.setdefault(regime, {})[subject] = run.training.best.validation_iou
        training_images.setdefault(regime, {})[subject] = run.training.config["train_images"]
        if subject == ids[0]:
            histories[regime] = run.training
            _predict_examples(examples, regime, run.training.model, training)

    result = run_loso(
        frames,
        reslices,
        regimes,
        training,
        seed=options.seed,
        device=device,
        encoder_weights=encoder_weights,
        progress=options.progress,
        on_run=record,
    )
    results = SubjectsResults(
        preset=preset,
        seed=options.seed,
        subject_numbers=subjects,
        images=tuple(
            ScanImages(s.subject, len(s), len(r)) for s, r in zip(frames, reslices, strict=True)
        ),
        loso=result,
        validation_iou=validation_iou,
        training_images=training_images,
        generalisation=generalisation_check(result, validation_iou),
        run=_run_record(options, device, threads, start, prepared),
    )
    write_subjects_report(options.out, results, ReportFigures(examples, histories))
    return results


GAP_THRESHOLD = 0.05
"""Mean-IoU drop (or spread over subjects) above which subjects count as really different."""


def generalisation_check(
    loso: LosoResult, validation_iou: dict[str, dict[str, VesselIoU]]
) -> GeneralisationCheck | None:
    """Do the subjects differ enough that generalising across them is a real problem?

    Compares the `us` regime's IoU on its training subjects' held-out validation frames
    (within-subject) with its IoU on the held-out subject, and the spread over subjects;
    None when the `us` regime did not run.
    """
    if "us" not in loso.iou:
        return None
    test = [iou.mean for iou in loso.iou["us"].values()]
    within = [iou.mean for iou in validation_iou["us"].values()]
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
