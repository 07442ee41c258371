"""`resus scan`: run a planned trajectory on a robot with a probe and record a Sweep live.

The robot is the in-process MuJoCo UR3e (`--robot sim`) or a UR controller over ur_rtde
(`--robot HOST`: a real UR3e, or `resus emulate`); the probe is the synthetic ultrasound at the
robot's reported pose (`--probe sim`) or the scanner's video through a frame grabber
(`--probe video:0`, `video:URL`, `video:FILE`). Before anything moves the plan is printed and
checked against the safety limits, and the user confirms (or passes `--yes`). The Sweep is
written frame by frame; with `--rerun`/`--rerun-save` every frame, the robot, the force and a
growing reconstruction go to rerun live. A fault, a limit or Ctrl-C stops the robot, keeps
the frames recorded so far and ends with one line on stderr and a non-zero status.
"""

from __future__ import annotations

import contextlib
import sys
import time
from pathlib import Path
from typing import Annotated

import numpy as np
import typer

from resus.errors import ResusError

DEFAULT_WORKSPACE = "-0.45,-0.45,-0.05,0.45,0.45,0.45"


def parse_numbers(text: str, count: int, option: str) -> tuple[float, ...]:
    """'a,b,...' -> `count` floats."""
    try:
        values = tuple(float(v) for v in text.split(","))
    except ValueError:
        values = ()
    if len(values) != count or not all(np.isfinite(values)):
        raise ResusError(f"{option}: expected {count} comma-separated numbers, got {text!r}")
    return values


def parse_probe(text: str) -> tuple[str, object]:
    """'sim' / 'sim:COLSxROWS' -> ("sim", (cols, rows) | None); 'video:SOURCE' -> ("video",
    int device index or str URL/path)."""
    kind, _, argument = text.partition(":")
    if kind == "sim":
        if not argument:
            return "sim", None
        try:
            cols, rows = (int(v) for v in argument.lower().split("x"))
        except ValueError:
            cols = rows = 0
        if cols < 2 or rows < 2:
            raise ResusError(
                f"--probe: expected sim or sim:COLSxROWS (e.g. sim:128x128), got {text!r}"
            )
        return "sim", (cols, rows)
    if kind == "video" and argument:
        return "video", int(argument) if argument.isdigit() else argument
    raise ResusError(f"--probe: expected sim, sim:COLSxROWS or video:DEVICE|URL|FILE, got {text!r}")


def describe_plan(trajectory, source: Path, limits, robot_pose: np.ndarray, probe_text: str) -> str:
    """What is about to happen, for the user to confirm."""
    start = trajectory.pose_at(0.0)
    approach = trajectory.approach_pose(start)
    distance = float(np.linalg.norm(approach[:3, 3] - robot_pose[:3, 3]))
    force = trajectory.contact_force
    control = "position control" if force is None else f"force mode at {force:.1f} N"
    frames = int(trajectory.duration * trajectory.frame_rate)
    low, high = np.array(limits.workspace_min), np.array(limits.workspace_max)

    def xyz(vector: np.ndarray) -> str:
        return "(" + ", ".join(f"{v:+.3f}" for v in vector) + ")"

    return "\n".join(
        [
            f"plan '{trajectory.name}' from {source}: {len(trajectory.waypoints)} waypoints",
            f"  start pose    TCP {xyz(start[:3, 3])} m, probe axis {xyz(start[:3, 2])}",
            f"  robot now     TCP {xyz(robot_pose[:3, 3])} m, {distance:.3f} m from the approach",
            f"  path          {trajectory.path_length:.3f} m in {trajectory.duration:.2f} s at "
            f"{trajectory.speed:.3f} m/s, {control}",
            f"  frames        about {frames} at {trajectory.frame_rate:g} Hz from {probe_text}",
            f"  limits        workspace {xyz(low)} .. {xyz(high)} m, speed <= "
            f"{limits.max_speed:g} m/s, force <= {limits.max_force:g} N",
        ]
    )


def confirm_motion(assume_yes: bool) -> None:
    """Ask before moving; without a terminal to ask on, refuse unless --yes."""
    if assume_yes:
        return
    if sys.stdin is None or not sys.stdin.isatty():
        raise ResusError("refusing to move the robot without confirmation: no terminal; pass --yes")
    if not typer.confirm("Move the robot and scan?", default=False):
        raise ResusError("scan cancelled; the robot did not move")


def _open_robot(robot: str, scene_config):
    """The robot for `--robot`: the simulated UR3e, or RTDERobot on a controller address."""
    if robot == "sim":
        from resus.acquisition.backends.simulated import SimulatedRobot

        return SimulatedRobot(scene_config)
    from resus.acquisition.backends.rtde import RTDERobot, RTDERobotConfig

    return RTDERobot(RTDERobotConfig(host=robot))


