"""The end-to-end demo: every stage of the pipeline on built-in defaults, into one folder.

Simulate sweeps of a few phantom subjects with the MuJoCo UR3e, reconstruct them, reslice the
volumes, train the quick U-Net with and without RESUS reslices on all but one subject with
several seeds, score every model on the held-out subject (each IoU a mean and a spread over
the seeds, the two regimes compared seed by seed), map the held-out subject's vessels from
the first seed's predictions, propose a needle site, and write a report, the meshes, the
volumes for 3D Slicer and a rerun recording of it all.
"""

from __future__ import annotations

import dataclasses
import itertools
import json
import sys
import time
from dataclasses import dataclass
from pathlib import Path
from typing import TYPE_CHECKING

import numpy as np

from resus.acquisition.patterns import LinearPattern
from resus.acquisition.safety import SafetyLimits
from resus.errors import ResusError
from resus.experiments.data import Scan, ScanSettings, SubjectData, placed_scan, prepare_scans
from resus.experiments.demo_report import render_report
from resus.experiments.results import MIN_SEEDS, IoUSummary, compare_models
from resus.sweep.model import Sweep
from sim.robot.scene_config import SceneConfig

if TYPE_CHECKING:  # torch is imported only when training starts
    from resus.segmentation.loso import RegimeRun
    from resus.segmentation.metrics import VesselIoU
    from resus.vessels.pipeline import VesselMapResult

DEMO_REGIMES = ("us", "resus")
"""Frames only, against frames plus reslices: the comparison RESUS is about (resus is a)."""
LABEL_SOURCES = ("ground_truth", *DEMO_REGIMES)
"""The held-out sweep's vessels are mapped from its true labels and from each model's."""
PICTURE_FRAMES = 3
"""Held-out frames shown with each model's prediction in predictions.png."""


@dataclass(frozen=True)
class DemoSettings:
    """Sizes of the demo; the defaults finish in a few minutes on 2 CPU cores."""

    subjects: tuple[int, ...] = (0, 1, 2)
    """Phantom subjects scanned; the last is held out for testing and mapping."""
    phantom: str = "femoral"
    """Phantom spec scanned (`assets/phantoms`): the in-vivo femoral triangle by default."""
    scanner: str | None = "vascular"
    """Scanner preset imaging every sweep (`sim.ultrasound.scanner.scanner_preset`; None:
    the simulator's own settings)."""
    image_size: int = 128
    """Probe image width and height (pixels)."""
    sweep_length: float = 0.05
    """Length of each linear sweep (m)."""
    contact_force: float = 1.5
    """Probe force of the sweeps (N): light, as a sonographer scans for vascular access, so the
    vein keeps its round lumen (at 4 N the femoral vein flattens to an axis ratio of 1.2-1.6,
    and the needle planner finds no round trunk station on it)."""
    max_epochs: int = 8
    """Epochs of the quick U-Net per regime."""
    seed: int = 0
    """First training seed (the phantoms are seeded by their subject numbers)."""
    seeds: int = 2
    """Training seeds per regime (seed, seed + 1, ...): each IoU is a mean and a spread over
    them; the first seed's models segment, map and appear in the pictures. Two keep the demo
    near 8 minutes on 2 CPU cores (each seed adds about 3.5)."""

    def __post_init__(self) -> None:
        if len(set(self.subjects)) != len(self.subjects) or len(self.subjects) < 2:
            raise ResusError(
                f"DemoSettings.subjects must be two or more distinct numbers, got {self.subjects}"
            )
        if min(self.subjects) < 0:
            raise ResusError(f"DemoSettings.subjects must not be negative, got {self.subjects}")
        if self.image_size < 32:
            raise ResusError(f"DemoSettings.image_size must be at least 32, got {self.image_size}")
        if not self.sweep_length > 0:
            raise ResusError(f"DemoSettings.sweep_length must be positive, got {self.sweep_length}")
        if not 0 < self.contact_force < SafetyLimits().max_force:
            raise ResusError(
                f"DemoSettings.contact_force must be in (0, {SafetyLimits().max_force}) N (the "
                f"scanner's force limit), got {self.contact_force}"
            )
        if self.max_epochs < 1:
            raise ResusError(f"DemoSettings.max_epochs must be at least 1, got {self.max_epochs}")
        if self.seeds < MIN_SEEDS:
            raise ResusError(
                f"DemoSettings.seeds must be at least {MIN_SEEDS} (a seed spread needs two "
                f"seeds), got {self.seeds}"
            )
        self.scan_settings()  # the phantom and scanner are checked there, before any work

    def training_seeds(self) -> tuple[int, ...]:
        """The seeds each regime is trained with."""
        return tuple(self.seed + k for k in range(self.seeds))

    def scans(self) -> list[Scan]:
        """One sweep per subject, centred on its artery and vein (`placed_scan`)."""
        settings = self.scan_settings()
        return [placed_scan(f"subject_{s:02d}", s, settings) for s in self.subjects]

    def scan_settings(self) -> ScanSettings:
        sweep = LinearPattern(
            start=(0.0, -self.sweep_length / 2),
            length=self.sweep_length,
            contact_force=self.contact_force,
        )
        return ScanSettings(
            phantom=self.phantom,
            scanner=self.scanner,
            centre_on_vessels=True,
            cols=self.image_size,
            rows=self.image_size,
            sweep=sweep,
        )


