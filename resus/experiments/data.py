"""Experiment data: simulated scans, each reconstructed and resliced, ready for training.

One scan = one simulated linear sweep of a phantom subject (`sweep.h5`), its SDW volume and
label volume (`volume.nrrd`, `labels.nrrd`) and the reslices of that volume (`reslices.h5`),
all in one folder. Scans are independent units, prepared by an executor (`resus.execution`):
worker processes of this machine, one per core by default, or a Ray cluster.

Every stage is cached: a folder's `scan.json` records the settings each stage ran with (for
the simulation, the scene's content, a digest of the phantom spec's files, the scanner
preset's knobs and the simulator's fingerprint too: `world_key`), and a stage whose files
exist and whose recorded settings equal the requested ones is skipped. The record is written
only after a stage finishes, so a crashed or interrupted stage runs again.
"""

from __future__ import annotations

import dataclasses
from collections.abc import Sequence
from dataclasses import dataclass, field
from pathlib import Path

from resus.acquisition.patterns import LinearPattern
from resus.errors import ResusError, check_choice, simulator_errors
from resus.execution import (
    Executor,
    as_json,
    limit_numba_threads,
    make_executor,
    read_json,
    write_json,
)
from resus.reconstruction.compounding import ReconstructionSettings
from resus.reconstruction.grid_settings import GRIDS, GridSettings
from resus.reslicing.reslice import ResliceSettings
from sim.labels import LABEL_NAMES
from sim.phantom.loader import load_phantom
from sim.ultrasound.scanner import ScannerPreset, scanner_preset

RECORD = "scan.json"


@dataclass(frozen=True)
class ScanSettings:
    """How every scan of an experiment is simulated, reconstructed and resliced."""

    scene: str = "default"
    """Scene name (assets/scenes) or YAML path; its phantom is scanned."""
    phantom: str | None = None
    """Phantom spec name or YAML path scanned in the scene instead of its own (None: the
    scene's)."""
    scanner: str | None = None
    """Scanner preset name or YAML file (`sim.ultrasound.scanner.scanner_preset`) imaging
    every scan at its frequency, depth and image settings; None: the simulator's own
    settings."""
    cols: int = 256
    """Probe image width (pixels)."""
    rows: int = 256
    """Probe image height (pixels)."""
    sweep: LinearPattern = field(default_factory=LinearPattern)
    """The default linear sweep (a scan may replace it)."""
    centre_on_vessels: bool = False
    """Move every scan's sweep across by where its subject's artery and vein lie at the
    default sweep's middle (`vessel_midline`), as a sonographer places the probe: an in-vivo
    phantom's vessels lie anywhere across the groin, the gel block's under its middle."""
    grid: str = "ransac"
    """Volume grid: "ransac" (the paper's parallelepiped) or "aabb" (axis-aligned box)."""
    spacing: float = 0.5e-3
    """Voxel spacing (m)."""
    reconstruction: ReconstructionSettings = field(default_factory=ReconstructionSettings)
    reslice: ResliceSettings = field(default_factory=ResliceSettings)

    def __post_init__(self) -> None:
        check_choice("ScanSettings.grid", self.grid, GRIDS)
        if self.phantom is not None:
            with simulator_errors("ScanSettings.phantom"):
                load_phantom(self.phantom)
        if self.scanner is not None:
            with simulator_errors("ScanSettings.scanner"):
                scanner_preset(self.scanner)
        if not self.spacing > 0:
            raise ResusError(f"ScanSettings.spacing must be positive, got {self.spacing}")
        if self.cols < 2 or self.rows < 2:
            raise ResusError(
                f"ScanSettings.cols and rows must be at least 2, got {self.cols} x {self.rows}"
            )

    @property
    def preset(self) -> ScannerPreset | None:
        """`scanner` as a preset (None: the simulator's own settings)."""
        return None if self.scanner is None else scanner_preset(self.scanner)

    def to_dict(self) -> dict:
        """JSON-able form (tuples become lists)."""
        return as_json(dataclasses.asdict(self))


@dataclass(frozen=True)
class Scan:
    """One scan to prepare: a phantom subject (None: the nominal phantom) and its sweep."""

    name: str
    """Folder name under the data folder."""
    subject: int | None
    sweep: LinearPattern | None = None
    """None: the settings' default sweep."""


