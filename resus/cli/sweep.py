"""`resus sweep ...`: look inside sweep files, convert to and from PLUS and ROS, stream over
OpenIGTLink, exchange labels with CVAT, draw a preview."""

from __future__ import annotations

from collections.abc import Callable
from pathlib import Path
from typing import TYPE_CHECKING, Annotated, TypeVar

import typer

from resus.cli.options import SweepArgument, SweepOutOption, recorded_subject_option
from resus.errors import ResusError

if TYPE_CHECKING:
    from resus.sweep.model import Sweep

Exported = TypeVar("Exported")

sweep_app = typer.Typer(
    help="Sweep files (resus.sweep/1 HDF5): inspect, import/export PLUS .igs.mha and ROS bags, "
    "stream over OpenIGTLink, CVAT labels, preview.",
    no_args_is_help=True,
)


def _out_folder_exists(path: Path) -> None:
    if not path.parent.is_dir():
        raise ResusError("output folder does not exist", path.parent)


def _export_sweep(
    sweep_path: Path,
    out: Path,
    config: Path | None,
    export: Callable[[Sweep, Path], Exported],
) -> tuple[Sweep, Path, Exported]:
    """Read the sweep at `sweep_path`, `export` it to `out` and write its calibration as a PLUS
    config XML to `config` (default: beside `out`, NAME_config.xml).

    Returns the sweep, the config path and what `export` returned.
    """
    from resus.sweep.io import read_sweep
    from resus.sweep.plus import write_plus_calibration

    config = config or out.with_name(out.name.split(".")[0] + "_config.xml")
    for path in (out, config):
        _out_folder_exists(path)
    sweep = read_sweep(sweep_path)
    exported = export(sweep, out)
    write_plus_calibration(sweep.image_to_probe, config)
    return sweep, config, exported


def _present(sweep: Sweep, names: tuple[str, ...]) -> str:
    """The comma-separated `names` of the sweep's optional data that it holds ('' if none)."""
    return ", ".join(name for name in names if getattr(sweep, name) is not None)


@sweep_app.command("info")
def info_command(
    sweep_path: SweepArgument,
) -> None:
    """Frames, image size, spacing, path length, frame spacing, duration and contents."""
    from resus.sweep.summary import summarize_sweep

    lines = summarize_sweep(sweep_path).lines()
    width = max(len(name) for name, _ in lines)
    for name, value in lines:
        typer.echo(f"{name:<{width}}  {value}")


