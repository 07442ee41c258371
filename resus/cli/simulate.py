"""`resus simulate`: scan a simulated phantom with the simulated UR3e, write Sweeps.

With `--subjects`, every subject's sweep is a unit on an executor (worker processes here, or
Ray), recorded when it finishes in `OUT/.done/` with the settings it was made with, so a
rerun of the same command makes only the sweeps that are missing.
"""

from __future__ import annotations

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
    open_igtl_stream,
)
from resus.cli.parsers import flag_error, parse_index_set, parse_numbers
from resus.cli.plan import make_pattern
from resus.errors import ResusError

if TYPE_CHECKING:
    from resus.acquisition.patterns import SweepPattern


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
    from sim.ultrasound.scanner import sweep_preset

    if trajectory == "linear":
        plan: SweepPattern | Path = make_pattern(
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
        plan = Path(trajectory)
    else:
        raise ResusError("--trajectory: neither 'linear' nor an existing file", trajectory)
    with flag_error("--scanner"):  # a bad preset fails here, before any work
        sweep_preset(scanner, seed, subject)
    check_executor_flags(executor, address)
    if igtl is not None and subjects is not None:
        raise ResusError("--igtl streams one sweep: not with --subjects")
    if subjects is None and executor != "local":
        raise ResusError(f"--executor {executor} runs the sweeps of --subjects: one runs here")
    from resus.acquisition.simulation import SimulatedSweepJob, simulate_subject_sweeps

    job = SimulatedSweepJob(
        out, plan, scene, phantom, subject, seed=seed, scanner=scanner, rigid=rigid
    )
    kept: list[Path] = []
    if subjects is None:
        if not out.parent.is_dir():
            raise ResusError("output folder does not exist", out.parent)
        if igtl is None:
            job.run()
        else:
            with open_igtl_stream(job.image_to_probe(), igtl, igtl_host) as server:
                job.run(listeners=[server])
        outputs = [out]
    else:
        from resus.execution import make_executor

        numbers = parse_index_set(subjects, "--subjects")
        with make_executor(executor, jobs, address) as engine:
            outputs, kept = simulate_subject_sweeps(job, numbers, out, engine)
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


def register(app: typer.Typer) -> None:
    """Add `resus simulate`."""
    app.command()(simulate)
