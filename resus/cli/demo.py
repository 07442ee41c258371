"""`resus demo`: the whole pipeline on built-in defaults, into one folder."""

from __future__ import annotations

from pathlib import Path
from typing import Annotated

import typer

from resus.cli.parsers import parse_numbers, settings_from_flags


def register(app: typer.Typer) -> None:
    """Add the `demo` command to the root app."""

    @app.command("demo")
    def demo_command(
        out: Annotated[Path, typer.Option("--out", help="Output folder.")] = Path("demo_out"),
        subjects: Annotated[
            str, typer.Option("--subjects", help="Phantom subjects; the last is held out.")
        ] = "0,1,2",
        phantom: Annotated[
            str, typer.Option("--phantom", help="Phantom spec name or YAML path.")
        ] = "femoral",
        scanner: Annotated[
            str,
            typer.Option("--scanner", help="Scanner preset, or 'none' for the simulator's own."),
        ] = "vascular",
        image_size: Annotated[int, typer.Option("--image-size", help="Frame size (px).")] = 128,
        sweep_length: Annotated[
            float, typer.Option("--sweep-length", help="Sweep length (m).")
        ] = 0.05,
        force: Annotated[float, typer.Option("--force", help="Probe force (N).")] = 1.5,
        epochs: Annotated[int, typer.Option("--epochs", help="Quick U-Net epochs.")] = 8,
        seed: Annotated[int, typer.Option("--seed", help="First training seed.")] = 0,
        seeds: Annotated[
            int, typer.Option("--seeds", help="Training seeds per regime (mean and spread).")
        ] = 2,
    ) -> None:
        """Simulate, reconstruct, reslice, train with and without RESUS, map vessels, report."""
        from resus.experiments.demo import DemoSettings, run_demo

        settings = settings_from_flags(
            DemoSettings,
            subjects=("--subjects", parse_numbers(subjects, "--subjects", kind=int)),
            phantom=("--phantom", phantom),
            scanner=("--scanner", None if scanner == "none" else scanner),
            image_size=("--image-size", image_size),
            sweep_length=("--sweep-length", sweep_length),
            contact_force=("--force", force),
            max_epochs=("--epochs", epochs),
            seed=("--seed", seed),
            seeds=("--seeds", seeds),
        )
        result = run_demo(out, settings)
        summary = result.summary
        files = summary["files"]
        resus_map = summary["vessels"]["resus"]["scores"]
        typer.echo(
            f"\ndemo finished in {result.timings['total_seconds']:.0f} s; everything is in {out}/"
        )
        for regime, iou in summary["iou"].items():
            typer.echo(
                f"  held-out mean IoU, {regime}: {iou['mean']:.3f} ± {iou['mean_std']:.3f} "
                f"over {iou['n_seeds']} seeds"
            )
        mean = next(c for c in summary["comparisons"] if c["metric"] == "mean")
        typer.echo(
            f"  {mean['a']} - {mean['b']}: {mean['difference']:+.3f} mean IoU, seed spread "
            f"{mean['seed_spread']:.3f}: {mean['verdict']}"
        )
        for vessel, score in resus_map.items():
            msd = score["mean_surface_distance_mm"]
            typer.echo(
                f"  vessel map from the RESUS model, {vessel}: mean surface distance "
                + ("n/a" if msd is None else f"{msd:.3f} mm")
            )
        typer.echo(f"  report:            {result.report}  (Markdown, pictures beside it)")
        typer.echo(
            f"  rerun recording:   {result.recording}  (open with: rerun {result.recording})"
        )
        typer.echo(
            f"  held-out volume:   {out / files['test_volume']}  (3D Slicer; more in the report)"
        )
        typer.echo(f"  vessel meshes:     {out / 'vessels'}/*/{{artery,vein}}.stl")
