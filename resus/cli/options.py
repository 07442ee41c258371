"""Options that several commands share, declared once so that each reads (and is checked) the
same everywhere: the scene and its phantom subject, the OpenIGTLink stream of a scan and the
torch device."""

from __future__ import annotations

from typing import Annotated

import typer

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
