"""`resus reconstruct`: a sweep (or a PLUS sequence) to an intensity volume and a label volume."""

from __future__ import annotations

from pathlib import Path

import typer

from resus.cli.parsers import parse_numbers, settings_from_flags
from resus.errors import ResusError


def _load_sweep(path: Path, calibration: Path | None):
    """A Sweep from `resus.sweep/1` HDF5, or from a PLUS .igs.mha with its config XML."""
    if not path.is_file():
        raise ResusError("no such sweep file", path)
    if path.suffix.lower() in (".mha", ".mhd"):
        if calibration is None:
            raise ResusError("a PLUS sequence needs --calibration CONFIG.xml (ImageToProbe)", path)
        from resus.sweep.plus import import_plus_sequence, read_plus_calibration

        return import_plus_sequence(path, read_plus_calibration(calibration))
    from resus.sweep.io import read_sweep

    return read_sweep(path)


def register(app: typer.Typer) -> None:
    """Add the `reconstruct` command to the root app."""

    @app.command("reconstruct")
    def reconstruct_command(
        sweep_path: Path = typer.Argument(
            ..., metavar="SWEEP", help="Sweep .h5, or PLUS .igs.mha with --calibration."
        ),
        out: Path = typer.Option(
            ..., "--out", help="Intensity volume, .nrrd or .mha (millimetres)."
        ),
        labels_out: Path | None = typer.Option(
            None, "--labels-out", help="Label volume, .nrrd or .mha."
        ),
        grid_kind: str = typer.Option(
            "ransac", "--grid", help="ransac (the paper's parallelepiped) or aabb (PLUS's box)."
        ),
        spacing: float = typer.Option(
            0.5e-3, "--spacing", help="Voxel spacing (m); for ransac sets the voxel counts."
        ),
        voxels: str | None = typer.Option(
            None, "--voxels", help="RANSAC grid voxel counts NX,NY,NZ (instead of --spacing)."
        ),
        method: str = typer.Option(
            "sdw", "--method", help="sdw, nn (nearest neighbour) or linear (trilinear)."
        ),
        compounding: str = typer.Option("mean", "--compounding", help="mean or max."),
        radius: float = typer.Option(1.5, "--radius", help="SDW radius (voxels)."),
        alpha: float = typer.Option(0.1, "--alpha", help="SDW weight offset alpha (voxels)."),
        fill_passes: int = typer.Option(
            3, "--fill-passes", help="Hole-filling passes, radius growing 1 voxel each (0: none)."
        ),
        seed: int = typer.Option(0, "--seed", help="RANSAC seed."),
        png: Path | None = typer.Option(
            None, "--png", help="PNG of three orthogonal slices (labels overlaid)."
        ),
        calibration: Path | None = typer.Option(
            None, "--calibration", help="PLUS config XML, for .igs.mha input."
        ),
    ) -> None:
        """Reconstruct a tracked sweep into a volume (squared-distance-weighted compounding)."""
        import numpy as np

        from resus.reconstruction.compounding import ReconstructionSettings, reconstruct
        from resus.reconstruction.figures import save_slices_png
        from resus.reconstruction.grid_settings import GridSettings
        from resus.reconstruction.io import intensity_to_uint8, volume_suffix, write_volume

        shape: tuple[int, int, int] | None = None
        if voxels is not None:
            nx, ny, nz = parse_numbers(voxels, "--voxels", count=3, kind=int)
            shape = (nx, ny, nz)
        grid_settings = settings_from_flags(
            GridSettings,
            kind=("--grid", grid_kind),
            spacing=("--spacing", spacing),
            voxels=("--voxels", shape),
            seed=("--seed", seed),
        )
        settings = settings_from_flags(
            ReconstructionSettings,
            method=("--method", method),
            compounding=("--compounding", compounding),
            radius=("--radius", radius),
            alpha=("--alpha", alpha),
            fill_passes=("--fill-passes", fill_passes),
        )
        for path in (out, labels_out, png):
            if path is not None and not path.parent.is_dir():
                raise ResusError("output folder does not exist", path.parent)
        for path in (out, labels_out):
            if path is not None:
                volume_suffix(path)
        sweep = _load_sweep(sweep_path, calibration)
        poses = np.asarray(sweep.probe_to_base)
        frame_shape = tuple(sweep.frames.shape[1:])
        if len(poses) == 0:
            raise ResusError("the sweep has no frames", sweep_path)
        grid = grid_settings.around(poses, sweep.image_to_probe, frame_shape)
        typer.echo(f"grid: {grid_kind}, {grid.describe()}")
        if labels_out is not None and sweep.labels is None:
            raise ResusError("--labels-out given but the sweep has no labels", sweep_path)
        label_names = list(sweep.label_names) if sweep.labels is not None else None
        result = reconstruct(
            sweep.frames, poses, sweep.image_to_probe, grid, settings,
            labels=sweep.labels, n_classes=len(label_names or ()), progress=True, total=len(poses),
        )  # fmt: skip
        subject = sweep.subject or None
        write_volume(out, intensity_to_uint8(result.volume), grid, subject=subject)
        typer.echo(
            f"wrote {out} ({result.observed.mean():.1%} of voxels observed, "
            f"{result.filled.mean():.1%} filled)"
        )
        if labels_out is not None:
            # --labels-out needs sweep labels (checked above), so reconstruct made a label volume
            assert result.labels is not None
            write_volume(labels_out, result.labels, grid, label_names, subject=subject)
            typer.echo(f"wrote {labels_out}")
        if png is not None:
            save_slices_png(
                png,
                result.volume,
                grid,
                result.labels,
                title=f"{sweep_path.name}: {method} {compounding}",
            )
            typer.echo(f"wrote {png}")
