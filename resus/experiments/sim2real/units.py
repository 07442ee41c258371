"""The sim-to-real experiment's training runs as independent, resumable units.

Two kinds: the simulation-only training (one unit, its outputs in `OUT/sim_only/`) and each
fine-tuning of the few-label curve (`OUT/few_label/INITIALISATION_kK_splitS/`). A unit reads
what it needs from files (the sweeps, the real image folders, the simulation-only
checkpoint), so it runs wherever they are visible: this process, a worker process, a Ray node
with them on a shared filesystem. Each writes `unit.json` last, keyed by everything its result
depends on (the real images by their content, torch's thread count included), so a rerun
skips every finished unit and a unit's result does not depend on the engine that ran it.
"""

from __future__ import annotations

import hashlib
from dataclasses import dataclass
from pathlib import Path

import numpy as np

from resus.execution import UnitRecord
from resus.experiments.sim2real.few_label import (
    FROM_SIMULATION,
    RealSplit,
    fine_tune,
    rehearsal_frames,
    vessel_scores,
)
from resus.experiments.sim2real.settings import Sim2RealSettings
from resus.segmentation.folders import FolderImages

FEW_LABEL_FOLDER = "few_label"
UNIT_RECORD, EXAMPLES, CHECKPOINT = "unit.json", "examples.npz", "checkpoint.pt"


def images_digest(images: FolderImages) -> str:
    """SHA-256 of the images' names, pixels and labels: a real set is known by its content,
    not by where it lies."""
    digest = hashlib.sha256()
    for name, image, labels in zip(images.names, images.images, images.labels, strict=True):
        for part in (name.encode(), str(image.shape).encode(), image.tobytes(), labels.tobytes()):
            digest.update(part)
    return digest.hexdigest()


@dataclass(frozen=True)
class SimOnlyUnit:
    """The U-Net trained on the simulated sweeps alone."""

    sweeps: tuple[Path, ...]
    sweep_provenance: tuple[dict, ...]
    """What each sweep was made from (`sweep_provenance`): the data part of the key."""
    settings: Sim2RealSettings
    seed: int
    device: str
    """As asked ("auto", "cpu", "cuda"); resolved where the unit runs."""
    folder: Path
    progress: bool = False
    """Show the epochs (in this process only: a worker's output is not a terminal)."""

    def key(self) -> dict:
        return {
            "unit": "simulation only",
            "settings": self.settings.simulation_only_key(),
            "seed": self.seed,
            "sweeps": list(self.sweep_provenance),
            "device": self.device,
            "torch_threads": self.settings.training_cpus,
        }

    @property
    def checkpoint(self) -> Path:
        return self.folder / CHECKPOINT

    def record(self) -> UnitRecord:
        return UnitRecord(self.folder / UNIT_RECORD, self.key(), (self.checkpoint,))


def train_sim_only(unit: SimOnlyUnit) -> dict:
    """Run the unit: train on every sweep's frames (a validation tail held out), checkpoint
    the model (the best epoch's, or the weight average); its validation IoU and which epochs
    it comes from."""
    import torch

    from resus.segmentation.loaders import load_sweep_frames
    from resus.segmentation.loso import make_split, run_regime
    from resus.segmentation.model import resolve_device

    torch.set_num_threads(unit.settings.training_cpus)
    preset = unit.settings.simulation_training_preset()
    split = make_split(load_sweep_frames(unit.sweeps), [], None, preset.validation_fraction)
    run = run_regime(
        split,
        unit.settings.regime,
        preset,
        seed=unit.seed,
        device=resolve_device(unit.device),
        out_dir=unit.folder,
        progress=unit.progress,
    )
    average = run.training.weight_average
    if average is not None:
        return {
            "weight_average": average.to_dict(),
            "validation_iou": average.validation_iou.to_dict(),
        }
    best = run.training.best
    return {"best_epoch": best.epoch, "validation_iou": best.validation_iou.to_dict()}


