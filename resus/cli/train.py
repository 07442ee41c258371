"""`resus train`: fit the segmentation U-Net in one of the paper's regimes."""

from __future__ import annotations

import json
from pathlib import Path
from typing import TYPE_CHECKING, Annotated

import typer

from resus.cli.options import DeviceOption, WeightsOption
from resus.cli.parsers import flag_error, parse_choice
from resus.errors import ResusError

if TYPE_CHECKING:  # for the annotation only: importing it loads torch
    from resus.segmentation.train import TrainingSummary


def register(app: typer.Typer) -> None:
    """Add the `train` command to the root app."""

    @app.command("train")
    def train_command(
        out: Annotated[
            Path, typer.Option(help="Output folder: checkpoint.pt, curves.png, metrics.json.")
        ],
        sweeps: Annotated[
            list[Path] | None,
            typer.Option(help="Labelled sweep file or directory of them (repeat for more)."),
        ] = None,
        images: Annotated[
            Path | None,
            typer.Option(help="Folder of PNG/JPEG images to train on as well; needs --masks."),
        ] = None,
        masks: Annotated[
            Path | None,
            typer.Option(help="Folder of PNG masks named like the --images (nonzero = vessel)."),
        ] = None,
        reslices: Annotated[
            list[Path] | None,
            typer.Option(help="Reslice dataset file or directory (repeat); for --regime resus."),
        ] = None,
        regime: Annotated[str, typer.Option(help="us, imagenet, aug or resus.")] = "us",
        preset: Annotated[
            str, typer.Option(help="quick (CPU, minutes), cpu128 (CPU, 128 px) or paper (GPU).")
        ] = "quick",
        device: DeviceOption = "auto",
        seed: Annotated[int, typer.Option(help="Seeds weights, data order, augmentation.")] = 0,
        average_epochs: Annotated[
            int,
            typer.Option(
                help="Keep the mean of the weights over the last N epochs' steps at a constant "
                "rate (stochastic weight averaging; every epoch runs), not the best epoch's."
            ),
        ] = 0,
        weights: WeightsOption = None,
        test_subject: Annotated[
            str | None,
            typer.Option(help="Hold this subject out and report its IoU (one LOSO fold)."),
        ] = None,
    ) -> None:
        """Train a U-Net on labelled sweeps and/or image folders (plus reslices of the training
        subjects)."""
        from resus.cli.evaluate import read_image_folders
        from resus.segmentation.loaders import load_reslice_sets, load_sweep_frames
        from resus.segmentation.loso import REGIMES, make_split, run_regime
        from resus.segmentation.model import resolve_device
        from resus.segmentation.presets import get_preset

        if (images is None) != (masks is None):
            given, missing = ("--images", "--masks") if masks is None else ("--masks", "--images")
            raise ResusError(f"{given}: needs {missing} too (images and their masks)")
        if not sweeps and images is None:
            raise ResusError("no training data: give --sweeps, or --images with --masks")
        parse_choice(regime, "--regime", REGIMES)
        if regime == "resus" and not reslices:
            raise ResusError("--regime resus: no reslices given (--reslices)")
        if regime == "imagenet" and weights is None:  # never silently replaced by random ones
            raise ResusError("--regime imagenet: no encoder weights file given (--weights)")
        with flag_error("--preset"):
            settings = get_preset(preset)
        with flag_error("--average-epochs"):
            settings = settings.weight_averaged(average_epochs)
        with flag_error("--device"):
            torch_device = resolve_device(device)
        with flag_error("--sweeps"):
            frames = load_sweep_frames(sweeps or [])
        if images is not None and masks is not None:
            folder = read_image_folders(images, masks)
            frames += folder.labelled_sets()
            if not folder.separates_classes:
                typer.echo(
                    f"{masks}: the masks do not tell artery from vein: "
                    "their vessels train as label 1 (artery)"
                )
        with flag_error("--reslices"):
            reslice_sets = load_reslice_sets(reslices or [])
        with flag_error("--test-subject"):
            split = make_split(frames, reslice_sets, test_subject, settings.validation_fraction)
        if regime == "resus" and not split.reslices:
            raise ResusError(
                f"--regime resus: every given reslice belongs to the test subject {test_subject!r}"
                " (--test-subject), so none is left to train on"
            )
        out.mkdir(parents=True, exist_ok=True)
        metrics_path = out / "metrics.json"
        metrics = {
            "regime": regime,
            "preset": preset,
            "average_epochs": average_epochs,
            "seed": seed,
            "test_subject": test_subject,
        }
        run = run_regime(
            split,
            regime,
            settings,
            seed=seed,
            device=torch_device,
            encoder_weights=weights,
            out_dir=out,
        )
        summary = run.training.summary()
        metrics.update(
            status="run",
            device=str(torch_device),
            train_subjects=run.training.config["train_subjects"],
            train_images=run.training.config["train_images"],
            validation_images=run.training.config["validation_images"],
            test_iou=None if run.test_iou is None else run.test_iou.to_dict(),
            checkpoint=str(out / "checkpoint.pt"),
            training=summary.to_dict(),
        )
        metrics_path.write_text(json.dumps(metrics, indent=2) + "\n")
        typer.echo(
            f"{_model_line(summary)} ({summary.images_per_second:.0f} images/s on {torch_device})"
        )
        if run.test_iou is not None:
            iou = run.test_iou
            typer.echo(
                f"test subject {test_subject}: IoU artery {iou.artery:.3f}, vein {iou.vein:.3f}, "
                f"mean {iou.mean:.3f}"
            )
        typer.echo(f"wrote {out / 'checkpoint.pt'}, {out / 'curves.png'}, {metrics_path}")


def _model_line(summary: TrainingSummary) -> str:
    """Which weights the checkpoint holds and how they did on validation."""
    average = summary.weight_average
    if average is None:
        return (
            f"best epoch {summary.best_epoch}/{summary.epochs_run}: validation loss "
            f"{summary.best_validation_loss:.4f}, validation IoU "
            f"{summary.best_validation_iou.mean:.3f}"
        )
    return (
        f"weight average of epochs {average.first_epoch}-{average.last_epoch} "
        f"({average.steps} steps): validation loss {average.validation_loss:.4f}, "
        f"validation IoU {average.validation_iou.mean:.3f}"
    )
