"""What the experiments return, typed; `to_dict()` gives results.json's content.

The reports are rendered from that same dictionary (`resus.experiments.report`), so the
numbers in report.md and in results.json always agree.
"""

from __future__ import annotations

from collections.abc import Sequence
from dataclasses import asdict, dataclass
from typing import TYPE_CHECKING

import numpy as np

from resus.segmentation.metrics import IOU_METRICS, VesselIoU

if TYPE_CHECKING:  # loso needs torch; the results only hold its outcome
    from resus.experiments.tables import ExperimentPreset
    from resus.segmentation.loso import LosoResult

NOT_CHECKED = "not checked: the us regime did not run"
"""results.json's generalisation verdict when the check could not be made."""


@dataclass(frozen=True)
class RunRecord:
    """How an experiment ran: on what, where, from which command, and how long each half
    took."""

    device: str
    torch_threads: int
    command: str
    data_folder: str
    data_seconds: float
    """Simulating, reconstructing and reslicing (cached scans take no time)."""
    training_seconds: float
    """Training and scoring (finished runs of an earlier attempt take no time)."""
    executor: str = "local"
    """Where the units ran (`Executor.describe()`)."""

    def environment(self) -> dict:
        """results.json's device, torch_threads, executor, command and data_folder."""
        return {
            "device": self.device,
            "torch_threads": self.torch_threads,
            "executor": self.executor,
            "command": self.command,
            "data_folder": self.data_folder,
        }

    def seconds(self) -> dict[str, float]:
        """results.json's seconds."""
        return {"data": self.data_seconds, "training": self.training_seconds}


@dataclass(frozen=True)
class ScanImages:
    """How many frames and reslices one scan (one subject) gave."""

    subject: str
    frames: int
    reslices: int


@dataclass(frozen=True)
class IoUSummary:
    """One phantom-table cell: each training seed's IoU, and the mean and standard deviation
    over the seeds of each IoU metric."""

    runs: tuple[VesselIoU, ...]
    artery: float
    artery_std: float
    vein: float
    vein_std: float
    mean: float
    mean_std: float

    @classmethod
    def of(cls, runs: Sequence[VesselIoU]) -> IoUSummary:
        statistics = {}
        for metric in IOU_METRICS:
            values = [run.to_dict()[metric] for run in runs]
            statistics[metric] = float(np.mean(values))
            statistics[f"{metric}_std"] = float(np.std(values))
        return cls(tuple(runs), **statistics)

    def to_dict(self) -> dict:
        data: dict = {"runs": [run.to_dict() for run in self.runs]}
        for metric in IOU_METRICS:
            data[metric] = getattr(self, metric)
            data[f"{metric}_std"] = getattr(self, f"{metric}_std")
        return data


@dataclass(frozen=True)
class PhantomResults:
    """Table I analogue: models trained on scan A's frames (or frames + reslices), scored on
    scan B's frames (or frames + reslices)."""

    preset: ExperimentPreset
    seeds: tuple[int, ...]
    scans: dict[str, ScanImages]
    """Scan "A" (training) and "B" (test)."""
    training_frames: int
    validation_frames: int
    iou: dict[str, dict[str, IoUSummary]]
    """What the model trained on -> what it was scored on -> the cell."""
    run: RunRecord

    def to_dict(self) -> dict:
        """JSON-able form, as results.json holds it."""
        return {
            "experiment": "phantom",
            "preset": self.preset.to_dict(),
            "seeds": list(self.seeds),
            **self.run.environment(),
            "scans": {name: asdict(scan) for name, scan in self.scans.items()},
            "training_images": {
                "frames": self.training_frames,
                "validation_frames": self.validation_frames,
            },
            "iou": {
                trained_on: {test: cell.to_dict() for test, cell in row.items()}
                for trained_on, row in self.iou.items()
            },
            "seconds": self.run.seconds(),
        }


@dataclass(frozen=True)
class GeneralisationCheck:
    """Whether the subjects differ enough that generalising across them is a real problem:
    the `us` regime within its training subjects against on the held-out subject."""

    us_within_subject_iou: float
    us_held_out_subject_iou: float
    gap: float
    """Within-subject minus held-out mean IoU."""
    held_out_iou_std_over_subjects: float
    threshold: float
    subjects_differ_enough: bool
    """Gap or spread above the threshold."""

    def to_dict(self) -> dict:
        return asdict(self)


@dataclass(frozen=True)
class SubjectsResults:
    """Table II analogue: leave-one-subject-out per regime, with paired t-tests."""

    preset: ExperimentPreset
    seed: int
    subject_numbers: tuple[int, ...]
    images: tuple[ScanImages, ...]
    """Frames and reslices of each subject."""
    loso: LosoResult
    validation_iou: dict[str, dict[str, VesselIoU]]
    """Regime -> held-out subject -> best-epoch IoU on the training subjects' validation tail."""
    training_images: dict[str, dict[str, int]]
    """Regime -> held-out subject -> images the model trained on."""
    generalisation: GeneralisationCheck | None
    """None when the `us` regime did not run."""
    run: RunRecord

    def to_dict(self) -> dict:
        """JSON-able form, as results.json holds it."""
        return {
            "experiment": "subjects",
            "preset": self.preset.to_dict(),
            "seed": self.seed,
            **self.run.environment(),
            "subject_numbers": list(self.subject_numbers),
            "images_per_subject": {
                scan.subject: {"frames": scan.frames, "reslices": scan.reslices}
                for scan in self.images
            },
            "loso": self.loso.to_dict(),
            "validation_iou": {
                regime: {subject: iou.to_dict() for subject, iou in per_subject.items()}
                for regime, per_subject in self.validation_iou.items()
            },
            "training_images": {
                regime: dict(per_subject) for regime, per_subject in self.training_images.items()
            },
            "generalisation": {"verdict": NOT_CHECKED}
            if self.generalisation is None
            else self.generalisation.to_dict(),
            "seconds": self.run.seconds(),
        }