@sweep_app.command("import-plus")
def import_plus_command(
    sequence: Annotated[Path, typer.Argument(metavar="FILE.igs.mha", help="PLUS sequence.")],
    out: SweepOutOption,
    calibration: Annotated[
        Path | None,
        typer.Option(
            "--calibration",
            metavar="CONFIG.xml",
            help="PLUS config XML with the Image to Probe transform "
            "(default: the sequence's ImageToProbeTransform field).",
        ),
    ] = None,
    subject: Annotated[str | None, recorded_subject_option("--subject", "the file name")] = None,
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
    sweep_path: SweepArgument,
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
    from resus.sweep.plus import export_plus_sequence

    sweep, config, _ = _export_sweep(sweep_path, out, config, export_plus_sequence)
    typer.echo(f"exported {len(sweep)} frames to {out}; calibration in {config}")
    if dropped := _present(sweep, ("labels", "wrench", "joint_positions")):
        typer.echo(f"not exported (PLUS sequences hold no such data): {dropped}")


@sweep_app.command("preview")
def preview_command(
    sweep_path: SweepArgument,
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


@sweep_app.command("stream")
def stream_command(
    sweep_path: SweepArgument,
    igtl: Annotated[
        int,
        typer.Option(
            "--igtl", metavar="PORT", help="OpenIGTLink port to serve (PLUS and Slicer use 18944)."
        ),
    ],
    loop: Annotated[bool, typer.Option("--loop", help="Start over after the last frame.")] = False,
    speed: Annotated[float, typer.Option("--speed", help="Replay speed (2: twice as fast).")] = 1.0,
    host: Annotated[
        str, typer.Option("--host", help="Address to listen on (0.0.0.0: every interface).")
    ] = "127.0.0.1",
) -> None:
    """Replay a sweep over OpenIGTLink at its recorded timing, as PLUS sends (3D Slicer)."""
    from resus.sweep.igtl import IMAGE_NAME, TRANSFORM_NAME, IgtlServer, check_port, stream_sweep
    from resus.sweep.io import read_sweep

    check_port(igtl, "--igtl", allow_zero=True)
    if not speed > 0:
        raise ResusError(f"--speed must be positive, got {speed}")
    sweep = read_sweep(sweep_path)
    duration = (sweep.timestamps[-1] - sweep.timestamps[0]) / speed

    def ready(server: IgtlServer) -> None:
        typer.echo(
            f"serving {len(sweep)} frames ({duration:.2f} s{', looped' if loop else ''}) from "
            f"{sweep_path} on {server.address}: IMAGE {IMAGE_NAME}, TRANSFORM {TRANSFORM_NAME} "
            "(mm); waiting for a client, Ctrl-C to stop"
        )

    sent = stream_sweep(sweep, igtl, loop, speed, host=host, on_ready=ready)
    typer.echo(f"sent {sent} frames")


def _calibration_option(help_text: str):
    return typer.Option("--calibration", metavar="probe.yaml|config.xml", help=help_text)


@sweep_app.command("import-ros")
def import_ros_command(
    bag: Annotated[
        Path, typer.Argument(metavar="BAG", help="ROS 1 .bag, ROS 2 bag folder or .mcap file.")
    ],
    image_topic: Annotated[
        str, typer.Option("--image-topic", help="sensor_msgs Image or CompressedImage topic.")
    ],
    calibration: Annotated[
        Path,
        _calibration_option("Probe calibration: resus.probe/1 YAML or PLUS config XML."),
    ],
    out: SweepOutOption,
    pose_topic: Annotated[
        str | None, typer.Option("--pose-topic", help="geometry_msgs PoseStamped topic.")
    ] = None,
    tf: Annotated[
        tuple[str, str] | None,
        typer.Option("--tf", metavar="PARENT CHILD", help="Or the tf chain PARENT -> probe TCP."),
    ] = None,
    wrench_topic: Annotated[
        str | None, typer.Option("--wrench-topic", help="geometry_msgs WrenchStamped topic.")
    ] = None,
    subject: Annotated[str | None, recorded_subject_option("--subject", "the bag's name")] = None,
) -> None:
    """Import a ROS bag (images placed by a pose topic or tf) as a sweep file."""
    from resus.sweep.io import write_sweep
    from resus.sweep.ros import import_ros

    _out_folder_exists(out)
    if (pose_topic is None) == (tf is None):
        raise ResusError("give one pose source: --pose-topic TOPIC or --tf PARENT CHILD")
    result = import_ros(
        bag, image_topic, pose_topic, tf, calibration, wrench_topic=wrench_topic, subject=subject
    )
    write_sweep(out, result.sweep)
    low, high = result.pose_span
    typer.echo(
        f"imported {len(result.sweep)} of {result.images} images from {bag} into {out} "
        f"({result.poses} pose samples, {low:.3f} .. {high:.3f} s)"
    )
    if result.outside_poses:
        typer.echo(f"left out {result.outside_poses} images stamped outside the pose stream")
    if result.repeated_stamps:
        typer.echo(f"left out {result.repeated_stamps} images repeating an earlier stamp")


@sweep_app.command("export-ros")
def export_ros_command(
    sweep_path: SweepArgument,
    out: Annotated[Path, typer.Option("--out", help="ROS 2 bag: FILE.mcap, or a new folder.")],
    calibration_out: Annotated[
        Path | None,
        typer.Option(
            "--calibration-out",
            help="PLUS config XML with the calibration (default: beside --out, NAME_config.xml).",
        ),
    ] = None,
) -> None:
    """Export a sweep as a ROS 2 MCAP bag (images, tf, wrench) for Foxglove and RViz."""
    from resus.sweep.ros import export_ros

    sweep, config, topics = _export_sweep(sweep_path, out, calibration_out, export_ros)
    typer.echo(
        f"exported {len(sweep)} frames to {out} ({', '.join(topics)}); calibration in {config}"
    )
    if dropped := _present(sweep, ("labels", "joint_positions")):
        typer.echo(f"not exported: {dropped}")


@sweep_app.command("attach-labels")
def attach_labels_command(
    sweep_path: SweepArgument,
    masks: Annotated[
        Path,
        typer.Option(
            "--masks",
            metavar="DIR",
            help="CVAT 'Segmentation mask 1.1' export, or label PNGs (0, 1, 2) per frame.",
        ),
    ],
    out: Annotated[
        Path | None, typer.Option("--out", help="Sweep file to write (default: SWEEP itself).")
    ] = None,
) -> None:
    """Make CVAT masks (or plain label PNGs) the sweep's labels."""
    import os
    import tempfile

    from resus.sweep.cvat import attach_labels
    from resus.sweep.io import read_sweep, write_sweep

    target = out or sweep_path
    _out_folder_exists(target)
    sweep = read_sweep(sweep_path)
    labelled = attach_labels(sweep, masks)
    handle, scratch = tempfile.mkstemp(dir=target.parent, prefix=f".{target.name}.", suffix=".h5")
    os.close(handle)
    try:
        write_sweep(scratch, labelled)
        os.replace(scratch, target)  # a crash never leaves a half-written sweep in place
    finally:
        if os.path.exists(scratch):
            os.unlink(scratch)
    assert labelled.labels is not None
    shares = [float((labelled.labels == value).mean()) * 100 for value in (1, 2)]
    replaced = "; replaced the labels it had" if sweep.labels is not None else ""
    typer.echo(
        f"labelled {len(labelled)} frames of {target} from {masks} (artery {shares[0]:.1f} %, "
        f"vein {shares[1]:.1f} % of pixels){replaced}"
    )


@sweep_app.command("export-labels")
def export_labels_command(
    sweep_path: SweepArgument,
    out: Annotated[Path, typer.Option("--out", metavar="DIR", help="Folder to write.")],
    frames: Annotated[
        bool, typer.Option("--frames", help="Also write the frames (JPEGImages/, PNG).")
    ] = False,
) -> None:
    """Write the sweep's labels as a CVAT 'Segmentation mask 1.1' folder (to correct in CVAT)."""
    from resus.sweep.cvat import export_labels
    from resus.sweep.io import read_sweep

    _out_folder_exists(out)
    count = export_labels(read_sweep(sweep_path), out, frames=frames)
    typer.echo(f"wrote {count} masks (frame_000000.png ...) with labelmap.txt to {out}")


def register(app: typer.Typer) -> None:
    """Add the `sweep` command group to the root app."""
    app.add_typer(sweep_app, name="sweep")
