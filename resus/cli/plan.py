"""`resus plan`: make a scan trajectory from a pattern, check it on the UR3e, report.

Exit status 0 when every check passes and 1 when any fails, so scripts can gate a real scan
on it; bad input is one line on stderr and exit status 2.
"""

from __future__ import annotations

from collections.abc import Mapping
from pathlib import Path
from typing import Annotated

import typer

from resus.cli.options import PhantomOption, SceneOption, SubjectOption
from resus.cli.parsers import parse_choice, parse_numbers, settings_from_flags
from resus.errors import ResusError

PATTERN_FLAGS = {
    "start": "--start",
    "direction": "--direction",
    "length": "--length",
    "speed": "--speed",
    "acceleration": "--acceleration",
    "contact_force": "--force",
    "frame_rate": "--frame-rate",
    "tilt_deg": "--tilt",
    "fan_deg": "--fan-angle",
    "passes": "--passes",
    "offset": "--offset",
    "stations": "--stations",
    "station_spacing": "--station-spacing",
    "press_force": "--press-force",
    "press_time": "--press-time",
    "hold_time": "--hold-time",
    "light_time": "--light-time",
}
"""The pattern setting each flag sets (`resus.acquisition.patterns`)."""
PATTERN_DEFAULT = "(default: the pattern's)"


def make_pattern(name: str, given: Mapping[str, object]):
    """The named pattern with the flags that were given; the others keep the pattern's own
    defaults (one place for each: its dataclass). A flag the pattern does not take is an error."""
    import dataclasses

    from resus.acquisition.patterns import PATTERNS

    kind = PATTERNS[parse_choice(name, "--pattern", tuple(PATTERNS))]
    fields = {field.name for field in dataclasses.fields(kind)}
    for setting in given:
        if setting not in fields:
            raise ResusError(f"{PATTERN_FLAGS[setting]} does not apply to --pattern {name}")
    flags = {setting: (PATTERN_FLAGS[setting], value) for setting, value in given.items()}
    return settings_from_flags(kind, **flags)


def plan(
    out: Annotated[Path, typer.Option(help="Trajectory YAML to write (resus.trajectory/1).")],
    pattern: Annotated[
        str, typer.Option(help="linear, fan, multipass, raster or compression.")
    ] = "linear",
    start: Annotated[
        str | None, typer.Option(help=f"Start x,y on the skin (m, phantom) {PATTERN_DEFAULT}.")
    ] = None,
    direction: Annotated[
        str | None, typer.Option(help=f"Sweep direction x,y (phantom) {PATTERN_DEFAULT}.")
    ] = None,
    length: Annotated[float | None, typer.Option(help="Length of a pass (m).")] = None,
    speed: Annotated[
        float | None, typer.Option(help="Probe speed (m/s; fan: at image depth).")
    ] = None,
    acceleration: Annotated[float | None, typer.Option(help="Acceleration (m/s^2).")] = None,
    force: Annotated[
        float | None,
        typer.Option(help="Contact force (N; compression: light contact); 0: position control."),
    ] = None,
    frame_rate: Annotated[float | None, typer.Option(help="Frames per second.")] = None,
    tilt: Annotated[float | None, typer.Option(help="Tilt about the array axis (deg).")] = None,
    fan_angle: Annotated[float | None, typer.Option(help="Fan: total rocking angle (deg).")] = None,
    passes: Annotated[int | None, typer.Option(help="Multipass/raster: number of passes.")] = None,
    offset: Annotated[
        float | None, typer.Option(help="Multipass/raster: pass spacing (m).")
    ] = None,
    stations: Annotated[
        int | None, typer.Option(help="Compression: number of stations, from --start on.")
    ] = None,
    station_spacing: Annotated[
        float | None, typer.Option(help="Compression: distance between stations (m).")
    ] = None,
    press_force: Annotated[
        float | None, typer.Option(help="Compression: force of each press (N).")
    ] = None,
    press_time: Annotated[
        float | None, typer.Option(help="Compression: rise (and fall) of each press (s).")
    ] = None,
    hold_time: Annotated[
        float | None, typer.Option(help="Compression: time at the press force (s).")
    ] = None,
    light_time: Annotated[
        float | None, typer.Option(help="Compression: light contact before and after (s).")
    ] = None,
    voxel_size: Annotated[float, typer.Option(help="Intended voxel size (m).")] = 0.5e-3,
    scene: SceneOption = "default",
    phantom: PhantomOption = None,
    subject: SubjectOption = None,
    report: Annotated[Path | None, typer.Option(help="Folder for report.md and PNGs.")] = None,
    simulate: Annotated[
        bool, typer.Option(help="Also scan it in simulation and measure the holes.")
    ] = False,
) -> None:
    """Plan a scan, check it (IK, limits, singularities, collisions, the force of a simulated
    scan, spacing, coverage, holes).

    Settings not given keep the pattern's defaults (`resus.acquisition.patterns`)."""
    given = {
        "start": None if start is None else parse_numbers(start, "--start", count=2),
        "direction": None
        if direction is None
        else parse_numbers(direction, "--direction", count=2),
        "length": length,
        "speed": speed,
        "acceleration": acceleration,
        "contact_force": force,
        "frame_rate": frame_rate,
        "tilt_deg": tilt,
        "fan_deg": fan_angle,
        "passes": passes,
        "offset": offset,
        "stations": stations,
        "station_spacing": station_spacing,
        "press_force": press_force,
        "press_time": press_time,
        "hold_time": hold_time,
        "light_time": light_time,
    }
    given = {setting: value for setting, value in given.items() if value is not None}
    if given.get("contact_force") == 0:
        given["contact_force"] = None  # position control
    if not out.parent.is_dir():
        raise ResusError("output folder does not exist", out.parent)
    sweep_pattern = make_pattern(pattern, given)
    from resus.acquisition.simulation import phantom_spec, resolve_scene
    from resus.planning.planner import PlanSettings, check_plan
    from sim.phantom import Phantom

    settings = settings_from_flags(PlanSettings, voxel_size=("--voxel-size", voxel_size))
    scene_config = resolve_scene(scene, phantom, subject)
    phantom_model = Phantom(phantom_spec(scene_config))
    trajectory = sweep_pattern.trajectory(phantom_model, scene_config.phantom_to_base)
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