def _open_probe(kind: str, argument: object, robot, scene_config, frame_rate: float, options):
    """The probe for `--probe`."""
    if kind == "sim":
        from resus.acquisition.backends.simulated import (
            SimulatedProbe,
            SimulatedProbeConfig,
            SimulatedRobot,
        )
        from resus.acquisition.simulation import phantom_spec
        from sim.phantom import Phantom
        from sim.ultrasound.probe import LinearProbe

        geometry = (
            LinearProbe() if argument is None else LinearProbe(cols=argument[0], rows=argument[1])
        )
        config = SimulatedProbeConfig(probe=geometry, frame_rate=frame_rate)
        phantom = Phantom(phantom_spec(scene_config))
        if isinstance(robot, SimulatedRobot):
            probe = SimulatedProbe(robot, config, phantom, scene_config)
            probe.poll()  # the first frame loads the renderer's compiled kernels: not mid-sweep
            return probe
        from resus.acquisition.backends.render_process import RenderProcessProbe

        return RenderProcessProbe(robot, config, phantom, scene_config)
    from resus.acquisition.backends.video import VideoProbe, VideoProbeConfig

    if options["calibration"] is None:
        raise ResusError("--probe video needs --calibration probe.yaml (crop and pixel size)")
    crop = None if options["crop"] is None else parse_numbers(options["crop"], 4, "--crop")
    return VideoProbe(VideoProbeConfig(argument, options["calibration"], crop=crop))


def robot_minus_probe_clock(robot) -> float:
    """Robot clock minus the host's monotonic clock, sampled back to back (s)."""
    before = time.monotonic()
    robot_time = robot.time()
    after = time.monotonic()
    return robot_time - 0.5 * (before + after)


def scan(
    robot: Annotated[
        str, typer.Option(help="'sim' (in-process MuJoCo UR3e) or the UR controller's address.")
    ],
    probe: Annotated[
        str, typer.Option(help="'sim', 'sim:COLSxROWS', or video:DEVICE|URL|FILE (frame grabber).")
    ],
    trajectory: Annotated[Path, typer.Option(help="Trajectory YAML (resus plan).")],
    out: Annotated[Path, typer.Option(help="Sweep file to write (.h5).")],
    scene: Annotated[
        str, typer.Option(help="Scene (assets/scenes name or YAML): the simulated phantom.")
    ] = "default",
    phantom: Annotated[str | None, typer.Option(help="Phantom spec name or YAML path.")] = None,
    subject: Annotated[int | None, typer.Option(help="Subject variant of the phantom.")] = None,
    subject_name: Annotated[
        str | None, typer.Option(help="Subject recorded in the Sweep (default: the phantom's).")
    ] = None,
    calibration: Annotated[
        Path | None, typer.Option(help="Probe calibration YAML (resus.probe/1) for --probe video.")
    ] = None,
    crop: Annotated[
        str | None, typer.Option(help="x,y,width,height of the image in the video (overrides).")
    ] = None,
    time_offset: Annotated[
        float, typer.Option(help="Seconds added to frame times (from resus calibrate-time).")
    ] = 0.0,
    yes: Annotated[bool, typer.Option("--yes", help="Move without asking for confirmation.")] = (
        False
    ),
    max_speed: Annotated[float, typer.Option(help="TCP speed limit (m/s).")] = 0.10,
    max_force: Annotated[float, typer.Option(help="Contact force limit (N).")] = 20.0,
    workspace: Annotated[
        str, typer.Option(help="TCP box xmin,ymin,zmin,xmax,ymax,zmax (m, robot base frame).")
    ] = DEFAULT_WORKSPACE,
    approach_speed: Annotated[
        float, typer.Option(help="TCP speed of the moves to and from the path (m/s).")
    ] = 0.05,
    rerun: Annotated[
        str | None,
        typer.Option("--rerun", help="Live viewer: 'serve' (web, 127.0.0.1) or 'spawn'."),
    ] = None,
    rerun_save: Annotated[
        Path | None, typer.Option("--rerun-save", help="Also save the recording to FILE.rrd.")
    ] = None,
    volume_every: Annotated[
        int, typer.Option(min=1, help="Log the live reconstruction every N frames.")
    ] = 30,
    volume_voxel: Annotated[
        float, typer.Option(help="Voxel size of the live reconstruction (m).")
    ] = 1e-3,
    grpc_port: Annotated[int, typer.Option(help="gRPC port of the live viewer.")] = 9876,
    web_port: Annotated[int, typer.Option(help="HTTP port of the served web viewer.")] = 9090,
) -> None:
    """Scan along a planned trajectory and record a Sweep, watching it live in rerun."""
    from resus.acquisition.robot import RobotFault
    from resus.acquisition.safety import SafetyLimits
    from resus.acquisition.scanner import Scanner, ScannerSettings
    from resus.acquisition.simulation import resolve_scene, subject_id
    from resus.acquisition.trajectory import Trajectory

    if not out.parent.is_dir():
        raise ResusError("output folder does not exist", out.parent)
    probe_kind, probe_argument = parse_probe(probe)
    if probe_kind == "video" and robot == "sim":
        raise ResusError("--probe video needs a real robot clock: use --robot HOST")
    if probe_kind == "sim" and (calibration is not None or crop is not None):
        raise ResusError("--calibration and --crop apply to --probe video only")
    if not volume_voxel > 0:
        raise ResusError(f"--volume-voxel must be positive, got {volume_voxel}")
    bounds = parse_numbers(workspace, 6, "--workspace")
    limits = SafetyLimits(bounds[:3], bounds[3:], max_speed, max_force)
    if not 0 < approach_speed <= max_speed:
        raise ResusError(f"--approach-speed must be in (0, --max-speed], got {approach_speed}")
    plan = Trajectory.from_yaml(trajectory)
    scene_config = resolve_scene(scene, phantom, subject)
    options = {"calibration": calibration, "crop": crop}
    try:
        with contextlib.ExitStack() as viewer, contextlib.ExitStack() as devices:
            robot_device = devices.enter_context(_open_robot(robot, scene_config))
            probe_device = _open_probe(
                probe_kind, probe_argument, robot_device, scene_config, plan.frame_rate, options
            )
            devices.callback(probe_device.close)
            offset = time_offset
            if probe_kind == "video":
                offset += robot_minus_probe_clock(robot_device)
            typer.echo(describe_plan(plan, trajectory, limits, robot_device.tcp_pose(), probe))
            settings = ScannerSettings(
                time_offset=offset, approach_speed=approach_speed, progress=sys.stderr.isatty()
            )
            Scanner(robot_device, probe_device, limits, settings).check_plan(plan)
            confirm_motion(yes)
            session, listeners = None, ()
            if rerun is not None or rerun_save is not None:
                session, listeners = _live_listeners(
                    viewer, plan, probe_device, scene_config if probe_kind == "sim" else None,
                    rerun, rerun_save, volume_every, volume_voxel, grpc_port, web_port,
                )  # fmt: skip
            scanner = Scanner(robot_device, probe_device, limits, settings, listeners)
            name = subject_name
            if name is None:
                name = subject_id(scene_config) if probe_kind == "sim" else ""
            result = scanner.run(
                plan, out, source="sim" if probe_kind == "sim" else "real", subject=name
            )
            devices.close()  # stop the control script and disconnect before lingering
            typer.echo(f"wrote {result.path}: {result.frames} frames over {result.duration:.2f} s")
            if listeners:
                listeners[1].log()
            if rerun_save is not None:
                typer.echo(f"saved {rerun_save}")
            if session is not None and session.viewer_url:
                typer.echo("serving; press Ctrl-C to stop")
                session.wait_until_interrupted()
    except RobotFault as fault:
        raise ResusError(f"robot {robot}: {fault}") from None


