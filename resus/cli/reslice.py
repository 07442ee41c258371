"""`resus reslice`: oblique reslices of a volume and its labels, as a training dataset."""

from __future__ import annotations

from pathlib import Path
from typing import Annotated

import typer

from resus.cli.parsers import parse_angles, settings_from_flags
from resus.errors import ResusError

SHEET_RESLICES = 24


def _recorded_subject(volume_path: Path) -> str:
    """The subject the volume records (its sweep's); without one the user must say it, since
    training matches reslices to frames by subject."""
    from resus.reconstruction.io import volume_subject

    recorded = volume_subject(volume_path)
    if recorded is None:
        raise ResusError("the volume records no subject: give --subject", volume_path)
    return recorded


def register(app: typer.Typer) -> None:
    """Add the `reslice` command to the root app."""

    @app.command("reslice")
    def reslice_command(
        volume_path: Annotated[
            Path, typer.Argument(metavar="VOLUME", help="Intensity volume, .nrrd or .mha.")
        ],
        labels_path: Annotated[
            Path, typer.Argument(metavar="LABELS", help="Label volume on the same grid.")
        ],
        out: Annotated[
            Path, typer.Option("--out", help="Output folder: reslices.h5 and reslices.png.")
        ],
        angles: Annotated[
            str,
            typer.Option(
                help="Degrees about x and y: start:stop:step (stop included) or a comma list; "
                "every (x, y) pair is used."
            ),
        ] = "-30:30:10",
        step: Annotated[int, typer.Option(help="Slice spacing along the rotated z (voxels).")] = 5,
        min_nonzero: Annotated[
            float, typer.Option(help="Keep a slice when this fraction of its pixels is non-zero.")
        ] = 0.4,
        size: Annotated[int, typer.Option(help="Output image side (pixels).")] = 256,
        method: Annotated[
            str,
            typer.Option(
                help="fast (sample each plane) or rotate (turn the whole volume, the paper's way)."
            ),
        ] = "fast",
        subject: Annotated[
            str | None,
            typer.Option(help="Subject id for the dataset (default: the one the volume records)."),
        ] = None,
    ) -> None:
        """Reslice a volume at oblique angles (the RESUS paper's procedure) into DIR/reslices.h5."""

        from resus.indices import evenly_spaced
        from resus.reconstruction.io import read_label_volume, read_volume
        from resus.reslicing.dataset import ResliceDataset, ResliceWriter
        from resus.reslicing.reslice import ResliceSettings, check_volume, reslice_volume
        from resus.reslicing.sheet import save_contact_sheet
        from sim.labels import LABEL_NAMES

        settings = settings_from_flags(
            ResliceSettings,
            angles_deg=("--angles", parse_angles(angles, "--angles")),
            step=("--step", step),
            min_nonzero=("--min-nonzero", min_nonzero),
            size=("--size", size),
            method=("--method", method),
        )
        volume, grid, _ = read_volume(volume_path)
        labels, label_names = read_label_volume(labels_path, grid)
        check_volume(volume, labels, grid, volume_path, labels_path)
        out.mkdir(parents=True, exist_ok=True)
        dataset_path, sheet_path = out / "reslices.h5", out / "reslices.png"
        with ResliceWriter(
            dataset_path,
            settings,
            source_volume=str(volume_path),
            subject=subject or _recorded_subject(volume_path),
            label_names=label_names or LABEL_NAMES,
        ) as writer:
            for reslice in reslice_volume(volume, labels, grid, settings, progress=True):
                writer.append(reslice)
        pairs = len(settings.angle_pairs())
        typer.echo(f"wrote {dataset_path} ({writer.count} reslices from {pairs} angle pairs)")
        if writer.count == 0:
            raise ResusError(
                f"no slice has {min_nonzero:.0%} non-zero pixels: lower --min-nonzero", volume_path
            )
        with ResliceDataset(dataset_path) as dataset:
            shown = [dataset[i] for i in evenly_spaced(len(dataset), SHEET_RESLICES)]
        title = f"{volume_path.name}: {writer.count} reslices ({method})"
        save_contact_sheet(sheet_path, shown, title=title)
        typer.echo(f"wrote {sheet_path}")
