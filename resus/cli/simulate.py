"""`resus simulate`: scan a simulated phantom with the simulated UR3e, write Sweeps.

With `--subjects`, every subject's sweep is a unit on an executor (worker processes here, or
Ray), recorded when it finishes in `OUT/.done/` with the settings it was made with, so a
rerun of the same command makes only the sweeps that are missing.
"""

from __future__ import annotations

import dataclasses
from pathlib import Path
from typing import TYPE_CHECKING, Annotated

import typer

from resus.cli.executor_options import AddressOption, ExecutorOption, check_executor_flags
from resus.cli.options import (
    IgtlHostOption,
    IgtlPortOption,
    PhantomOption,
    SceneOption,
    SubjectOption,
)
from resus.cli.parsers import flag_error, parse_index_set, parse_numbers
from resus.cli.plan import make_pattern
from resus.errors import ResusError

if TYPE_CHECKING:
    from resus.execution import Executor, UnitRecord
    from sim.ultrasound.scanner import ScannerPreset

DONE_FOLDER = ".done"
"""Under a --subjects output folder: one record per finished sweep."""


def _simulate_one(job: dict) -> tuple[str, int]:
    """One subject's sweep (top level so worker processes can run it)."""
    from resus.acquisition.simulation import resolve_scene, simulate_sweep
    from resus.acquisition.trajectory import Trajectory

    scene = resolve_scene(job["scene"], job["phantom"], job["subject"])
    preset = sweep_scanner(job.get("scanner"), job["seed"], job["subject"])
    trajectory = job["trajectory"]
    if isinstance(trajectory, str):
        trajectory = Trajectory.from_yaml(trajectory)
    result = simulate_sweep(
        job["out"],
        scene,
        trajectory,
        seed=job["seed"],
        preset=preset,
        progress=job["progress"],
        listeners=job.get("listeners", ()),
        rigid=job.get("rigid", False),
    )
    return str(result.path), result.frames


def sweep_scanner(name: str | None, seed: int | None, subject: int | None) -> ScannerPreset | None:
    """The `--scanner` preset of one sweep (`sim.ultrasound.scanner.sweep_preset`), a bad
    name reported under the flag."""
    from sim.ultrasound.scanner import sweep_preset

    with flag_error("--scanner"):
        return sweep_preset(name, seed, subject)


def simulate(
    out: Annotated[Path, typer.Option(help="Sweep file (.h5), or a folder with --subjects.")],
    scene: SceneOption = "default",
    phantom: PhantomOption = None,
    subject: SubjectOption = None,
    subjects: Annotated[
        str | None, typer.Option(help="Several subjects, e.g. 0-7: one sweep each, both cores.")
    ] = None,
    trajectory: Annotated[
        str, typer.Option(help="'linear' (built in) or a trajectory YAML file.")
    ] = "linear",
    start: Annotated[str, typer.Option(help="Linear: start x,y on the skin (m, phantom).")] = (
        "0,-0.04"
    ),
    direction: Annotated[str, typer.Option(help="Linear: direction x,y (phantom frame).")] = "0,1",
    length: Annotated[float, typer.Option(help="Linear: sweep length (m).")] = 0.08,
    speed: Annotated[float, typer.Option(help="Linear: probe speed (m/s).")] = 0.01,
    frame_rate: Annotated[float, typer.Option(help="Linear: frames per second.")] = 30.0,
    force: Annotated[
        float, typer.Option(help="Linear: contact force (N); 0 for position control.")
    ] = 4.0,
    tilt: Annotated[float, typer.Option(help="Linear: tilt about the array axis (deg).")] = 0.0,
    seed: Annotated[int | None, typer.Option(help="Phantom seed (anatomy and speckle).")] = None,
    scanner: Annotated[
        str | None,
        typer.Option(
            help="Scanner preset: vascular, vascular-compound, vascular-deep, nerve, classic, "
            "random-N, random (one per sweep), or a preset YAML file; default: the "
            "simulator's own settings."
        ),
    ] = None,
    rigid: Annotated[
        bool,
        typer.Option(
            help="Image the rigid world: no tissue deformation under the probe, no pulsation."
        ),
    ] = False,
    preview: Annotated[Path | None, typer.Option(help="Also save a contact sheet PNG.")] = None,
    jobs: Annotated[
        int, typer.Option(min=1, help="Worker processes for --subjects, or a local Ray's CPUs.")
    ] = 2,
    executor: ExecutorOption = "local",
    address: AddressOption = None,
    igtl: IgtlPortOption = None,
    igtl_host: IgtlHostOption = "127.0.0.1",
) -> None:
    """Scan a simulated phantom with the simulated UR3e and write Sweeps with labels."""
    if trajectory == "linear":
        plan: object = make_pattern(
            "linear",
            {
                "start": parse_numbers(start, "--start", count=2),
                "direction": parse_numbers(direction, "--direction", count=2),
                "length": length,
                "speed": speed,
                "contact_force": force if force > 0 else None,
                "frame_rate": frame_rate,
                "tilt_deg": tilt,
            },
        )
    elif Path(trajectory).is_file():
        plan = trajectory
    else:
        raise ResusError("--trajectory: neither 'linear' nor an existing file", trajectory)
    sweep_scanner(scanner, seed, subject)  # a bad name fails here, before any work
    check_executor_flags(executor, address)
    base = {
        "scene": scene,
        "phantom": phantom,
        "trajectory": plan,
        "seed": seed,
        "scanner": scanner,
        "rigid": rigid,
    }
    if igtl is not None and subjects is not None:
        raise ResusError("--igtl streams one sweep: not with --subjects")
    if subjects is None and executor != "local":
        raise ResusError(f"--executor {executor} runs the sweeps of --subjects: one runs here")
    kept: list[Path] = []
    if subjects is None:
        if not out.parent.is_dir():
            raise ResusError("output folder does not exist", out.parent)
        job = {**base, "subject": subject, "out": out, "progress": True}
        if igtl is None:
            _simulate_one(job)
        else:
            with _igtl_server(igtl, igtl_host) as server:
                _simulate_one({**job, "listeners": [server]})
        outputs = [out]
    else:
        from resus.execution import make_executor

        numbers = parse_index_set(subjects, "--subjects")
        with make_executor(executor, jobs, address) as engine:
            outputs, kept = _simulate_many(base, numbers, out, engine)
    for path in outputs:
        if path in kept:
            typer.echo(f"kept {path} (made earlier, same settings)")
        else:
            typer.echo(f"wrote {path}")
    if preview is not None:
        from resus.sweep.io import SweepReader
        from resus.sweep.preview import save_contact_sheet

        with SweepReader(outputs[0]) as sweep:
            save_contact_sheet(sweep, preview)
        typer.echo(f"wrote {preview}")


