"""`resus experiment sim2real`: train on simulation only, score on real images, and the
few-label curve with and without simulation pretraining."""

from __future__ import annotations

import dataclasses
from pathlib import Path
from typing import Annotated

import typer

from resus.cli.executor_options import AddressOption, ExecutorOption, JobsOption
from resus.cli.experiment import PresetOption, ReportFolderOption, run_options
from resus.cli.options import DeviceOption
from resus.cli.parsers import flag_error, parse_numbers


def register(group: typer.Typer) -> None:
    """Add `sim2real` to the `resus experiment` group."""

    @group.command("sim2real")
    def sim2real_command(
        real: Annotated[
            Path, typer.Option(help="Folder of real images/NAME.png and masks/NAME.png.")
        ],
        out: ReportFolderOption,
        preset: PresetOption = "quick",
        training: Annotated[
            str | None,
            typer.Option(help="Training preset instead of the preset's: quick, cpu128, paper."),
        ] = None,
        ensemble: Annotated[
            int | None,
            typer.Option(
                min=1, help="Simulation-only models averaged (the preset's when not given)."
            ),
        ] = None,
        label_counts: Annotated[
            str | None,
            typer.Option(
                help="The curve's k, e.g. 0,25,100: real labels per fine-tuning (the preset's "
                "0,5,10,25,50,100 when not given)."
            ),
        ] = None,
        splits: Annotated[
            int | None,
            typer.Option(min=1, help="Random splits the curve is averaged over (the preset's)."),
        ] = None,
        rehearsal: Annotated[
            int | None,
            typer.Option(
                help="Simulated frames in every epoch of a fine-tuning from simulation, 0 for "
                "none (the preset's when not given)."
            ),
        ] = None,
        data: Annotated[
            Path | None, typer.Option(help="Scratch folder for the sweeps (default: OUT/data).")
        ] = None,
        seed: Annotated[int, typer.Option(help="Phantom, scanner, split and training seed.")] = 0,
        device: DeviceOption = "auto",
        jobs: JobsOption = 2,
        executor: ExecutorOption = "local",
        address: AddressOption = None,
    ) -> None:
        """Simulation-only U-Net scored on --real, then fine-tuned on k = 0..100 real images
        from simulation and from scratch: report.md, results.json, few_label_curve.png."""
        from resus.execution import make_executor
        from resus.experiments.sim2real import get_sim2real_preset, real_splits, run_sim2real
        from resus.segmentation.folders import read_data_set
        from resus.segmentation.model import resolve_device

        options = run_options(out, data, seed, device, jobs, executor, address)
        with flag_error("--preset"):
            settings = get_sim2real_preset(preset)
        if training is not None:
            with flag_error("--training"):
                settings = dataclasses.replace(settings, training=training)
        if ensemble is not None:
            settings = dataclasses.replace(settings, ensemble=ensemble)
        if splits is not None:
            settings = dataclasses.replace(settings, splits=splits)
        if rehearsal is not None:
            with flag_error("--rehearsal"):
                settings = dataclasses.replace(settings, rehearsal_images=rehearsal)
        if label_counts is not None:
            with flag_error("--label-counts"):
                counts = parse_numbers(label_counts, "--label-counts", kind=int)
                settings = dataclasses.replace(settings, label_counts=counts)
        with flag_error("--device"):
            resolve_device(device)
        with flag_error("--real"):
            folder = read_data_set(real)
            real_splits(len(folder), settings, seed)
        with make_executor(executor, jobs, address) as engine:
            result = run_sim2real(
                settings,
                folder,
                out,
                data=options.data,
                seed=seed,
                device=device,
                executor=engine,
                command=options.command,
            )
        summary = result.to_dict()
        vessel = summary["sim_only"]["pooled"]["vessel"]
        typer.echo(f"simulation only: vessel IoU {vessel['iou']:.3f}, Dice {vessel['dice']:.3f}")
        for initialisation, by_k in summary["curve_summary"].items():
            cells = ", ".join(f"k={k} {entry['mean']:.3f}" for k, entry in by_k.items())
            typer.echo(f"from {initialisation}: {cells}")
        typer.echo(f"wrote {out / 'report.md'}")
