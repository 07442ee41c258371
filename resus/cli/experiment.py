"""`resus experiment phantom|subjects`: the paper's Tables I and II, in simulation.

Every command of the group takes the same run options (`--out`, `--data`, `--seed`,
`--device`, `--jobs`, `--executor`, `--address`), turned into `RunOptions` by `run_options`;
`phantom` and `subjects` also take `--seeds` (training seeds per model), `--phantom` and
`--scanner` (what is scanned and how it is imaged), applied to the preset by
`experiment_preset`.
"""

from __future__ import annotations

import dataclasses
import shlex
import sys
from pathlib import Path
from typing import TYPE_CHECKING, Annotated

import typer

from resus.cli.executor_options import (
    AddressOption,
    ExecutorOption,
    JobsOption,
    check_executor_flags,
)
from resus.cli.options import DeviceOption, WeightsOption
from resus.cli.parsers import flag_error, parse_index_set, parse_names
from resus.errors import ResusError

if TYPE_CHECKING:
    from resus.experiments.tables import ExperimentPreset, RunOptions

REGIME_HELP = "Comma list of us, imagenet, aug, resus (imagenet needs --weights)."

# The options that mean the same in each of the group's commands, declared once. `sim2real`
# words --data and --seed its own way: its scratch folder holds sweeps only, and its seed also
# draws the phantom, the scanner and the real-image split.
ReportFolderOption = Annotated[
    Path, typer.Option(help="Report folder (report.md, results.json, PNGs).")
]
PresetOption = Annotated[str, typer.Option(help="quick (2-core CPU) or paper (GPU).")]
DataOption = Annotated[
    Path | None, typer.Option(help="Scratch folder for sweeps and volumes (default: OUT/data).")
]
FirstSeedOption = Annotated[int, typer.Option(help="First training seed.")]
ExperimentPhantomOption = Annotated[
    str | None,
    typer.Option(
        help="Phantom spec name or YAML path (default: the gel block); each sweep is centred "
        "on its subject's artery and vein."
    ),
]
ExperimentScannerOption = Annotated[
    str | None,
    typer.Option(
        help="Scanner preset (a name or a YAML file) imaging every sweep (default: the "
        "simulator's own settings)."
    ),
]
SeedsOption = Annotated[
    int | None,
    typer.Option(
        help="Training seeds per model (--seed, --seed + 1, ...; default: the preset's, 3)."
    ),
]


def experiment_preset(
    name: str, seeds: int | None, phantom: str | None = None, scanner: str | None = None
) -> ExperimentPreset:
    """The experiment preset called `name` (`--preset`), with `seeds` training seeds per
    model (`--seeds`), scanning `phantom` with each sweep centred on its subject's vessels
    (`--phantom`) and imaging through the scanner preset `scanner` (`--scanner`), each when
    given."""
    from resus.experiments.tables import get_experiment_preset

    with flag_error("--preset"):
        preset = get_experiment_preset(name)
    if seeds is not None:
        with flag_error("--seeds"):
            preset = dataclasses.replace(preset, repeats=seeds)
    scans = preset.scans
    if phantom is not None:
        with flag_error("--phantom"):
            scans = dataclasses.replace(scans, phantom=phantom, centre_on_vessels=True)
    if scanner is not None:
        with flag_error("--scanner"):
            scans = dataclasses.replace(scans, scanner=scanner)
    return dataclasses.replace(preset, scans=scans)


def parse_subjects(text: str) -> list[int]:
    """'K' -> subjects 0..K-1; '0-5' or '0,2,5' -> those subjects; at least two."""
    if text.strip().isdecimal():
        subjects = list(range(int(text)))
    else:
        subjects = parse_index_set(text, "--subjects")
    if len(subjects) < 2:
        raise ResusError(f"--subjects: leave-one-subject-out needs at least 2, got {text!r}")
    return subjects