@dataclass(frozen=True)
class DemoResult:
    """Where the demo put things, and its headline numbers."""

    folder: Path
    report: Path
    recording: Path
    summary: dict
    timings: dict
    """Wall time per stage (timings.json), kept apart so summary.json is reproducible."""


class _Stopwatch:
    """Wall time of each stage, in the order they ran."""

    def __init__(self) -> None:
        self.seconds: dict[str, float] = {}
        self._last = time.perf_counter()

    def lap(self, stage: str) -> None:
        now = time.perf_counter()
        self.seconds[stage] = round(now - self._last, 1)
        self._last = now

    def timings(self) -> dict:
        """timings.json's content: `seconds` per stage and `total_seconds`."""
        return {"seconds": self.seconds, "total_seconds": round(sum(self.seconds.values()), 1)}


def run_demo(
    folder: str | Path, settings: DemoSettings | None = None, progress: bool = True
) -> DemoResult:
    """Run the whole pipeline into `folder` (created; prepared scans already there are reused)."""
    from resus.experiments.tables import set_torch_threads

    settings = settings or DemoSettings()
    folder = Path(folder)
    if folder.exists() and not folder.is_dir():
        raise ResusError("output is a file, not a folder", folder)
    folder.mkdir(parents=True, exist_ok=True)
    clock = _Stopwatch()
    data = prepare_scans(
        folder / "data", settings.scans(), settings.scan_settings(), progress=progress
    )
    clock.lap("simulate, reconstruct, reslice")
    set_torch_threads()
    runs = _train_regimes(folder / "models", data, settings, progress)
    clock.lap("train")
    test = _HeldOut.load(data[-1])
    predictions = {regime: _segment(seeded[0], test.sweep) for regime, seeded in runs.items()}
    clock.lap("segment")
    vessels = _map_vessels(folder / "vessels", test, predictions, progress)
    clock.lap("vessel maps")
    pictures = _pictures(folder, test, predictions)
    recording = _record(folder / "demo.rrd", test, predictions, runs["resus"][0])
    clock.lap("pictures and rerun recording")
    summary = _summary(folder, settings, data, runs, vessels, pictures)
    (folder / "summary.json").write_text(json.dumps(summary, indent=2) + "\n")
    timings = clock.timings()
    (folder / "timings.json").write_text(json.dumps(timings, indent=2) + "\n")
    report = folder / "report.md"
    report.write_text(render_report(summary, timings))
    return DemoResult(folder, report, recording, summary, timings)


@dataclass(frozen=True)
class _HeldOut:
    """The held-out subject's files, its sweep and the scene it was scanned in."""

    files: SubjectData
    sweep: Sweep
    scene: SceneConfig
    labels: np.ndarray
    """The sweep's true labels (`sweep.labels`, checked to be there)."""

    @classmethod
    def load(cls, files: SubjectData) -> _HeldOut:
        from resus.acquisition.simulation import parse_subject_id, resolve_scene
        from resus.sweep.io import read_sweep

        sweep = read_sweep(files.sweep)
        phantom, subject = parse_subject_id(sweep.subject)
        scene = resolve_scene("default", phantom, subject)
        if sweep.labels is None:
            raise ResusError("the held-out sweep has no labels", files.sweep)
        return cls(files, sweep, scene, sweep.labels)


