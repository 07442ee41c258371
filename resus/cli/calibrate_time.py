"""`resus calibration-plan` and `resus calibrate-time`: find the video's delay against the robot.

1. `resus calibration-plan cal.yaml --start 0,0` writes an oscillating trajectory: the probe
   moves back and forth along its array on the skin of the scene's phantom.
2. `resus scan ... --trajectory cal.yaml --out cal.h5` records it.
3. `resus calibrate-time cal.h5` prints the offset to add to `--time-offset` for later scans.
"""

from __future__ import annotations

import functools
from pathlib import Path
from typing import Annotated

import numpy as np
import typer

from resus.cli.options import PhantomOption, SceneOption
from resus.cli.parsers import flag_error, parse_numbers, parse_range, settings_from_flags
from resus.errors import ResusError


def calibrate_time_command(
    sweep_path: Annotated[
        Path, typer.Argument(metavar="SWEEP", help="Calibration sweep (.h5): in-plane oscillation.")
    ],
    search: Annotated[
        str, typer.Option("--range", help="Offsets to search, LOW:HIGH seconds.")
    ] = "-0.5:0.5",
    step: Annotated[float, typer.Option(help="Search step (s); refined below it.")] = 0.001,
    plot: Annotated[Path | None, typer.Option(help="Save the signals and scores as a PNG.")] = None,
) -> None:
    """Estimate the image-vs-pose time offset of a calibration sweep (PLUS-style)."""
    from resus.acquisition.calibration.temporal import calibrate_time, save_plot
    from resus.sweep.io import read_sweep

    low, high = parse_range(search, "--range")
    if not step > 0:
        raise ResusError(f"--step must be positive, got {step}")
    result = calibrate_time(read_sweep(sweep_path), (low, high), step)
    typer.echo(result.describe())
    if plot is not None:
        save_plot(result, plot)
        typer.echo(f"wrote {plot}")


def calibration_plan(
    out: Annotated[Path, typer.Argument(metavar="OUT", help="Trajectory YAML to write.")],
    start: Annotated[str, typer.Option(help="Centre x,y on the skin (m, phantom frame).")] = "0,0",
    direction: Annotated[
        str, typer.Option(help="Probe array direction x,y (phantom frame) to move along.")
    ] = "1,0",
    amplitude: Annotated[float, typer.Option(help="Travel to either side (m).")] = 0.005,
    cycles: Annotated[int, typer.Option(help="Back-and-forth cycles.")] = 3,
    speed: Annotated[float, typer.Option(help="Probe speed (m/s).")] = 0.01,
    force: Annotated[float, typer.Option(help="Contact force (N); 0: position control.")] = 4.0,
    frame_rate: Annotated[float, typer.Option(help="Frames per second.")] = 30.0,
    scene: SceneOption = "default",
    phantom: PhantomOption = None,
) -> None:
    """Write an oscillating calibration trajectory on the scene's phantom."""
    from resus.acquisition.calibration.temporal import oscillation
    from resus.acquisition.patterns import skin_poses, sweep_heading
    from resus.acquisition.simulation import phantom_spec, resolve_scene
    from sim.phantom import Phantom

    if not out.parent.is_dir():
        raise ResusError("output folder does not exist", out.parent)
    scene_config = resolve_scene(scene, phantom, None)
    model = Phantom(phantom_spec(scene_config))
    x, y = parse_numbers(direction, "--direction", count=2)
    # the array lies along `direction`: the pattern heading is `direction` turned +90 deg about z
    with flag_error("--direction"):
        heading = sweep_heading((-y, x))
    centre_xy = np.array([parse_numbers(start, "--start", count=2)])
    centre = skin_poses(model, scene_config.phantom_to_base, centre_xy, heading, np.zeros(1))[0]
    trajectory = settings_from_flags(
        functools.partial(oscillation, centre),
        amplitude=("--amplitude", amplitude),
        cycles=("--cycles", cycles),
        speed=("--speed", speed),
        contact_force=("--force", force if force > 0 else None),
        frame_rate=("--frame-rate", frame_rate),
    )
    trajectory.to_yaml(out)
    typer.echo(
        f"wrote {out}: {cycles} cycles of +-{amplitude * 1e3:.1f} mm in {trajectory.duration:.1f} s"
    )


def register(app: typer.Typer) -> None:
    """Add `resus calibrate-time` and `resus calibration-plan`."""
    app.command("calibrate-time")(calibrate_time_command)
    app.command("calibration-plan")(calibration_plan)
