"""`resus vessels`: a sweep's segmentations to a 3D vessel map and a needle insertion site."""

from __future__ import annotations

from pathlib import Path
from typing import Annotated

import typer

from resus.cli.parsers import flag_error, settings_from_flags
from resus.errors import ResusError


def register(app: typer.Typer) -> None:
    """Add the `vessels` command to the root app."""

    @app.command("vessels")
    def vessels_command(
        sweep_path: Annotated[Path, typer.Argument(metavar="SWEEP", help="Sweep .h5 file.")],
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
    ) -> None:
        """Map artery and vein surfaces from a sweep's labels; propose a needle site."""
        from resus.acquisition.simulation import parse_subject_id, resolve_scene
        from resus.sweep.io import read_sweep
        from resus.vessels.map import VesselMapSettings, segment_frames
        from resus.vessels.needle import NeedleSettings
        from resus.vessels.pipeline import VesselJob, map_vessels

        if (model is None) == (not labels_from_sweep):
            raise ResusError("give exactly one of --model CKPT or --labels-from-sweep")
        needle = settings_from_flags(
            NeedleSettings,
            angle_deg=("--needle-angle", needle_angle),
            min_clearance=("--clearance", clearance),
        )
        vessel_map = settings_from_flags(VesselMapSettings, spacing=("--spacing", spacing))
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
        }
        result = map_vessels(sweep, labels, scene, out, sources, job, progress=True)
        typer.echo(f"anatomy: {result.anatomy}")
        for name, score in (result.scores or {}).items():
            msd = score.mean_surface_distance_mm
            typer.echo(
                f"{name}: Dice {score.dice:.3f}, mean surface distance "
                + ("n/a" if msd is None else f"{msd:.3f} mm, HD95 {score.hd95_mm:.3f} mm")
            )
        typer.echo(f"needle ({target}): {result.needle.reason}")
        typer.echo(f"wrote {len(result.files) + 1} files to {out}")