def _train_regimes(
    folder: Path, data: list[SubjectData], settings: DemoSettings, progress: bool
) -> dict[str, list[RegimeRun]]:
    """Quick U-Nets for frames only and frames plus reslices, one per seed, tested on the
    last subject; checkpoints and curves in `folder/REGIME/seedN/`."""
    from tqdm import tqdm

    from resus.segmentation.loaders import load_reslice_sets, load_sweep_frames
    from resus.segmentation.loso import make_split, run_regime
    from resus.segmentation.presets import QUICK

    preset = dataclasses.replace(QUICK, max_epochs=settings.max_epochs)
    frames = load_sweep_frames([d.sweep for d in data])
    reslices = load_reslice_sets([d.reslices for d in data])
    split = make_split(frames, reslices, data[-1].subject, preset.validation_fraction)
    seeds = settings.training_seeds()
    runs: dict[str, list[RegimeRun]] = {}
    for k, (regime, seed) in enumerate(itertools.product(DEMO_REGIMES, seeds), start=1):
        if progress:
            count = len(DEMO_REGIMES) * len(seeds)
            tqdm.write(f"training {regime}, seed {seed} ({k} of {count})", file=sys.stderr)
        out = folder / regime / f"seed{seed}"
        out.mkdir(parents=True, exist_ok=True)
        runs.setdefault(regime, []).append(
            run_regime(split, regime, preset, seed=seed, out_dir=out, progress=progress)
        )
    return runs


def _segment(run: RegimeRun, sweep: Sweep) -> np.ndarray:
    """A trained model's labels for every frame of the held-out sweep."""
    from resus.segmentation.inference import predict

    image_size = run.training.config["model"]["image_size"]
    return predict(run.training.model, sweep.frames, image_size=image_size)


def _map_vessels(
    folder: Path, test: _HeldOut, predictions: dict[str, np.ndarray], progress: bool
) -> dict[str, VesselMapResult]:
    """Vessel maps of the held-out sweep from its true labels and from each model's, under
    one progress bar."""
    from resus.vessels.pipeline import map_progress, map_vessels

    labels = {"ground_truth": test.labels, **predictions}
    sweep_name = str(test.files.sweep.relative_to(folder.parent))
    with map_progress(len(LABEL_SOURCES), progress) as bar:
        return {
            source: map_vessels(
                test.sweep,
                labels[source],
                test.scene,
                folder / source,
                {"sweep": sweep_name, "labels": source},
                progress=bar,
            )
            for source in LABEL_SOURCES
        }


