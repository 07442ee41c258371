"""`resus plan`: make a scan trajectory from a pattern, check it on the UR3e, report.

Exit status 0 when every check passes and 1 when any fails, so scripts can gate a real scan
on it; bad input is one line on stderr and exit status 2.
"""

from __future__ import annotations

from pathlib import Path
from typing import Annotated

import typer

from resus.cli.parsers import parse_choice, parse_numbers, settings_from_flags
from resus.errors import ResusError

PATTERNS = ("linear", "fan", "multipass", "raster")


def _make_trajectory(pattern: str, phantom, phantom_to_base, options: dict):
    """The trajectory for `pattern` from the command-line options."""
    from resus.acquisition import patterns

    common = {
        key: options[key]
        for key in ("start", "direction", "speed", "contact_force", "frame_rate", "tilt_deg")
    }
    common["acceleration"] = options["acceleration"]
    if pattern == "linear":
        return patterns.linear_sweep(phantom, phantom_to_base, length=options["length"], **common)
    if pattern == "fan":
        return patterns.fan_sweep(phantom, phantom_to_base, fan_deg=options["fan_deg"], **common)
    make = patterns.multipass_sweep if pattern == "multipass" else patterns.raster_sweep
    return make(
        phantom,
        phantom_to_base,
        length=options["length"],
        passes=options["passes"],
        offset=options["offset"],
        **common,
    )


def plan(
    out: Annotated[Path, typer.Option(help="Trajectory YAML to write (resus.trajectory/1).")],
    pattern: Annotated[str, typer.Option(help="linear, fan, multipass or raster.")] = "linear",
    start: Annotated[str, typer.Option(help="Start x,y on the skin (m, phantom frame).")] = (
        "0,-0.04"
    ),
    direction: Annotated[str, typer.Option(help="Sweep direction x,y (phantom frame).")] = "0,1",
    length: Annotated[float, typer.Option(help="Length of a pass (m).")] = 0.08,
    speed: Annotated[float, typer.Option(help="Probe speed (m/s; fan: at image depth).")] = 0.01,
    acceleration: Annotated[float, typer.Option(help="Acceleration (m/s^2).")] = 0.05,
    force: Annotated[float, typer.Option(help="Contact force (N); 0: position control.")] = 4.0,
    frame_rate: Annotated[float, typer.Option(help="Frames per second.")] = 30.0,
    tilt: Annotated[float, typer.Option(help="Tilt about the array axis (deg).")] = 0.0,
    fan_angle: Annotated[float, typer.Option(help="Fan: total rocking angle (deg).")] = 40.0,
    passes: Annotated[int, typer.Option(help="Multipass/raster: number of passes.")] = 2,
    offset: Annotated[float, typer.Option(help="Multipass/raster: pass spacing (m).")] = 0.02,
    voxel_size: Annotated[float, typer.Option(help="Intended voxel size (m).")] = 0.5e-3,
    scene: Annotated[str, typer.Option(help="Scene name (assets/scenes) or YAML path.")] = (
        "default"
    ),
    phantom: Annotated[str | None, typer.Option(help="Phantom spec name or YAML path.")] = None,
    subject: Annotated[int | None, typer.Option(help="Subject variant of the phantom.")] = None,
    report: Annotated[Path | None, typer.Option(help="Folder for report.md and PNGs.")] = None,
    simulate: Annotated[
        bool, typer.Option(help="Also scan it in simulation and measure the holes.")
    ] = False,
) -> None:
    """Plan a scan, check it (IK, limits, singularities, collisions, spacing, coverage, holes)."""
    parse_choice(pattern, "--pattern", PATTERNS)
    if passes < 1:
        raise ResusError(f"--passes must be at least 1, got {passes}")
    if not out.parent.is_dir():
        raise ResusError("output folder does not exist", out.parent)
    if force < 0:
        raise ResusError(f"--force must be >= 0, got {force}")
    if not frame_rate > 0:
        raise ResusError(f"--frame-rate must be positive, got {frame_rate}")
    from resus.acquisition.simulation import phantom_spec, resolve_scene
    from resus.planning.planner import PlanSettings, check_plan
    from sim.phantom import Phantom

    settings = settings_from_flags(PlanSettings, voxel_size=("--voxel-size", voxel_size))
    scene_config = resolve_scene(scene, phantom, subject)
    phantom_model = Phantom(phantom_spec(scene_config))
    options = {
        "start": parse_numbers(start, "--start", count=2),
        "direction": parse_numbers(direction, "--direction", count=2),
        "length": length,
        "speed": speed,
        "acceleration": acceleration,
        "contact_force": force if force > 0 else None,
        "frame_rate": frame_rate,
        "tilt_deg": tilt,
        "fan_deg": fan_angle,
        "passes": passes,
        "offset": offset,
    }
    trajectory = _make_trajectory(pattern, phantom_model, scene_config.phantom_to_base, options)
    trajectory.to_yaml(out)
    typer.echo(f"wrote {out}")
    analysis = check_plan(trajectory, scene_config, phantom_model, settings)
    for check in analysis.checks:
        typer.echo(check.line())
    simulated = None
    if simulate:
        from resus.planning.simulated import simulate_plan

        folder = report if report is not None else out.parent
        folder.mkdir(parents=True, exist_ok=True)
        outcome = simulate_plan(
            folder / f"{out.stem}_sweep.h5", scene_config, trajectory, voxel_size
        )
        simulated = outcome.describe()
        typer.echo(simulated)
    if report is not None:
        from resus.planning.report import write_report

        typer.echo(f"wrote {write_report(report, analysis, simulated)}")
    passed = sum(check.passed for check in analysis.checks)
    typer.echo(f"{passed}/{len(analysis.checks)} checks pass")
    if not analysis.passed:
        raise typer.Exit(1)


def register(app: typer.Typer) -> None:
    """Add `resus plan`."""
    app.command()(plan)