def _live_listeners(
    stack: contextlib.ExitStack,
    plan,
    probe_device,
    scene_config,
    rerun: str | None,
    rerun_save: Path | None,
    volume_every: int,
    volume_voxel: float,
    grpc_port: int,
    web_port: int,
) -> tuple:
    """Open the rerun recording; return it and the scanner listeners that log to it (frames
    and robot, then the live volume)."""
    from resus.reconstruction.live import LiveVolume, planned_grid
    from resus.sweep.model import DEFAULT_LABEL_NAMES
    from resus.visualize import SweepLogger, make_blueprint, open_recording

    middle = plan.pose_at(0.5 * plan.duration)[:3, 3]
    session = stack.enter_context(
        open_recording(
            "resus", save=rerun_save, live=rerun, blueprint=make_blueprint(look_at=middle),
            grpc_port=grpc_port, web_port=web_port,
        )
    )  # fmt: skip
    if session.viewer_url:
        typer.echo(f"rerun web viewer: {session.viewer_url}")
    if scene_config is not None:
        from resus.visualize.scene import log_phantom

        log_phantom(session.stream, scene_config, probe_device.phantom)
    grid = planned_grid(plan, probe_device.image_to_probe, probe_device.shape, volume_voxel)
    n_classes = len(DEFAULT_LABEL_NAMES) if probe_device.has_labels else 0
    volume = LiveVolume(
        session.stream, grid, probe_device.image_to_probe, n_classes=n_classes, every=volume_every
    )
    stack.callback(volume.log)  # the final volume, also after an aborted scan
    return session, (SweepLogger(session.stream, probe_device.image_to_probe), volume)


def register(app: typer.Typer) -> None:
    """Add `resus scan`."""
    app.command()(scan)