def placed_scan(
    name: str, subject: int | None, settings: ScanSettings, sweep: LinearPattern | None = None
) -> Scan:
    """The scan of `subject` along `sweep` (None: the settings' default), moved across onto the
    subject's vessels when `settings.centre_on_vessels` asks. Every sweep of one subject moves
    by the same amount, measured at the default sweep's middle, so scans placed apart (Table
    I's scan B, 4 mm aside of scan A) stay apart."""
    sweep = sweep or settings.sweep
    if settings.centre_on_vessels:
        from resus.acquisition.simulation import phantom_spec, resolve_scene
        from resus.experiments.vessel_targets import vessel_midline

        spec = phantom_spec(resolve_scene(settings.scene, settings.phantom, subject))
        x, y = settings.sweep.middle
        shift = vessel_midline(spec, float(y)) - float(x)
        sweep = dataclasses.replace(sweep, start=(sweep.start[0] + shift, sweep.start[1]))
    return Scan(name, subject, sweep)


@dataclass(frozen=True)
class SubjectData:
    """Files of one prepared scan, and the subject id its frames and reslices carry."""

    subject: str
    """Subject id as written in the sweep (e.g. "default/3"), used by LOSO splits."""
    sweep: Path
    volume: Path
    labels: Path
    reslices: Path


def prepare_subjects(
    folder: str | Path,
    subjects: Sequence[int],
    settings: ScanSettings | None = None,
    *,
    jobs: int = 2,
    progress: bool = True,
    executor: Executor | None = None,
) -> list[SubjectData]:
    """Prepare one scan per phantom subject in `folder/subject_KK/` (see `prepare_scans`)."""
    settings = settings or ScanSettings()
    scans = [placed_scan(f"subject_{k:02d}", k, settings) for k in subjects]
    return prepare_scans(folder, scans, settings, jobs=jobs, progress=progress, executor=executor)


def prepare_scans(
    folder: str | Path,
    scans: Sequence[Scan],
    settings: ScanSettings | None = None,
    *,
    jobs: int = 2,
    progress: bool = True,
    executor: Executor | None = None,
) -> list[SubjectData]:
    """Simulate, reconstruct and reslice every scan (cached), one unit per scan that is not:
    on `executor`, or else `jobs` worker processes of this machine."""
    settings = settings or ScanSettings()
    folder = Path(folder)
    if folder.exists() and not folder.is_dir():
        raise ResusError("data folder is a file", folder)
    if len({scan.name for scan in scans}) != len(scans):
        raise ResusError("scan names must be unique")
    folder.mkdir(parents=True, exist_ok=True)
    work = [
        (folder / scan.name, scan, settings)
        for scan in scans
        if stale_stages(folder / scan.name, scan, settings)
    ]
    if work:  # a local executor holds nothing between maps: no need to close one made here
        engine = executor or make_executor("local", max(1, jobs))
        engine.map(_prepare_in_worker, work, "scans", "scan", progress=progress)
    return [_with_subject(_files(folder / scan.name)) for scan in scans]


def _prepare_in_worker(job: tuple[Path, Scan, ScanSettings]) -> None:
    """`prepare_scan` as a unit: in a worker, numba threads only the cores it was granted."""
    limit_numba_threads()
    prepare_scan(*job)


def stage_settings(scan: Scan, settings: ScanSettings) -> dict[str, dict]:
    """What each stage of `scan` depends on, as JSON values (the cache key of each stage)."""
    from resus.acquisition.simulation import resolve_scene, world_key

    scene = resolve_scene(settings.scene, settings.phantom, scan.subject)
    stages = {
        "simulate": {**world_key(scene, settings.preset),
                     "sweep": dataclasses.asdict(scan.sweep or settings.sweep),
                     "cols": settings.cols, "rows": settings.rows},
        "reconstruct": {"grid": settings.grid, "spacing": settings.spacing,
                        "settings": dataclasses.asdict(settings.reconstruction)},
        "reslice": dataclasses.asdict(settings.reslice),
    }  # fmt: skip
    return as_json(stages)


