"""The scanner: run a trajectory on a robot and a probe, stream a tracked Sweep to disk.

Frames and poses come from different clocks. The robot's pose is sampled every control
period into a history; each frame's timestamp plus `time_offset` is a time on the robot's
clock, and the frame is paired with the pose interpolated there (linear in position, slerp
in rotation), as PLUS does with tracker and video streams. A frame is written as soon as the
history covers its time, so a frame that arrives late is still placed where it was taken.

A trajectory with a force profile (a compression scan's presses) changes the force-mode
setpoint on the way: the same loop re-sends force mode whenever the profile has moved
`force_step` from the setpoint last sent, or settles at another value.

Safety is checked here, for every backend: the whole plan before moving, every streamed
target, every wrench reading and the robot's own fault state. Any violation, fault or Ctrl-C
stops the robot, closes the Sweep with every frame recorded so far, and raises ScanAborted.
"""

from __future__ import annotations

import bisect
import sys
from collections.abc import Mapping, Sequence
from dataclasses import dataclass
from pathlib import Path

import numpy as np
from tqdm import tqdm

from resus.acquisition.probe import Frame, Probe
from resus.acquisition.robot import Robot, RobotFault
from resus.acquisition.safety import SafetyLimits, SafetyViolation
from resus.acquisition.trajectory import Trajectory
from resus.errors import ResusError
from resus.sweep.io import SweepWriter
from resus.sweep.model import FrameSink, SweepFrame
from sim.transforms import interpolate_poses


@dataclass(frozen=True)
class ScannerSettings:
    """How the scanner runs a trajectory."""

    time_offset: float = 0.0
    """Seconds added to a frame's probe timestamp to put it on the robot clock."""
    approach_speed: float = 0.05
    """TCP speed of the moves to and from the path (m/s)."""
    approach_acceleration: float = 0.5
    """TCP acceleration of those moves (m/s^2)."""
    settle_time: float = 10.0
    """Longest wait for the contact force to build up before the sweep (s). The press starts
    at the approach height and force mode crosses the air at the force over its damping: the
    simulated UR3e (400 N s/m) pressing 1.2 N on the femoral phantom spent 3.3 s in the air
    and settled 2.4 s after touching, so the 5 s allowed until 2026-12-04 aborted light
    presses (1 N on the default scene). A press that settles takes only as long as it needs."""
    settle_tolerance: float = 0.05
    """Relative force error within which contact counts as established..."""
    settle_hold: float = 0.2
    """...once it has stayed within it this long (s)."""
    max_frame_latency: float = 0.5
    """How long after the path ends the scanner waits for late frames (s)."""
    force_step: float = 0.1
    """Change of a force profile (N) after which force mode is re-sent with the new setpoint:
    each re-send costs the RTDE backend two control periods of the stream, so not every one."""
    progress: bool = True
    """Say on stderr what the robot is doing (approach, contact, lift-off) and show a progress
    bar over the sweep."""

    def __post_init__(self) -> None:
        if not (np.isfinite(self.force_step) and self.force_step > 0):
            raise ResusError(f"ScannerSettings.force_step must be positive, got {self.force_step}")


@dataclass(frozen=True)
class ScanResult:
    """What a scan produced."""

    path: Path
    frames: int
    duration: float
    """Robot-clock seconds from the first to the last recorded frame."""


class ScanAborted(ResusError):
    """The scan stopped early; the Sweep at `result.path` keeps every frame recorded."""

    def __init__(self, reason: str, result: ScanResult) -> None:
        self.reason = reason
        self.result = result
        super().__init__(
            f"scan stopped: {reason}; the robot was stopped and {result.path} keeps "
            f"the {result.frames} frames recorded before it"
        )

    def __reduce__(self) -> tuple[type[ScanAborted], tuple[str, ScanResult]]:
        """Rebuilt from its reason and result when unpickled: a scan in a worker process
        hands its abort back this way, and the default (the message alone) would fail there
        and break the worker pool, hiding the reason."""
        return type(self), (self.reason, self.result)


class _PoseHistory:
    """Robot-clock samples of TCP pose, wrench and joints, interpolated at any covered time."""

    def __init__(self) -> None:
        self.times: list[float] = []
        self.poses: list[np.ndarray] = []
        self.wrenches: list[np.ndarray] = []
        self.joints: list[np.ndarray] = []

    def record(self, robot: Robot) -> None:
        time = robot.time()
        if self.times and time <= self.times[-1]:
            return
        self.times.append(time)
        self.poses.append(robot.tcp_pose())
        self.wrenches.append(robot.tcp_wrench())
        self.joints.append(robot.joint_positions())

    @property
    def latest(self) -> float:
        return self.times[-1] if self.times else -np.inf

    def at(self, time: float) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
        """Pose, wrench and joints at `time` from the two samples around it."""
        upper = min(max(bisect.bisect_left(self.times, time), 1), len(self.times) - 1)
        lower = upper - 1
        if lower < 0:  # a single sample
            return self.poses[0], self.wrenches[0], self.joints[0]
        t0, t1 = self.times[lower], self.times[upper]
        pose = interpolate_poses(
            np.array([t0, t1]), np.stack([self.poses[lower], self.poses[upper]]), np.array([time])
        )[0]
        weight = float(np.clip((time - t0) / (t1 - t0), 0.0, 1.0))
        wrench = (1 - weight) * self.wrenches[lower] + weight * self.wrenches[upper]
        joints = (1 - weight) * self.joints[lower] + weight * self.joints[upper]
        return pose, wrench, joints


