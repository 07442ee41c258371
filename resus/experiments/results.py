"""What the experiments return, typed; `to_dict()` gives results.json's content.

Every IoU is a figure over several training seeds (`IoUSummary`: each seed's value, the mean
and the sample standard deviation), and every comparison of two models weighs the difference
against that seed spread (`SeedComparison`). In results.json (and the demo's summary.json):

- an IoU cell: `runs` (per seed: `artery`, `vein`, `mean`), `n_seeds`, and `artery`,
  `artery_std`, `vein`, `vein_std`, `mean`, `mean_std` (mean and sample std over the seeds);
- a comparison: `a`, `b`, `metric`, `difference` (a - b, means over seeds), `seed_spread`,
  `verdict` ("no difference" or "NAME better"), and the paired t-test's `n`,
  `mean_difference`, `statistic`, `p_value`, `note`;
- phantom: top-level `seeds`, `iou[trained on][tested on]` cells, `comparisons[tested on]`;
- subjects: top-level `seeds`, `loso.regimes[regime].iou[subject]` and `.mean_over_subjects`
  cells (the average over subjects taken seed by seed), `loso.comparisons` (every pair of
  regimes, paired over held-out subject and seed), `validation_iou[regime][subject]` cells.

The reports are rendered from the same dictionary (`resus.experiments.report`,
`resus.experiments.demo_report`), so the numbers in report.md and in results.json agree.
"""

from __future__ import annotations

import itertools
from collections.abc import Sequence
from dataclasses import asdict, dataclass
from typing import TYPE_CHECKING

import numpy as np

from resus.errors import ResusError
from resus.segmentation.metrics import IOU_METRICS, VesselIoU
from resus.segmentation.stats import PairedTest, paired_t_test

if TYPE_CHECKING:
    from resus.experiments.tables import ExperimentPreset

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


MIN_SEEDS = 2
"""Training seeds a comparison needs: one seed gives no spread to weigh a difference against."""
NO_DIFFERENCE = "no difference"
"""A comparison's verdict when the difference is within the seed spread."""


@dataclass(frozen=True)
class IoUSummary:
    """One IoU figure over training seeds: each seed's IoU, and the mean and the sample
    standard deviation over the seeds of each IoU metric."""

    runs: tuple[VesselIoU, ...]
    artery: float
    artery_std: float
    vein: float
    vein_std: float
    mean: float
    mean_std: float

    @classmethod
    def of(cls, runs: Sequence[VesselIoU]) -> IoUSummary:
        """The summary of one IoU per seed (at least `MIN_SEEDS`)."""
        if len(runs) < MIN_SEEDS:
            raise ResusError(
                f"a spread over training seeds needs at least {MIN_SEEDS} seeds, got {len(runs)}"
            )
        statistics = {}
        for metric in IOU_METRICS:
            values = [run.to_dict()[metric] for run in runs]
            statistics[metric] = float(np.mean(values))
            statistics[f"{metric}_std"] = float(np.std(values, ddof=1))
        return cls(tuple(runs), **statistics)

    @classmethod
    def averaged(cls, summaries: Sequence[IoUSummary]) -> IoUSummary:
        """Per seed, the average over `summaries` (e.g. over held-out subjects), summarised
        over the seeds: the spread of an average, not the average of spreads."""
        per_seed = zip(*(summary.runs for summary in summaries), strict=True)
        return cls.of(
            [
                VesselIoU(
                    float(np.mean([run.artery for run in runs])),
                    float(np.mean([run.vein for run in runs])),
                )
                for runs in per_seed
            ]
        )

    def values(self, metric: str) -> list[float]:
        """Each seed's `metric` (one of `IOU_METRICS`)."""
        return [run.to_dict()[metric] for run in self.runs]

    def to_dict(self) -> dict:
        data: dict = {"runs": [run.to_dict() for run in self.runs], "n_seeds": len(self.runs)}
        for metric in IOU_METRICS:
            data[metric] = getattr(self, metric)
            data[f"{metric}_std"] = getattr(self, f"{metric}_std")
        return data


