"""`resus scan`: run a planned trajectory on a robot with a probe and record a Sweep live.

The robot is the in-process MuJoCo UR3e (`--robot sim`) or a UR controller over ur_rtde
(`--robot HOST`: a real UR3e, or `resus emulate`); the probe is the synthetic ultrasound at the
robot's reported pose (`--probe sim`), the scanner's video through a frame grabber
(`--probe video:0`, `video:URL`, `video:FILE`) or the IMAGE stream of an OpenIGTLink server
such as PLUS (`--probe igtl://HOST:PORT`). Before anything moves the plan is printed and
checked against the safety limits, and the user confirms (or passes `--yes`). The Sweep is
written frame by frame; with `--rerun`/`--rerun-save` every frame, the robot, the force and a
growing reconstruction go to rerun live, and with `--igtl PORT` every frame goes out over
OpenIGTLink as PLUS sends it (3D Slicer). A fault, a limit, a lost image stream or Ctrl-C
stops the robot, keeps the frames recorded so far and ends with one line on stderr and a
non-zero status.
"""

from __future__ import annotations

import contextlib
import sys
from pathlib import Path
from typing import TYPE_CHECKING, Annotated

import numpy as np
import typer

from resus.cli.options import (
    GrpcPortOption,
    IgtlHostOption,
    IgtlPortOption,
    PhantomOption,
    RerunOption,
    RerunSaveOption,
    SceneOption,
    SubjectOption,
    SweepOutOption,
    WebPortOption,
    open_igtl_stream,
    recorded_subject_option,
)
from resus.cli.parsers import flag_error, parse_numbers, settings_from_flags
from resus.errors import ResusError

if TYPE_CHECKING:
    from resus.acquisition.factory import (
        IgtlProbeConfig,
        RTDERobotConfig,
        SimulatedProbeConfig,
        SimulatedRobotConfig,
        VideoProbeConfig,
    )
    from sim.robot.scene_config import SceneConfig

DEFAULT_WORKSPACE = "-0.45,-0.45,-0.05,0.45,0.45,0.45"


PROBE_FORMS = "sim, sim:COLSxROWS or video:DEVICE|URL|FILE, or igtl://HOST:PORT"


def parse_igtl_address(text: str) -> tuple[str, int]:
    """'igtl://HOST:PORT' -> (HOST, PORT)."""
    from resus.sweep.igtl import check_port

    host, _, port = text.removeprefix("igtl://").rpartition(":")
    if not text.startswith("igtl://") or not host or not port.isdecimal():
        raise ResusError(
            f"--probe: expected igtl://HOST:PORT (e.g. igtl://127.0.0.1:18944), got {text!r}"
        )
    return host, check_port(int(port), "--probe igtl port")


def parse_probe(
    text: str, frame_rate: float, calibration: Path | None, crop: str | None
) -> SimulatedProbeConfig | VideoProbeConfig | IgtlProbeConfig:
    """The probe config for `--probe`: 'sim', 'sim:COLSxROWS', 'video:DEVICE|URL|FILE'
    (device index, stream URL or video file), with `--calibration` and `--crop` for video, or
    'igtl://HOST:PORT' (an OpenIGTLink server), with an optional `--calibration`."""
    from resus.acquisition.factory import IgtlProbeConfig, SimulatedProbeConfig, VideoProbeConfig
    from sim.ultrasound.probe import LinearProbe

    kind, _, argument = text.partition(":")
    if kind == "igtl":
        if crop is not None:
            raise ResusError("--crop applies to --probe video only")
        host, port = parse_igtl_address(text)
        return IgtlProbeConfig(host=host, port=port, calibration=calibration)
    if kind == "sim":
        if calibration is not None or crop is not None:
            raise ResusError(
                "--calibration and --crop apply to --probe video only (--calibration to igtl too)"
            )
        if not argument:
            return SimulatedProbeConfig(frame_rate=frame_rate)
        try:
            cols, rows = (int(v) for v in argument.lower().split("x"))
        except ValueError:
            cols = rows = 0
        if cols < 2 or rows < 2:
            raise ResusError(
                f"--probe: expected sim or sim:COLSxROWS (e.g. sim:128x128), got {text!r}"
            )
        return SimulatedProbeConfig(probe=LinearProbe(cols=cols, rows=rows), frame_rate=frame_rate)
    if kind == "video" and argument:
        if calibration is None:
            raise ResusError("--probe video needs --calibration probe.yaml (crop and pixel size)")
        source = int(argument) if argument.isdigit() else argument
        box = None if crop is None else parse_numbers(crop, "--crop", count=4, kind=int)
        with flag_error("--crop"):
            return VideoProbeConfig(source, calibration, crop=box)  # type: ignore[arg-type]
    raise ResusError(f"--probe: expected {PROBE_FORMS}, got {text!r}")