class Scanner:
    """Runs trajectories on one robot and one probe under one set of safety limits."""

    def __init__(
        self,
        robot: Robot,
        probe: Probe,
        limits: SafetyLimits | None = None,
        settings: ScannerSettings | None = None,
        listeners: Sequence[FrameSink] = (),
    ) -> None:
        """`listeners` receive every recorded frame too (e.g. a live rerun SweepLogger)."""
        self.robot = robot
        self.probe = probe
        self.limits = limits or SafetyLimits()
        self.settings = settings or ScannerSettings()
        self.listeners = tuple(listeners)

    def check_plan(self, trajectory: Trajectory) -> None:
        """Refuse, before anything moves, a plan that breaks a safety limit."""
        samples = trajectory.poses_at(np.linspace(0.0, trajectory.duration, 200))
        approach = [trajectory.approach_pose(samples[0]), trajectory.approach_pose(samples[-1])]
        forces = trajectory.force_range
        reasons = self.limits.plan_violations(
            np.concatenate([np.stack(approach), samples]),
            trajectory.speed,
            None if forces is None else forces[1],
        )
        if reasons:
            raise SafetyViolation(f"unsafe plan '{trajectory.name}': " + "; ".join(reasons))

    def run(
        self,
        trajectory: Trajectory,
        out_path: str | Path,
        *,
        source: str,
        subject: str = "",
        provenance: Mapping[str, object] | None = None,
    ) -> ScanResult:
        """Scan along `trajectory`, writing the Sweep (with `provenance`, see `Sweep`) to
        `out_path` as frames arrive."""
        self.check_plan(trajectory)
        out_path = Path(out_path)
        rows, cols = self.probe.shape
        writer = SweepWriter(
            out_path,
            (rows, cols),
            self.probe.image_to_probe,
            with_labels=self.probe.has_labels,
            with_wrench=True,
            with_joints=True,
            source=source,
            subject=subject,
            provenance=provenance,
        )
        recorded = _Recording((writer, *self.listeners))
        with writer:
            try:
                self._approach(trajectory)
                self._sweep(trajectory, recorded)
                self._leave(trajectory)
            except (SafetyViolation, RobotFault, KeyboardInterrupt) as error:
                self._halt()
                reason = "interrupted" if isinstance(error, KeyboardInterrupt) else str(error)
                raise ScanAborted(reason, recorded.result(out_path)) from None
        return recorded.result(out_path)

    def _approach(self, trajectory: Trajectory) -> None:
        """Move above the start, then descend into contact (force mode) or onto the path."""
        start = trajectory.pose_at(0.0)
        settings = self.settings
        self._say(
            f"moving to {trajectory.approach_height * 1e3:.0f} mm above the start at "
            f"{settings.approach_speed * 1e3:.0f} mm/s"
        )
        self.robot.move_linear(
            trajectory.approach_pose(start), settings.approach_speed, settings.approach_acceleration
        )
        if trajectory.contact_force is None:
            self._say("moving onto the path (position control)")
            self.robot.move_linear(start, settings.approach_speed, settings.approach_acceleration)
            return
        self._say(f"pressing the probe on in force mode until {trajectory.contact_force:g} N hold")
        self.robot.force_mode(trajectory.contact_force)
        deadline = self.robot.time() + settings.settle_time
        settled_since = None
        while self.robot.time() < deadline:
            self.robot.servo_linear(start)
            self.robot.wait_period()
            self._check_state()
            now = self.robot.time()
            force = self.robot.probe_force()
            error = abs(force - trajectory.contact_force) / trajectory.contact_force
            if error >= settings.settle_tolerance:
                settled_since = None
            elif settled_since is None:
                settled_since = now
            elif now - settled_since >= settings.settle_hold:
                return
        raise SafetyViolation(
            f"no stable contact: force {force:.2f} N after {settings.settle_time} s, "
            f"wanted {trajectory.contact_force} N"
        )

    def _sweep(self, trajectory: Trajectory, recorded: _Recording) -> None:
        """Stream the path at the control rate and record every frame taken along it.

        The path is sampled once at the control period (target k is the plan at k periods),
        and so is a force profile. Each pass sends the target for the robot's elapsed time
        (and the force setpoint, when due), so a loop that falls behind real time skips
        targets rather than stretching the sweep; after the last target the probe holds still
        until the frames still in flight have arrived.

        The progress bar counts the sweep's seconds on the robot clock, with the frames
        recorded beside them: a count of frames cannot have a total, since a probe may run
        at another rate than the plan's (a video grabber) or skip frames while it is busy
        (the synthetic probe's renderer beside a real-time robot).
        """
        robot, settings = self.robot, self.settings
        period = robot.control_period
        periods = int(np.ceil(trajectory.duration / period))
        targets = trajectory.poses_at(np.arange(periods + 1) * period)
        forces = trajectory.force_at(np.arange(periods + 1) * period)
        setpoint = trajectory.contact_force
        history = _PoseHistory()
        self.probe.poll()  # discard frames taken before the sweep
        history.record(robot)
        start_time = robot.time()
        end_time = start_time + trajectory.duration
        pending: list[Frame] = []
        with tqdm(
            total=round(trajectory.duration, 2),
            unit="s",
            desc="scanning",
            bar_format="{l_bar}{bar}| {n:.1f}/{total:.1f} s [{elapsed}<{remaining}{postfix}]",
            postfix="0 frames",
            disable=not settings.progress,
        ) as bar:
            sent, now, shown = 0, start_time, 0
            while True:
                index = min(periods, max(sent, round((now - start_time) / period)))
                elapsed = max(index - sent, 1) * period
                self.limits.check_target(targets[index], targets[sent], elapsed)
                if trajectory.force_profile is not None and _setpoint_due(
                    forces, index, setpoint, settings.force_step
                ):
                    setpoint = float(forces[index])
                    robot.force_mode(setpoint)
                robot.servo_linear(targets[index])
                sent = index
                robot.wait_period()
                history.record(robot)
                self._check_state()
                pending.extend(self.probe.poll())
                pending = self._write_covered(pending, history, recorded, start_time, end_time)
                now = robot.time()
                if settings.progress and recorded.frames != shown:
                    shown, wall = recorded.frames, bar.format_dict["elapsed"]
                    rate = f", {shown / wall:.1f} frames/s" if wall > 0 else ""
                    bar.set_postfix_str(f"{shown} frames{rate}", refresh=False)
                bar.update(min(now - start_time, bar.total) - bar.n)
                if now >= end_time and (not pending or now > end_time + settings.max_frame_latency):
                    break

    def _write_covered(
        self,
        pending: list[Frame],
        history: _PoseHistory,
        recorded: _Recording,
        start_time: float,
        end_time: float,
    ) -> list[Frame]:
        """Write the pending frames whose pose time the history covers; return the rest."""
        waiting = []
        for frame in pending:
            time = frame.timestamp + self.settings.time_offset
            if time > history.latest:
                waiting.append(frame)
            elif start_time <= time <= end_time:
                recorded.write(frame, time, *history.at(time))
        return waiting

    def _leave(self, trajectory: Trajectory) -> None:
        """End force mode and lift the probe off the tissue."""
        self._say("lifting the probe off")
        if trajectory.contact_force is not None:
            self.robot.force_mode_stop()
        self.robot.move_linear(
            trajectory.approach_pose(self.robot.tcp_pose()),
            self.settings.approach_speed,
            self.settings.approach_acceleration,
        )

    def _say(self, message: str) -> None:
        """One line on stderr about what the robot does next, when progress is shown: the
        moves before and after the sweep take seconds (tens on a real arm) without a bar."""
        if self.settings.progress:
            tqdm.write(message, file=sys.stderr)

    def _check_state(self) -> None:
        """Raise if the robot reports a fault or the contact force is over the limit. The
        wrench is read first, so a fault that arrives with it (a protective stop set off by
        the force) is the reason given."""
        wrench = self.robot.tcp_wrench()
        fault = self.robot.fault()
        if fault is not None:
            raise RobotFault(fault)
        self.limits.check_wrench(wrench)

    def _halt(self) -> None:
        """Stop the robot on an abort; a robot that is already gone cannot be stopped."""
        try:
            self.robot.force_mode_stop()
            self.robot.stop()
        except RobotFault:
            pass


