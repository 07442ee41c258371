"""The whole experiment: sweeps, the simulation-only model, the curve, realism, the report."""

from __future__ import annotations

import dataclasses
from dataclasses import dataclass
from pathlib import Path

import torch

from resus.execution import Executor, make_executor
from resus.experiments.sim2real.few_label import (
    CurvePoint,
    RealSplit,
    curve_summary,
    few_label_curve,
    real_splits,
    vessel_scores,
)
from resus.experiments.sim2real.settings import Sim2RealSettings
from resus.experiments.sim2real.subjects import simulate_subjects, sweep_provenance
from resus.experiments.sim2real.units import CHECKPOINT, SimOnlyUnit, train_sim_only
from resus.segmentation.evaluate import Evaluation
from resus.segmentation.folders import FolderImages

SCHEMA = "resus.sim2real/1"
SIM_ONLY_FOLDER = "sim_only"
"""The simulation-only model's folder in the output."""


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
    from resus.experiments.sim2real.report import EXAMPLE_IMAGES, write_sim2real_report
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
        engine, train_sim_only, units, "simulation only", "run", settings.resources(), progress
    )
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
