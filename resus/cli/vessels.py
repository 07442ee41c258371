"""`resus vessels`: a sweep's segmentations to a 3D vessel map and a needle insertion site."""

from __future__ import annotations

from pathlib import Path
from typing import Annotated

import typer

from resus.cli.options import SweepArgument
from resus.cli.parsers import flag_error, parse_choice, settings_from_flags
from resus.errors import ResusError

CLASSIFY_RULES = ("anatomy", "compression")
"""How `--classify` tells artery from vein."""


def register(app: typer.Typer) -> None:
    """Add the `vessels` command to the root app."""

    @app.command("vessels")
    def vessels_command(
        sweep_path: SweepArgument,
        out: Annotated[Path, typer.Option("--out", help="Output folder (created if missing).")],
        model: Annotated[
            Path | None, typer.Option("--model", help="Segmentation checkpoint (.pt).")
        ] = None,
        labels_from_sweep: Annotated[
            bool, typer.Option("--labels-from-sweep", help="Use the sweep's own labels.")
        ] = False,
        scene_name: Annotated[str, typer.Option("--scene", help="Scene name or YAML.")] = "default",
        phantom: Annotated[
            str | None, typer.Option("--phantom", help="Default: the sweep's, else the scene's.")
        ] = None,
        subject: Annotated[
            int | None, typer.Option("--subject", help="Default: the sweep's, else the scene's.")
        ] = None,
        target: Annotated[
            str, typer.Option("--target", help="vein (central line) or artery (REBOA).")
        ] = "vein",
        needle_angle: Annotated[
            float, typer.Option("--needle-angle", help="Needle-skin angle (deg).")
        ] = 45.0,
        clearance: Annotated[
            float, typer.Option("--clearance", help="Least distance from the other vessel (m).")
        ] = 3.0e-3,
        spacing: Annotated[float, typer.Option("--spacing", help="Voxel size (m).")] = 0.3e-3,
        classify: Annotated[
            str,
            typer.Option(
                "--classify",
                help="anatomy (the artery lies lateral) or compression (the vein collapses "
                "under the probe's press; a compression sweep, with its wrench).",
            ),
        ] = "anatomy",
        merge_classes: Annotated[
            bool,
            typer.Option(
                "--merge-classes",
                help="Compression: follow vessels whatever class the labels give them.",
            ),
        ] = False,
    ) -> None:
        """Map artery and vein surfaces from a sweep's labels; propose a needle site."""
        from resus.acquisition.simulation import parse_subject_id, resolve_scene
        from resus.sweep.io import read_sweep
        from resus.vessels.map import VesselMapSettings, segment_frames
        from resus.vessels.needle import NeedleSettings
        from resus.vessels.pipeline import VesselJob, map_vessels

        if (model is None) == (not labels_from_sweep):
            raise ResusError("give exactly one of --model CKPT or --labels-from-sweep")
        rule = parse_choice(classify, "--classify", CLASSIFY_RULES)
        if merge_classes and rule != "compression":
            raise ResusError(
                "--merge-classes applies to --classify compression only (the anatomy rule "
                "ignores the labels' classes already)"
            )
        needle = settings_from_flags(
            NeedleSettings,
            angle_deg=("--needle-angle", needle_angle),
            min_clearance=("--clearance", clearance),
        )
        vessel_map = settings_from_flags(
            VesselMapSettings,
            spacing=("--spacing", spacing),
            classes=("--classify", "anatomy" if rule == "anatomy" else "labels"),
        )
        with flag_error("--target"):
            job = VesselJob(target=target, needle=needle, map=vessel_map)
        if not sweep_path.is_file():
            raise ResusError("no such sweep file", sweep_path)
        if model is not None and not model.is_file():
            raise ResusError("checkpoint not found", model)
        sweep = read_sweep(sweep_path)
        sweep_phantom, sweep_subject = parse_subject_id(sweep.subject)
        scene = resolve_scene(
            scene_name,
            phantom or sweep_phantom,
            subject if subject is not None else sweep_subject,
        )
        if labels_from_sweep:
            if sweep.labels is None:
                raise ResusError(
                    "--labels-from-sweep given but the sweep has no labels", sweep_path
                )
            labels = sweep.labels
        else:
            assert model is not None  # exactly one of --model and --labels-from-sweep (above)
            labels = segment_frames(sweep.frames, model)
        sources = {
            "sweep": str(sweep_path),
            "labels": "sweep" if labels_from_sweep else f"model {model}",
            "classify": rule,
        }
        extra = {}
        if rule == "compression":
            labels, extra = _relabel_by_compression(sweep, sweep_path, labels, merge_classes, out)
        result = map_vessels(sweep, labels, scene, out, sources, job, progress=True, extra=extra)
        typer.echo(f"anatomy: {result.anatomy}")
        for name, score in (result.scores or {}).items():
            msd = score.mean_surface_distance_mm
            typer.echo(
                f"{name}: Dice {score.dice:.3f}, mean surface distance "
                + ("n/a" if msd is None else f"{msd:.3f} mm, HD95 {score.hd95_mm:.3f} mm")
            )
        typer.echo(f"needle ({target}): {result.needle.reason}")
        typer.echo(f"wrote {len(result.files) + 1} files to {out}")


def _relabel_by_compression(sweep, sweep_path: Path, labels, merge_classes: bool, out: Path):
    """The labels relabelled by `classify_by_compression`, and vessels.json's "compression";
    writes the relabelled sweep beside the map and says each track's call."""
    import dataclasses

    from resus.sweep.io import write_sweep
    from resus.vessels.compression import CompressionSettings, classify_by_compression
    from resus.vessels.sections import SectionSettings

    if sweep.wrench is None:
        raise ResusError(
            "--classify compression needs the force of every frame, and the sweep records no "
            "wrench",
            sweep_path,
        )
    settings = CompressionSettings(sections=SectionSettings(merge_classes=merge_classes))
    result = classify_by_compression(sweep, labels, settings)
    typer.echo(result.summary)
    for call in result.calls:
        if call.call != "unknown":
            typer.echo(f"  track {call.track}: {call.call} ({call.confidence:.2f}): {call.reason}")
    out.mkdir(parents=True, exist_ok=True)
    relabelled = out / "sweep_relabelled.h5"
    write_sweep(relabelled, dataclasses.replace(sweep, labels=result.labels))
    return result.labels, {"compression": {**result.to_dict(), "relabelled_sweep": relabelled.name}}