def _setpoint_due(forces: np.ndarray, index: int, sent: float | None, step: float) -> bool:
    """Whether force mode is re-sent at target `index` of the sampled profile `forces`: it has
    moved `step` from the setpoint `sent`, or it settles (holds) at another value there."""
    force = float(forces[index])
    if sent is None or force == sent:
        return False
    settles = index + 1 >= len(forces) or forces[index + 1] == force
    return abs(force - sent) >= step or settles


class _Recording:
    """Hands each frame to the writer and listeners; counts them for progress and for an
    aborted scan's report."""

    def __init__(self, sinks: Sequence[FrameSink]) -> None:
        self.sinks = sinks
        self.frames = 0
        self.first_time: float | None = None
        self.last_time = 0.0

    def write(
        self, frame: Frame, time: float, pose: np.ndarray, wrench: np.ndarray, joints: np.ndarray
    ) -> None:
        if self.frames and time <= self.last_time:
            return  # two frames on one robot-clock instant: keep the first
        recorded = SweepFrame(self.frames, frame.image, pose, time, frame.label, wrench, joints)
        for sink in self.sinks:
            sink.append(recorded)
        self.frames += 1
        self.first_time = time if self.first_time is None else self.first_time
        self.last_time = time

    def result(self, path: Path) -> ScanResult:
        duration = 0.0 if self.first_time is None else self.last_time - self.first_time
        return ScanResult(path=path, frames=self.frames, duration=duration)