@dataclass(frozen=True)
class FineTuneUnit:
    """One fine-tuning of the few-label curve: the first `labels` images of a split's pool,
    from the simulation-only weights or from random ones, scored on the split's test set."""

    image_folder: Path
    mask_folder: Path
    real_digest: str
    """`images_digest` of the real set, read again where the unit runs and checked."""
    split: RealSplit
    initialisation: str
    labels: int
    settings: Sim2RealSettings
    seed: int
    device: str
    sim_only: Path
    """The simulation-only checkpoint (read when starting from simulation)."""
    sweeps: tuple[Path, ...]
    """Its training sweeps, whose frames a fine-tuning from it rehearses (`rehearsal_frames`)."""
    sim_only_key: dict
    """The key of the unit that trained it (`SimOnlyUnit.key`): the sweeps it learnt from,
    down to the simulator that made them, so that a fine-tuning from an older model is not
    taken for one from this."""
    shown: tuple[int, ...]
    """Indices into the split's test set whose predicted labels are kept for the figure."""
    folder: Path

    def key(self) -> dict:
        """Everything the result depends on: from simulation, the simulation-only model
        (its unit's key) and what it rehearses; from scratch, neither."""
        settings = self.settings.fine_tuning_key()
        start = {"sim_only": self.sim_only_key}
        if self.initialisation != FROM_SIMULATION:
            del settings["rehearsal_images"]
            start = {}
        return {
            "unit": "fine-tuning",
            "real": self.real_digest,
            "split": {"pool": list(self.split.pool), "test": list(self.split.test)},
            "initialisation": self.initialisation,
            "labels": self.labels,
            "settings": settings,
            "seed": self.seed,
            "training_seed": self.training_seed,
            "device": self.device,
            "torch_threads": self.settings.training_cpus,
            "shown": list(self.shown),
            **start,
        }

    @property
    def training_seed(self) -> int:
        """A seed of its own per split and k (the two initialisations share it)."""
        return self.seed + 1000 * self.split.index + self.labels

    @property
    def examples(self) -> Path:
        return self.folder / EXAMPLES

    def record(self) -> UnitRecord:
        outputs = (self.examples,) if self.shown else ()
        return UnitRecord(self.folder / UNIT_RECORD, self.key(), outputs)


def fine_tune_unit(unit: FineTuneUnit) -> dict:
    """Run the unit: fine-tune, score on the split's test set (vessel IoU and Dice), keep the
    labels of the shown test images in examples.npz."""
    import torch

    from resus.errors import ResusError
    from resus.segmentation.folders import read_folders
    from resus.segmentation.model import resolve_device
    from resus.segmentation.trained_model import load_model

    torch.set_num_threads(unit.settings.training_cpus)
    device = resolve_device(unit.device)
    real = read_folders(unit.image_folder, unit.mask_folder)
    if images_digest(real) != unit.real_digest:
        raise ResusError("the real images changed while the experiment ran", unit.image_folder)
    from_simulation = unit.initialisation == FROM_SIMULATION
    initial = load_model(unit.sim_only, device) if from_simulation else None
    rehearsal = (
        rehearsal_frames(
            unit.sweeps,
            unit.settings.rehearsal_images,
            unit.training_seed,
            one_vessel_class=not real.separates_classes,
        )
        if from_simulation and unit.settings.rehearsal_images
        else []
    )
    model = fine_tune(
        real.subset(unit.split.pool[: unit.labels]),
        initial,
        unit.settings.training_preset(),
        unit.settings,
        seed=unit.training_seed,
        device=device,
        rehearsal=rehearsal,
    )
    evaluation, predicted = vessel_scores(model, real.subset(unit.split.test))
    if unit.shown:
        unit.folder.mkdir(parents=True, exist_ok=True)
        np.savez_compressed(unit.examples, *[predicted[i] for i in unit.shown])
    pooled = evaluation.pooled()["vessel"]
    return {"iou": pooled.iou, "dice": pooled.dice}


def read_examples(unit: FineTuneUnit) -> list[np.ndarray]:
    """The labels a finished unit gave its shown test images, in `shown` order."""
    with np.load(unit.examples) as saved:
        return [saved[f"arr_{i}"] for i in range(len(unit.shown))]