def _pictures(folder: Path, test: _HeldOut, predictions: dict[str, np.ndarray]) -> list[str]:
    """The held-out volume's slices, its reslices and predictions on a few of its frames."""
    from resus.experiments.report import save_prediction_figure
    from resus.experiments.tables import Example, example_index
    from resus.reconstruction.figures import save_slices_png
    from resus.reconstruction.io import read_volume
    from resus.reslicing.dataset import ResliceDataset
    from resus.reslicing.sheet import save_contact_sheet

    volume, grid, _ = read_volume(test.files.volume)
    labels, _, _ = read_volume(test.files.labels)
    save_slices_png(folder / "volume.png", volume, grid, labels, title="held-out volume")
    with ResliceDataset(test.files.reslices) as reslices:
        chosen = np.linspace(0, len(reslices) - 1, min(12, len(reslices))).round().astype(int)
        save_contact_sheet(
            folder / "reslices.png", [reslices[int(i)] for i in chosen], title="held-out reslices"
        )
    truth = test.labels
    best = example_index(truth)
    indices = sorted({best, len(truth) // 4, 3 * len(truth) // 4})[:PICTURE_FRAMES]
    examples = [
        Example(
            f"frame {index}",
            test.sweep.frames[index],
            truth[index],
            {regime: labels[index] for regime, labels in predictions.items()},
        )
        for index in indices
    ]
    save_prediction_figure(folder / "predictions.png", examples, "held-out subject")
    return ["volume.png", "reslices.png", "predictions.png"]


def _record(
    path: Path, test: _HeldOut, predictions: dict[str, np.ndarray], resus_run: RegimeRun
) -> Path:
    """One rerun recording: the held-out scan with the RESUS model's predictions, its volume,
    reslices, phantom, vessel maps and the RESUS model's training curves (first seed)."""
    from resus.acquisition.simulation import phantom_spec
    from resus.reconstruction.io import read_volume
    from resus.reslicing.dataset import ResliceDataset
    from resus.visualize import (
        log_phantom,
        log_reslices,
        log_sweep,
        log_training_curves,
        log_vessel_map,
        log_volume,
        make_blueprint,
        open_recording,
    )
    from sim.phantom import Phantom

    volume, grid, _ = read_volume(test.files.volume)
    labels, _, _ = read_volume(test.files.labels)
    middle = test.sweep.probe_to_base[len(test.sweep) // 2, :3, 3]
    blueprint = make_blueprint(reslices=True, training=True, look_at=middle)
    with open_recording("resus-demo", save=path, blueprint=blueprint) as session:
        log_sweep(session.stream, test.sweep, predictions=predictions["resus"])
        log_phantom(session.stream, test.scene, Phantom(phantom_spec(test.scene)))
        log_volume(session.stream, volume, grid, labels)
        with ResliceDataset(test.files.reslices) as reslices:
            log_reslices(session.stream, reslices, test.sweep.label_names, limit=100)
        for source in LABEL_SOURCES:
            log_vessel_map(session.stream, path.parent / "vessels" / source, source)
        history = [record.to_dict() for record in resus_run.training.history]
        log_training_curves(session.stream, history)
    return path


def _summary(
    folder: Path,
    settings: DemoSettings,
    data: list[SubjectData],
    runs: dict[str, list[RegimeRun]],
    vessels: dict[str, VesselMapResult],
    pictures: list[str],
) -> dict:
    """Everything the report shows, as written to summary.json (paths relative to `folder`):
    `seeds`, `iou[regime]` cells and `comparisons` (resus against us, one per IoU metric) as
    `resus.experiments.results` documents them, `best_epoch[regime]` per seed, `mapped_seed`
    (whose models segmented, mapped and made the pictures), `vessels`, `files`. No wall times
    (those are in timings.json): the same settings give the same summary.json on any run."""
    test = data[-1]
    seeds = settings.training_seeds()
    iou = {
        regime: IoUSummary.of([_test_iou(run) for run in seeded]) for regime, seeded in runs.items()
    }
    models = [f"models/{regime}/seed{seed}" for regime in runs for seed in seeds]
    return {
        "settings": dataclasses.asdict(settings),
        "subjects": [d.subject for d in data],
        "test_subject": test.subject,
        "frames": {
            "test": _frame_count(test.sweep),
            "train": sum(_frame_count(d.sweep) for d in data[:-1]),
        },
        "seeds": list(seeds),
        "iou": {regime: cell.to_dict() for regime, cell in iou.items()},
        "comparisons": [
            comparison.to_dict()
            for comparison in compare_models("resus", "us", [iou["resus"]], [iou["us"]])
        ],
        "best_epoch": {
            regime: [run.training.best_epoch for run in seeded] for regime, seeded in runs.items()
        },
        "mapped_seed": seeds[0],
        "vessels": {
            source: {
                "scores": result.scores_to_dict(),
                "needle": result.needle.to_dict(),
                "needle_truth": None
                if result.needle_truth is None
                else result.needle_truth.to_dict(),
                "anatomy": result.anatomy,
            }
            for source, result in vessels.items()
        },
        "files": {
            "pictures": pictures,
            "curves": [f"{model}/curves.png" for model in models],
            "checkpoints": [f"{model}/checkpoint.pt" for model in models],
            "vessel_pictures": [
                f"vessels/{source}/{name}"
                for source in vessels
                for name in ("vessel_map.png", "needle.png")
            ],
            "meshes": [
                f"vessels/{source}/{name}"
                for source, result in vessels.items()
                for name in result.files
                if name.endswith((".stl", ".ply", ".glb"))
            ],
            "volumes": [
                str(path.relative_to(folder)) for d in data for path in (d.volume, d.labels)
            ]
            + [f"vessels/{source}/vessel_labels.nrrd" for source in vessels],
            "test_volume": str(test.volume.relative_to(folder)),
            "sweeps": [str(d.sweep.relative_to(folder)) for d in data],
            "recording": "demo.rrd",
        },
    }


def _test_iou(run: RegimeRun) -> VesselIoU:
    """A demo run's IoU on the held-out subject (every demo run has one: its split tests the
    last subject)."""
    assert run.test_iou is not None
    return run.test_iou


def _frame_count(sweep_path: Path) -> int:
    from resus.sweep.io import SweepReader

    with SweepReader(sweep_path) as reader:
        return len(reader)