def parse_robot(text: str, scene_config: SceneConfig) -> SimulatedRobotConfig | RTDERobotConfig:
    """The robot config for `--robot`: 'sim' (in-process MuJoCo UR3e) or a controller address."""
    from resus.acquisition.factory import RTDERobotConfig, SimulatedRobotConfig

    return SimulatedRobotConfig(scene_config) if text == "sim" else RTDERobotConfig(host=text)


def describe_plan(trajectory, source: Path, limits, robot_pose: np.ndarray, probe_text: str) -> str:
    """What is about to happen, for the user to confirm."""
    start = trajectory.pose_at(0.0)
    approach = trajectory.approach_pose(start)
    distance = float(np.linalg.norm(approach[:3, 3] - robot_pose[:3, 3]))
    forces = trajectory.force_range
    control = "position control"
    if forces is not None:
        low, high = forces
        control = f"force mode at {low:.1f} N"
        if high > low:
            control = f"force mode at {low:.1f}-{high:.1f} N (profile)"
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


def scan(
    robot: Annotated[
        str, typer.Option(help="'sim' (in-process MuJoCo UR3e) or the UR controller's address.")
    ],
    probe: Annotated[
        str,
        typer.Option(
            help="'sim', 'sim:COLSxROWS', video:DEVICE|URL|FILE (frame grabber) or "
            "igtl://HOST:PORT (OpenIGTLink, e.g. PLUS)."
        ),
    ],
    trajectory: Annotated[Path, typer.Option(help="Trajectory YAML (resus plan).")],
    out: SweepOutOption,
    scene: SceneOption = "default",
    phantom: PhantomOption = None,
    subject: SubjectOption = None,
    subject_name: Annotated[
        str | None, recorded_subject_option("--subject-name", "the phantom's")
    ] = None,
    calibration: Annotated[
        Path | None,
        typer.Option(help="Probe calibration YAML (resus.probe/1) for --probe video or igtl."),
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
    rerun: RerunOption = None,
    rerun_save: RerunSaveOption = None,
    volume_every: Annotated[
        int, typer.Option(min=1, help="Log the live reconstruction every N frames.")
    ] = 30,
    volume_voxel: Annotated[
        float, typer.Option(help="Voxel size of the live reconstruction (m).")
    ] = 1e-3,
    grpc_port: GrpcPortOption = 9876,
    web_port: WebPortOption = 9090,
    igtl: IgtlPortOption = None,
    igtl_host: IgtlHostOption = "127.0.0.1",
) -> None:
    """Scan along a planned trajectory and record a Sweep, watching it live in rerun."""
    from resus.acquisition.factory import SimulatedProbeConfig, make_probe, make_robot
    from resus.acquisition.robot import RobotFault, host_clock_offset
    from resus.acquisition.safety import SafetyLimits
    from resus.acquisition.scanner import Scanner, ScannerSettings
    from resus.acquisition.simulation import resolve_scene, subject_id
    from resus.acquisition.trajectory import Trajectory

    if not out.parent.is_dir():
        raise ResusError("output folder does not exist", out.parent)
    if probe.partition(":")[0] in ("video", "igtl") and robot == "sim":
        kind = probe.partition(":")[0]
        raise ResusError(f"--probe {kind} needs a real robot clock: use --robot HOST")
    if igtl is not None:
        from resus.sweep.igtl import check_port

        check_port(igtl, "--igtl", allow_zero=True)
    if not volume_voxel > 0:
        raise ResusError(f"--volume-voxel must be positive, got {volume_voxel}")
    bounds = parse_numbers(workspace, "--workspace", count=6)
    limits = settings_from_flags(
        SafetyLimits,
        workspace_min=("--workspace", bounds[:3]),
        workspace_max=("--workspace", bounds[3:]),
        max_speed=("--max-speed", max_speed),
        max_force=("--max-force", max_force),
    )
    if not 0 < approach_speed <= max_speed:
        raise ResusError(f"--approach-speed must be in (0, --max-speed], got {approach_speed}")
    plan = Trajectory.from_yaml(trajectory)
    scene_config = resolve_scene(scene, phantom, subject)
    probe_config = parse_probe(probe, plan.frame_rate, calibration, crop)
    simulated = isinstance(probe_config, SimulatedProbeConfig)
    progress = sys.stderr.isatty()  # lines and a bar for a person, none in a log
    try:
        with contextlib.ExitStack() as viewer, contextlib.ExitStack() as devices:
            if progress and robot != "sim":
                print(f"connecting to the UR controller at {robot}", file=sys.stderr)
            robot_device = devices.enter_context(make_robot(parse_robot(robot, scene_config)))
            if progress:  # the synthetic probe's renderer loads its kernels for seconds
                print(f"starting the probe ({probe})", file=sys.stderr)
            probe_device = make_probe(probe_config, robot_device, scene_config)
            devices.callback(probe_device.close)
            offset = time_offset
            if not simulated:
                offset += host_clock_offset(robot_device)
            typer.echo(describe_plan(plan, trajectory, limits, robot_device.tcp_pose(), probe))
            settings = ScannerSettings(
                time_offset=offset, approach_speed=approach_speed, progress=progress
            )
            Scanner(robot_device, probe_device, limits, settings).check_plan(plan)
            confirm_motion(yes)
            session, listeners = None, []
            live_volume = None
            if rerun is not None or rerun_save is not None:
                session, (logger, live_volume) = _live_listeners(
                    viewer, plan, probe_device, scene_config if simulated else None,
                    rerun, rerun_save, volume_every, volume_voxel, grpc_port, web_port,
                )  # fmt: skip
                listeners += [logger, live_volume]
            if igtl is not None:
                stream = open_igtl_stream(probe_device.image_to_probe, igtl, igtl_host)
                listeners.append(viewer.enter_context(stream))
            scanner = Scanner(robot_device, probe_device, limits, settings, listeners)
            name = subject_name
            if name is None:
                name = subject_id(scene_config) if simulated else ""
            result = scanner.run(plan, out, source="sim" if simulated else "real", subject=name)
            devices.close()  # stop the control script and disconnect before lingering
            typer.echo(f"wrote {result.path}: {result.frames} frames over {result.duration:.2f} s")
            if live_volume is not None:
                live_volume.log()
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
    from resus.visualize import SweepLogger, make_blueprint, open_recording
    from sim.labels import LABEL_NAMES

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
    n_classes = len(LABEL_NAMES) if probe_device.has_labels else 0
    volume = LiveVolume(
        session.stream, grid, probe_device.image_to_probe, n_classes=n_classes, every=volume_every
    )
    stack.callback(volume.log)  # the final volume, also after an aborted scan
    return session, (SweepLogger(session.stream, probe_device.image_to_probe), volume)


def register(app: typer.Typer) -> None:
    """Add `resus scan`."""
    app.command()(scan)