@dataclass(frozen=True)
class SeedComparison:
    """Model a against model b on one IoU metric over training seeds: the difference of their
    means, the seed spread it is weighed against, the verdict and the paired t-test.

    A difference no larger than the spread (the larger of the two models' sample standard
    deviations over seeds) is "no difference": another seed could as well reverse it.
    """

    a: str
    b: str
    metric: str
    difference: float
    """Mean over seeds of a minus that of b."""
    seed_spread: float
    verdict: str
    """`NO_DIFFERENCE`, or which model is better ("resus better")."""
    test: PairedTest
    """Two-sided paired t-test of a - b over the pairs (same seed, same group)."""

    @classmethod
    def of(
        cls,
        a: str,
        b: str,
        metric: str,
        a_cells: Sequence[IoUSummary],
        b_cells: Sequence[IoUSummary],
    ) -> SeedComparison:
        """Compare two models' cells, one per group (the held-out subjects, or one test set),
        all over the same seeds; a seed's value is its mean over the groups."""
        seeds = {len(cell.runs) for cell in (*a_cells, *b_cells)}
        if len(a_cells) != len(b_cells) or len(seeds) != 1:
            raise ResusError(
                f"comparing {a} with {b} needs as many cells of each, all over the same seeds; "
                f"got {len(a_cells)} and {len(b_cells)} cells over {sorted(seeds)} seeds"
            )
        x = np.array([cell.values(metric) for cell in a_cells]).T  # (seeds, groups)
        y = np.array([cell.values(metric) for cell in b_cells]).T
        a_seeds, b_seeds = x.mean(axis=1), y.mean(axis=1)
        difference = float(a_seeds.mean() - b_seeds.mean())
        spread = float(max(np.std(a_seeds, ddof=1), np.std(b_seeds, ddof=1)))
        if abs(difference) <= spread:
            verdict = NO_DIFFERENCE
        else:
            verdict = f"{a if difference > 0 else b} better"
        test = paired_t_test(x.ravel().tolist(), y.ravel().tolist())
        return cls(a, b, metric, difference, spread, verdict, test)

    def to_dict(self) -> dict:
        """results.json's and summary.json's form, the paired test's fields included."""
        return {
            "a": self.a,
            "b": self.b,
            "metric": self.metric,
            "difference": self.difference,
            "seed_spread": self.seed_spread,
            "verdict": self.verdict,
            **self.test.to_dict(),
        }


def compare_models(
    a: str, b: str, a_cells: Sequence[IoUSummary], b_cells: Sequence[IoUSummary]
) -> list[SeedComparison]:
    """`SeedComparison` of a against b on every IoU metric."""
    return [SeedComparison.of(a, b, metric, a_cells, b_cells) for metric in IOU_METRICS]


@dataclass(frozen=True)
class PhantomResults:
    """Table I analogue: models trained on scan A's frames (or frames + reslices), scored on
    scan B's frames (or frames + reslices), over several training seeds."""

    preset: ExperimentPreset
    seeds: tuple[int, ...]
    scans: dict[str, ScanImages]
    """Scan "A" (training) and "B" (test)."""
    training_frames: int
    validation_frames: int
    iou: dict[str, dict[str, IoUSummary]]
    """What the model trained on -> what it was scored on -> the cell."""
    comparisons: dict[str, list[SeedComparison]]
    """What the models were scored on -> trained on frames + reslices against frames only."""
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
            "comparisons": {
                test: [comparison.to_dict() for comparison in comparisons]
                for test, comparisons in self.comparisons.items()
            },
            "seconds": self.run.seconds(),
        }


@dataclass(frozen=True)
class SeededLoso:
    """Leave-one-subject-out over several training seeds: each regime's IoU on each held-out
    subject over the seeds, the regimes that did not run (and why), and every pair of regimes
    compared (paired over held-out subject and seed)."""

    subjects: tuple[str, ...]
    seeds: tuple[int, ...]
    iou: dict[str, dict[str, IoUSummary]]
    """Regime -> held-out subject -> IoU over the seeds."""
    not_run: dict[str, str]

    def average(self, regime: str) -> IoUSummary:
        """The regime's IoU averaged over the held-out subjects, per seed, over the seeds."""
        return IoUSummary.averaged([self.iou[regime][subject] for subject in self.subjects])

    def comparisons(self) -> list[SeedComparison]:
        """Every pair of regimes that ran, on every IoU metric; the later regime of a pair
        (in the paper's order us, imagenet, aug, resus) is a."""
        return [
            comparison
            for b, a in itertools.combinations(self.iou, 2)
            for comparison in compare_models(
                a,
                b,
                [self.iou[a][subject] for subject in self.subjects],
                [self.iou[b][subject] for subject in self.subjects],
            )
        ]

    def to_dict(self) -> dict:
        """results.json's "loso": per-regime tables with their average, and the comparisons."""
        regimes: dict[str, dict] = {
            regime: {
                "status": "run",
                "iou": {subject: cell.to_dict() for subject, cell in per_subject.items()},
                "mean_over_subjects": self.average(regime).to_dict(),
            }
            for regime, per_subject in self.iou.items()
        }
        for regime, reason in self.not_run.items():
            regimes[regime] = {"status": "not run", "reason": reason}
        return {
            "subjects": list(self.subjects),
            "seeds": list(self.seeds),
            "regimes": regimes,
            "comparisons": [comparison.to_dict() for comparison in self.comparisons()],
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
    """Table II analogue: leave-one-subject-out per regime over several training seeds, with
    the regimes compared."""

    preset: ExperimentPreset
    subject_numbers: tuple[int, ...]
    images: tuple[ScanImages, ...]
    """Frames and reslices of each subject."""
    loso: SeededLoso
    validation_iou: dict[str, dict[str, IoUSummary]]
    """Regime -> held-out subject -> best-epoch IoU on the training subjects' validation
    tail, over the seeds."""
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
            "seeds": list(self.loso.seeds),
            **self.run.environment(),
            "subject_numbers": list(self.subject_numbers),
            "images_per_subject": {
                scan.subject: {"frames": scan.frames, "reslices": scan.reslices}
                for scan in self.images
            },
            "loso": self.loso.to_dict(),
            "validation_iou": {
                regime: {subject: cell.to_dict() for subject, cell in per_subject.items()}
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
