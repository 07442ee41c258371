"""Options that several commands share, declared once so that each reads (and is checked) the
same everywhere: the scene and its phantom subject, the OpenIGTLink stream of a scan, the
torch device and the ImageNet encoder weights, the sweep file a command reads or writes, and
the live viewer (rerun) with its ports."""

from __future__ import annotations

from pathlib import Path
from typing import TYPE_CHECKING, Annotated

import typer

if TYPE_CHECKING:
    import numpy as np

    from resus.sweep.igtl import IgtlServer

SceneOption = Annotated[str, typer.Option(help="Scene name (assets/scenes) or YAML path.")]
PhantomOption = Annotated[str | None, typer.Option(help="Phantom spec name or YAML path.")]
SubjectOption = Annotated[int | None, typer.Option(help="Subject variant of the phantom.")]
IgtlPortOption = Annotated[
    int | None,
    typer.Option(
        "--igtl", metavar="PORT", help="Stream every frame over OpenIGTLink on this port."
    ),
]
IgtlHostOption = Annotated[str, typer.Option(help="Address the OpenIGTLink stream listens on.")]
DeviceOption = Annotated[str, typer.Option(help="auto (CUDA when present), cpu, cuda.")]
WeightsOption = Annotated[
    Path | None, typer.Option(help="Local torchvision ResNet state dict, for the imagenet regime.")
]
SweepArgument = Annotated[Path, typer.Argument(metavar="SWEEP", help="Sweep file (.h5).")]
SweepOutOption = Annotated[Path, typer.Option("--out", help="Sweep file to write (.h5).")]
RerunOption = Annotated[
    str | None,
    typer.Option(
        "--rerun",
        help="Live viewer: 'serve' (web viewer on 127.0.0.1, Ctrl-C ends it) or "
        "'spawn' (native viewer, needs a display).",
    ),
]
RerunSaveOption = Annotated[
    Path | None, typer.Option("--rerun-save", help="Save the recording to FILE.rrd.")
]
GrpcPortOption = Annotated[int, typer.Option(help="gRPC port of the live viewer.")]
WebPortOption = Annotated[int, typer.Option(help="HTTP port of the served web viewer.")]


def recorded_subject_option(flag: str, default: str) -> typer.models.OptionInfo:
    """The option of a command that writes a sweep naming the subject it records there;
    `default` says what is recorded when it is not given."""
    return typer.Option(flag, help=f"Subject recorded in the sweep (default: {default}).")


def open_igtl_stream(image_to_probe: np.ndarray, port: int, host: str) -> IgtlServer:
    """What `--igtl PORT` (`--igtl-host HOST`) opens: a server for the frames a command
    records, placed by `image_to_probe`, announced in one line with the port it listens on
    (the one it got, when asked for 0)."""
    from resus.sweep.igtl import IMAGE_NAME, TRANSFORM_NAME, IgtlServer, check_port

    server = IgtlServer(image_to_probe, check_port(port, "--igtl", allow_zero=True), host)
    typer.echo(
        f"streaming OpenIGTLink on {server.address}: IMAGE {IMAGE_NAME}, TRANSFORM "
        f"{TRANSFORM_NAME} (mm)"
    )
    return server