def _igtl_server(port: int, host: str):
    """An OpenIGTLink server for the simulated probe's frames (its default geometry, the one
    `simulate_sweep` images with)."""
    from resus.acquisition.backends.simulated import SimulatedProbeConfig
    from resus.sweep.igtl import IMAGE_NAME, TRANSFORM_NAME, IgtlServer, check_port

    check_port(port, "--igtl", allow_zero=True)
    server = IgtlServer(SimulatedProbeConfig().probe.image_to_probe(), port, host)
    typer.echo(
        f"streaming OpenIGTLink on {server.address}: IMAGE {IMAGE_NAME}, TRANSFORM "
        f"{TRANSFORM_NAME} (mm)"
    )
    return server


def _simulate_many(
    base: dict, subjects: list[int], folder: Path, executor: Executor
) -> tuple[list[Path], list[Path]]:
    """One sweep per subject into `folder`, each a unit on `executor` unless an earlier run
    made it with the same settings: every sweep's path, and those that were kept."""
    from resus.execution import run_pending

    folder.mkdir(parents=True, exist_ok=True)
    units = []
    for k in subjects:
        job = {**base, "subject": k, "out": folder / f"subject_{k:02d}.h5", "progress": False}
        units.append((job, _sweep_record(job, folder / DONE_FOLDER / f"subject_{k:02d}.json")))
    kept = [job["out"] for job, record in units if record.done()]
    run_pending(executor, _simulate_one, units, "subjects", "sweep")
    return [job["out"] for job, _ in units], kept


def _sweep_record(job: dict, path: Path) -> UnitRecord:
    """The record of one sweep of `--subjects`: everything the sweep depends on (scene,
    phantom, scanner and simulator as `world_key` knows them, a plan file's text with its
    path: a file edited in place makes a new sweep)."""
    from resus.acquisition.simulation import resolve_scene, world_key
    from resus.execution import UnitRecord

    plan = job["trajectory"]  # a LinearPattern or the path of a trajectory file
    scene = resolve_scene(job["scene"], job["phantom"], job["subject"])
    key = {
        **world_key(scene, sweep_scanner(job["scanner"], job["seed"], job["subject"])),
        "trajectory": (
            {"path": plan, "text": Path(plan).read_text()}
            if isinstance(plan, str)
            else dataclasses.asdict(plan)
        ),
        **{name: job[name] for name in ("seed", "rigid")},
    }
    return UnitRecord(path, key, (job["out"],))


def register(app: typer.Typer) -> None:
    """Add `resus simulate`."""
    app.command()(simulate)
