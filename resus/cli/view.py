"""`resus view`: a recorded sweep, and optionally its volume and reslices, in rerun."""

from __future__ import annotations

import contextlib
from pathlib import Path
from typing import TYPE_CHECKING, Annotated

import typer

from resus.cli.options import (
    GrpcPortOption,
    RerunOption,
    RerunSaveOption,
    SubjectOption,
    SweepArgument,
    WebPortOption,
)
from resus.cli.parsers import parse_choice
from resus.errors import ResusError

if TYPE_CHECKING:
    from resus.sweep.model import Sweep

MAX_RESLICES = 200


def register(app: typer.Typer) -> None:
    """Add the `view` command to the root app."""

    @app.command("view")
    def view(
        sweep_path: SweepArgument,
        volume: Annotated[
            Path | None, typer.Option(help="Reconstructed volume (.nrrd/.mha) to show.")
        ] = None,
        labels: Annotated[
            Path | None, typer.Option(help="Label volume on the volume's grid (tints its slices).")
        ] = None,
        dense_volume: Annotated[
            bool, typer.Option(help="Also log the volume as a dense Volume3D (rerun: unstable).")
        ] = False,
        reslices: Annotated[
            Path | None, typer.Option(help="Reslice dataset (reslices.h5) to show.")
        ] = None,
        max_reslices: Annotated[
            int, typer.Option(min=1, help="Log at most this many reslices, evenly spread.")
        ] = MAX_RESLICES,
        predictions: Annotated[
            Path | None,
            typer.Option(help="Sweep file whose labels are predictions for SWEEP's frames."),
        ] = None,
        scene: Annotated[
            str | None,
            typer.Option(help="Scene name (assets/scenes) or YAML path: draw its phantom."),
        ] = None,
        subject: SubjectOption = None,
        rerun_save: RerunSaveOption = None,
        rerun: RerunOption = None,
        grpc_port: GrpcPortOption = 9876,
        web_port: WebPortOption = 9090,
    ) -> None:
        """Log a recorded sweep to rerun: robot replayed from its joints, frames as 3D quads and
        2D images, force and joint series; with a volume, reslices and the scene's phantom."""
        from resus.sweep.io import read_sweep
        from resus.visualize import make_blueprint, open_recording
        from resus.visualize.recording import LIVE_MODES
        from resus.visualize.sweep_logger import log_sweep

        if labels is not None and volume is None:
            raise ResusError("--labels needs --volume (the label volume tints its slices)")
        if rerun is None and rerun_save is None:
            raise ResusError(
                "nowhere to send the recording: give --rerun-save FILE or --rerun serve"
            )
        if rerun is not None:
            parse_choice(rerun, "--rerun", LIVE_MODES)
        sweep = read_sweep(sweep_path)
        predicted = None if predictions is None else _predicted_labels(predictions, sweep)
        phantom = None if scene is None else _scene_and_phantom(scene, subject)
        volumes = None if volume is None else _read_volumes(volume, labels)
        if volumes is not None and dense_volume:
            from resus.visualize.volume import check_dense_grid

            check_dense_grid(volumes[1])
        blueprint = make_blueprint(
            sweep=True,
            reslices=reslices is not None,
            look_at=sweep.probe_to_base[len(sweep) // 2, :3, 3],
        )
        with contextlib.ExitStack() as stack:
            dataset = None
            if reslices is not None:
                from resus.reslicing.dataset import ResliceDataset

                dataset = stack.enter_context(ResliceDataset(reslices))
            session = stack.enter_context(
                open_recording(
                    "resus", save=rerun_save, live=rerun, blueprint=blueprint,
                    grpc_port=grpc_port, web_port=web_port,
                )
            )  # fmt: skip
            if session.viewer_url:
                typer.echo(f"rerun web viewer: {session.viewer_url}")
            log_sweep(session.stream, sweep, predictions=predicted, progress=True)
            if phantom is not None:
                from resus.visualize.scene import log_phantom

                log_phantom(session.stream, *phantom)
            if volumes is not None:
                from resus.visualize.volume import log_volume

                log_volume(session.stream, *volumes, dense=dense_volume)
            if dataset is not None:
                from resus.visualize.volume import log_reslices

                count = log_reslices(
                    session.stream, dataset, dataset.label_names, limit=max_reslices
                )
                typer.echo(f"logged {count} of {len(dataset)} reslices")
            session.stream.flush()
            if rerun_save is not None:
                typer.echo(f"saved {rerun_save}")
            if session.viewer_url:
                typer.echo("serving; press Ctrl-C to stop")
                session.wait_until_interrupted()


def _predicted_labels(path: Path, sweep: Sweep):
    """The labels of the sweep file `path`, checked against `sweep`'s frames."""
    from resus.sweep.io import read_sweep

    predicted = read_sweep(path)
    if predicted.labels is None:
        raise ResusError("holds no labels to show as predictions", path)
    if predicted.labels.shape != sweep.frames.shape:
        raise ResusError(
            f"labels {predicted.labels.shape} do not match the sweep's frames {sweep.frames.shape}",
            path,
        )
    return predicted.labels


def _scene_and_phantom(scene: str, subject: int | None):
    """The scene config and its phantom."""
    from resus.acquisition.simulation import phantom_spec, resolve_scene
    from sim.phantom import Phantom

    config = resolve_scene(scene, None, subject)
    return config, Phantom(phantom_spec(config))


def _read_volumes(volume_path: Path, labels_path: Path | None):
    """(volume, grid, labels or None) from the files, labels checked to lie on the grid."""
    import numpy as np

    from resus.reconstruction.io import read_label_volume, read_volume

    array, grid, _ = read_volume(volume_path)
    if labels_path is None:
        return array, grid, None
    labels, _ = read_label_volume(labels_path, grid)
    return array, grid, labels.astype(np.uint8)