def run_options(
    out: Path,
    data: Path | None,
    seed: int,
    device: str,
    jobs: int,
    executor: str = "local",
    address: str | None = None,
) -> RunOptions:
    """The flags every experiment takes, checked (before any work) and as `RunOptions`."""
    from resus.experiments.tables import RunOptions

    if out.exists() and not out.is_dir():
        raise ResusError("--out: is a file, expected a folder", out)
    check_executor_flags(executor, address)
    command = shlex.join(["resus", *sys.argv[1:]]) if sys.argv else "resus experiment"
    return RunOptions(
        out,
        data or out / "data",
        seed,
        device,
        jobs,
        command,
        executor=executor,
        address=address,
    )


def register(app: typer.Typer) -> None:
    """Add `resus experiment phantom`, `subjects` and `sim2real`."""
    from resus.cli import sim2real

    group = typer.Typer(
        help="The paper's tables in simulation, and sim-to-real: report.md, results.json, figures.",
        no_args_is_help=True,
    )
    app.add_typer(group, name="experiment")
    sim2real.register(group)

    @group.command("phantom")
    def phantom_command(
        out: ReportFolderOption,
        preset: PresetOption = "quick",
        phantom: ExperimentPhantomOption = None,
        scanner: ExperimentScannerOption = None,
        data: DataOption = None,
        seed: FirstSeedOption = 0,
        seeds: SeedsOption = None,
        device: DeviceOption = "auto",
        jobs: JobsOption = 2,
        executor: ExecutorOption = "local",
        address: AddressOption = None,
    ) -> None:
        """Table I: train on phantom scan A (frames vs frames + reslices), test on scan B."""
        from resus.experiments.tables import run_phantom_experiment

        options = run_options(out, data, seed, device, jobs, executor, address)
        settings = experiment_preset(preset, seeds, phantom, scanner)
        results = run_phantom_experiment(settings, options)
        for trained_on, row in results.iou.items():
            cells = ", ".join(
                f"{test} {iou.mean:.3f} ± {iou.mean_std:.3f}" for test, iou in row.items()
            )
            typer.echo(f"trained on {trained_on}: tested on {cells}")
        for test, comparisons in results.comparisons.items():
            mean = next(c for c in comparisons if c.metric == "mean")
            typer.echo(
                f"tested on {test}: {mean.a} - {mean.b} {mean.difference:+.3f} mean IoU, "
                f"seed spread {mean.seed_spread:.3f}: {mean.verdict}"
            )
        typer.echo(f"wrote {out / 'report.md'}")

    @group.command("subjects")
    def subjects_command(
        out: ReportFolderOption,
        preset: PresetOption = "quick",
        phantom: ExperimentPhantomOption = None,
        scanner: ExperimentScannerOption = None,
        subjects: Annotated[
            str | None,
            typer.Option(help="K (subjects 0..K-1), or e.g. 0-5 or 0,2,5 (default: the preset's)."),
        ] = None,
        regimes: Annotated[str, typer.Option(help=REGIME_HELP)] = "us,imagenet,aug,resus",
        weights: WeightsOption = None,
        data: DataOption = None,
        seed: FirstSeedOption = 0,
        seeds: SeedsOption = None,
        device: DeviceOption = "auto",
        jobs: JobsOption = 2,
        executor: ExecutorOption = "local",
        address: AddressOption = None,
    ) -> None:
        """Table II: leave-one-subject-out over simulated subjects, per regime, with t-tests."""
        from resus.experiments.tables import run_subjects_experiment

        options = run_options(out, data, seed, device, jobs, executor, address)
        settings = experiment_preset(preset, seeds, phantom, scanner)
        from resus.segmentation.loso import REGIMES  # torch: after the quick checks

        results = run_subjects_experiment(
            settings,
            options,
            None if subjects is None else parse_subjects(subjects),
            parse_names(regimes, "--regimes", REGIMES),
            weights,
        )
        for regime, entry in results.loso.to_dict()["regimes"].items():
            if entry["status"] == "run":
                average = entry["mean_over_subjects"]
                typer.echo(
                    f"{regime}: mean IoU {average['mean']:.3f} ± {average['mean_std']:.3f} "
                    f"over {average['n_seeds']} seeds"
                )
            else:
                typer.echo(f"{regime}: not run ({entry['reason']})")
        typer.echo(f"wrote {out / 'report.md'}")
