"""`resus evaluate`: score a trained model on a folder of real images and their masks."""

from __future__ import annotations

from pathlib import Path
from typing import TYPE_CHECKING, Annotated

import typer

from resus.cli.options import DeviceOption
from resus.cli.parsers import flag_error, parse_numbers
from resus.errors import ResusError

if TYPE_CHECKING:
    from resus.segmentation.folders import FolderImages


def read_image_folders(images: Path, masks: Path) -> FolderImages:
    """The images and masks of `--images` and `--masks`; a missing or empty folder is
    reported under its flag, a problem with a file names the file."""
    from resus.segmentation.folders import MASK_SUFFIXES, image_files, read_folders

    with flag_error("--images"):
        image_files(images)
    with flag_error("--masks"):
        image_files(masks, MASK_SUFFIXES)
    return read_folders(images, masks)


def register(app: typer.Typer) -> None:
    """Add the `evaluate` command to the root app."""

    @app.command("evaluate")
    def evaluate_command(
        model: Annotated[
            list[Path],
            typer.Option(
                help="Checkpoint written by `resus train`; repeat it to score the checkpoints "
                "as one ensemble (their class probabilities averaged)."
            ),
        ],
        images: Annotated[Path, typer.Option(help="Folder of PNG/JPEG images, any size.")],
        masks: Annotated[Path, typer.Option(help="Folder of PNG masks named like the images.")],
        out: Annotated[
            Path, typer.Option(help="Output folder: metrics.json and overlays/NAME.png.")
        ] = Path("evaluation"),
        mirror: Annotated[
            bool | None,
            typer.Option(
                "--mirror/--no-mirror",
                help="Also segment each image mirrored left-right and average the two; "
                "default: when the model trained with horizontal flips.",
            ),
        ] = None,
        zooms: Annotated[
            str | None,
            typer.Option(
                help="Magnifications of the network's input size to segment at and average, "
                "comma-separated (1: the trained size alone); default: a quarter less, the "
                "trained size and a quarter more.",
            ),
        ] = None,
        device: DeviceOption = "auto",
    ) -> None:
        """Segment every image, score vessel IoU and Dice against its mask, draw overlays."""
        from resus.segmentation.evaluate import evaluate_folder
        from resus.segmentation.model import resolve_device
        from resus.segmentation.trained_model import DEFAULT_ZOOMS, load_ensemble, load_model

        with flag_error("--device"):
            torch_device = resolve_device(device)
        magnifications = DEFAULT_ZOOMS if zooms is None else parse_numbers(zooms, "--zooms")
        if min(magnifications) <= 0:
            raise ResusError(f"--zooms: magnifications must be positive, got {zooms!r}")
        with flag_error("--model"):
            trained = (
                load_model(model[0], torch_device, mirror, magnifications)
                if len(model) == 1
                else load_ensemble(model, torch_device, mirror, magnifications)
            )
        data = read_image_folders(images, masks)
        evaluation = evaluate_folder(trained, data, out)
        for line in evaluation.summary():
            typer.echo(line)
        typer.echo(f"wrote {out / 'metrics.json'} and {len(data)} overlays in {out / 'overlays'}")