def stale_stages(out: Path, scan: Scan, settings: ScanSettings) -> list[str]:
    """Stages of `scan` in folder `out` that must (re)run: the first one whose files are
    missing or whose recorded settings differ, and every stage after it."""
    record = read_json(Path(out) / RECORD)
    data = _files(Path(out))
    outputs = {
        "simulate": [data.sweep],
        "reconstruct": [data.volume, data.labels],
        "reslice": [data.reslices],
    }
    stages = stage_settings(scan, settings)
    for index, (stage, wanted) in enumerate(stages.items()):
        if record.get(stage) != wanted or not all(p.is_file() for p in outputs[stage]):
            return list(stages)[index:]
    return []


def prepare_scan(out: Path, scan: Scan, settings: ScanSettings) -> SubjectData:
    """One scan's sweep, volumes and reslices in `out`, each stage skipped when cached."""
    out = Path(out)
    out.mkdir(parents=True, exist_ok=True)
    data = _files(out)
    steps = {"simulate": _simulate, "reconstruct": _reconstruct, "reslice": _reslice}
    wanted = stage_settings(scan, settings)
    for stage in stale_stages(out, scan, settings):
        record = read_json(out / RECORD)
        record.pop(stage, None)
        write_json(out / RECORD, record)
        steps[stage](data, scan, settings)
        write_json(out / RECORD, {**record, stage: wanted[stage]})
    return _with_subject(data)


def scan_record(data: SubjectData) -> dict:
    """The settings each stage of a prepared scan ran with (its scan.json)."""
    return read_json(data.sweep.parent / RECORD)


def _files(out: Path) -> SubjectData:
    return SubjectData("", out / "sweep.h5", out / "volume.nrrd", out / "labels.nrrd",
                       out / "reslices.h5")  # fmt: skip


def _with_subject(data: SubjectData) -> SubjectData:
    """`data` with the subject id its sweep file carries."""
    from resus.sweep.io import SweepReader

    with SweepReader(data.sweep) as reader:
        return dataclasses.replace(data, subject=reader.subject)


def _simulate(data: SubjectData, scan: Scan, settings: ScanSettings) -> None:
    from resus.acquisition.backends.simulated import SimulatedProbeConfig
    from resus.acquisition.simulation import resolve_scene, simulate_sweep
    from sim.ultrasound.probe import LinearProbe

    sweep = scan.sweep or settings.sweep
    probe = SimulatedProbeConfig(
        probe=LinearProbe(cols=settings.cols, rows=settings.rows), frame_rate=sweep.frame_rate
    )
    scene = resolve_scene(settings.scene, settings.phantom, scan.subject)
    simulate_sweep(data.sweep, scene, sweep, probe=probe, preset=settings.preset, progress=False)


def _reconstruct(data: SubjectData, scan: Scan, settings: ScanSettings) -> None:
    import numpy as np

    from resus.reconstruction.compounding import reconstruct
    from resus.reconstruction.io import intensity_to_uint8, write_volume
    from resus.sweep.io import read_sweep

    sweep = read_sweep(data.sweep)
    if sweep.labels is None or len(sweep.frames) < 2:
        raise ResusError("an experiment sweep needs at least 2 labelled frames", data.sweep)
    poses = np.asarray(sweep.probe_to_base)
    shape = tuple(sweep.frames.shape[1:])
    grid = GridSettings(settings.grid, settings.spacing).around(poses, sweep.image_to_probe, shape)
    names = list(sweep.label_names)
    result = reconstruct(
        sweep.frames, poses, sweep.image_to_probe, grid, settings.reconstruction,
        labels=sweep.labels, n_classes=len(names),
    )  # fmt: skip
    write_volume(data.volume, intensity_to_uint8(result.volume), grid)
    assert result.labels is not None  # labels (checked above) and their names were given
    write_volume(data.labels, result.labels, grid, names)


def _reslice(data: SubjectData, scan: Scan, settings: ScanSettings) -> None:
    from resus.reconstruction.io import read_volume
    from resus.reslicing.dataset import ResliceWriter
    from resus.reslicing.reslice import reslice_volume
    from resus.sweep.io import SweepReader

    volume, grid, _ = read_volume(data.volume)
    labels, _, names = read_volume(data.labels)
    with SweepReader(data.sweep) as reader:
        subject = reader.subject
    with ResliceWriter(
        data.reslices, settings.reslice, str(data.volume), subject, names or LABEL_NAMES
    ) as writer:
        for reslice in reslice_volume(volume, labels, grid, settings.reslice):
            writer.append(reslice)
