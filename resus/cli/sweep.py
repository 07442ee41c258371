"""`resus sweep ...`: look inside sweep files, convert to and from PLUS, draw a preview."""

from __future__ import annotations

from pathlib import Path
from typing import Annotated

import typer

from resus.errors import ResusError

sweep_app = typer.Typer(
    help="Sweep files (resus.sweep/1 HDF5): inspect, import/export PLUS .igs.mha, preview.",
    no_args_is_help=True,
)


def _out_folder_exists(path: Path) -> None:
    if not path.parent.is_dir():
        raise ResusError("output folder does not exist", path.parent)


def _describe(path: Path) -> list[tuple[str, str]]:
    """(field, value) lines describing the sweep file at `path`, reading no frame images."""
    import numpy as np

    from resus.sweep.io import SweepReader
    from resus.sweep.model import pixel_spacing, pixels_to_world

    with SweepReader(path) as sweep:
        rows, cols = sweep.frame_shape
        spacing = np.array(pixel_spacing(sweep.image_to_probe)) * 1e3
        optional = [
            f"labels ({', '.join(sweep.label_names)})" if sweep.has_labels else "",
            "wrench" if sweep.wrench is not None else "",
            "joint positions" if sweep.joint_positions is not None else "",
        ]
        lines = [
            ("file", str(path)),
            ("frames", str(len(sweep))),
            ("image size", f"{cols} x {rows} px (width x height)"),
            ("pixel spacing", f"{spacing[0]:.4f} x {spacing[1]:.4f} mm (column x row)"),
        ]
        if len(sweep):
            travel = np.diff(sweep.probe_to_base[:, :3, 3], axis=0)
            centres = pixels_to_world(
                sweep.probe_to_base, sweep.image_to_probe, (cols - 1) / 2, (rows - 1) / 2
            )
            steps = np.linalg.norm(np.diff(centres, axis=0), axis=-1) * 1e3
            lines += [
                ("duration", f"{sweep.timestamps[-1] - sweep.timestamps[0]:.3f} s"),
                ("path length", f"{np.linalg.norm(travel, axis=-1).sum() * 1e3:.2f} mm (probe)"),
                (
                    "frame spacing",
                    f"mean {steps.mean():.3f}, min {steps.min():.3f}, max {steps.max():.3f} mm "
                    "(between frame centres)"
                    if len(steps)
                    else "n/a (one frame)",
                ),
            ]
        lines += [
            ("source", sweep.source),
            ("subject", sweep.subject or "(none)"),
            ("created", sweep.created),
            ("optional data", "; ".join(item for item in optional if item) or "none"),
        ]
    return lines


@sweep_app.command("info")
def info_command(
    sweep_path: Annotated[Path, typer.Argument(metavar="FILE", help="Sweep file (.h5).")],
) -> None:
    """Frames, image size, spacing, path length, frame spacing, duration and contents."""
    lines = _describe(sweep_path)
    width = max(len(name) for name, _ in lines)
    for name, value in lines:
        typer.echo(f"{name:<{width}}  {value}")


@sweep_app.command("import-plus")
def import_plus_command(
    sequence: Annotated[Path, typer.Argument(metavar="FILE.igs.mha", help="PLUS sequence.")],
    out: Annotated[Path, typer.Option("--out", help="Sweep file to write (.h5).")],
    calibration: Annotated[
        Path | None,
        typer.Option(
            "--calibration",
            metavar="CONFIG.xml",
            help="PLUS config XML with the Image to Probe transform "
            "(default: the sequence's ImageToProbeTransform field).",
        ),
    ] = None,
    subject: Annotated[
        str | None, typer.Option("--subject", help="Default: the file name.")
    ] = None,
) -> None:
    """Import a PLUS tracked sequence (millimetres, Reference frame) as a sweep file."""
    from resus.sweep.io import write_sweep
    from resus.sweep.plus import import_plus_sequence, read_plus_calibration

    _out_folder_exists(out)
    image_to_probe = None if calibration is None else read_plus_calibration(calibration)
    skipped: list[str] = []
    sweep = import_plus_sequence(
        sequence,
        image_to_probe,
        subject=subject,
        on_skip=lambda index, reason: skipped.append(f"{index} ({reason})"),
    )
    write_sweep(out, sweep)
    typer.echo(f"imported {len(sweep)} frames from {sequence} into {out}")
    if skipped:
        typer.echo(f"skipped {len(skipped)} frames whose status is not OK: {', '.join(skipped)}")


@sweep_app.command("export-plus")
def export_plus_command(
    sweep_path: Annotated[Path, typer.Argument(metavar="FILE", help="Sweep file (.h5).")],
    out: Annotated[Path, typer.Option("--out", help="PLUS sequence to write (.igs.mha).")],
    config: Annotated[
        Path | None,
        typer.Option(
            "--config",
            help="PLUS config XML to write with the calibration (default: beside --out, "
            "named NAME_config.xml).",
        ),
    ] = None,
) -> None:
    """Export a sweep as a PLUS sequence (.igs.mha, millimetres) plus a PLUS config XML."""
    from resus.sweep.io import read_sweep
    from resus.sweep.plus import export_plus_sequence, write_plus_calibration

    config = config or out.with_name(out.name.split(".")[0] + "_config.xml")
    for path in (out, config):
        _out_folder_exists(path)
    sweep = read_sweep(sweep_path)
    export_plus_sequence(sweep, out)
    write_plus_calibration(sweep.image_to_probe, config)
    typer.echo(f"exported {len(sweep)} frames to {out}; calibration in {config}")
    dropped = [
        name for name in ("labels", "wrench", "joint_positions") if getattr(sweep, name) is not None
    ]
    if dropped:
        typer.echo(f"not exported (PLUS sequences hold no such data): {', '.join(dropped)}")


@sweep_app.command("preview")
def preview_command(
    sweep_path: Annotated[Path, typer.Argument(metavar="FILE", help="Sweep file (.h5).")],
    out: Annotated[Path, typer.Option("--out", help="PNG to write.")],
    count: Annotated[int, typer.Option("--count", min=1, help="How many frames to show.")] = 12,
) -> None:
    """Save a contact sheet of evenly chosen frames, labels overlaid (artery red, vein blue)."""
    from resus.sweep.io import SweepReader
    from resus.sweep.preview import save_contact_sheet

    _out_folder_exists(out)
    with SweepReader(sweep_path) as sweep:
        if len(sweep) == 0:
            raise ResusError("the sweep holds no frames, nothing to preview", sweep_path)
        shown = save_contact_sheet(sweep, out, count)
    typer.echo(f"wrote {out} ({len(shown)} frames of {len(sweep)})")


def register(app: typer.Typer) -> None:
    """Add the `sweep` command group to the root app."""
    app.add_typer(sweep_app, name="sweep")
