"""`resus realism`: how close simulated sweeps' frames come to real B-mode images."""

from __future__ import annotations

from pathlib import Path
from typing import Annotated

import typer

from resus.cli.parsers import flag_error


def register(app: typer.Typer) -> None:
    """Add the `realism` command to the root app."""

    @app.command("realism")
    def realism_command(
        sweeps: Annotated[
            list[Path],
            typer.Option("--sweep", help="Simulated sweep (.h5) with labels; repeat for more."),
        ],
        real: Annotated[
            Path, typer.Option("--real", help="Folder of real images/NNNN.png and masks/NNNN.png.")
        ],
        out: Annotated[Path, typer.Option("--out", help="Output folder (created if missing).")],
        frames: Annotated[
            int, typer.Option("--frames", min=1, help="Frames per sweep, evenly spaced.")
        ] = 32,
    ) -> None:
        """Grey levels, contrast and speckle of simulated frames against real images:
        realism.json, realism.md, sim_vs_real.png, histograms.png."""
        from resus.experiments.realism import (
            HISTOGRAMS_PNG,
            REALISM_JSON,
            REALISM_MD,
            SIM_VS_REAL_PNG,
            read_image_folder,
            read_sweep_set,
            write_realism_report,
        )

        with flag_error("--sweep"):
            simulated = read_sweep_set(sweeps, frames)
        with flag_error("--real"):
            real_images = read_image_folder(real)
        sources = {
            "sweeps": ", ".join(map(str, sweeps)),
            "frames per sweep": frames,
            "real": str(real),
        }
        comparison = write_realism_report(out, simulated, real_images, sources=sources)
        typer.echo("\n".join(comparison.to_markdown()))
        files = ", ".join((REALISM_JSON, REALISM_MD, SIM_VS_REAL_PNG, HISTOGRAMS_PNG))
        typer.echo(f"wrote {files} to {out}")
