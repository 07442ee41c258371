"""The contact force a plan will really see, predicted by running it.

A set force between the bounds says little about the force a scan reads: the force mode's
admittance loop lags the path, the descent overshoots into contact, and a probe rocked about
its face (a fan) swings the flange on the TCP's 135 mm lever. So the plan is run: the scanner
(the very code `resus scan` runs) drives the in-process MuJoCo UR3e, whose servo and force
controller are the RTDE emulator's (`sim.robot.motions.Servo`, `sim.robot.force_mode`), and
the wrench is read every control period the scanner streams: from the descent into contact to
the end of the sweep.

In process, the scanner and the physics step in lockstep; on the emulator or a real UR3e the
scanner's 500 Hz stream runs on a host that is not real-time, and stalls: it then sends the
target for the time it has reached, many periods ahead (measured on the project's 2-core host
while other work ran: stalls of 20-100 ms a few times per scan). The prediction stalls the
stream too, for `STALL` seconds at most once per `STALL_INTERVAL`, so a plan whose force holds
only for a perfect stream fails here, not on the robot.
"""

from __future__ import annotations

import tempfile
from dataclasses import dataclass
from pathlib import Path

import numpy as np

from resus.acquisition.backends.simulated import SimulatedRobot
from resus.acquisition.probe import Probe
from resus.acquisition.safety import SafetyLimits, SafetyViolation
from resus.acquisition.scanner import ScanAborted, Scanner, ScannerSettings
from resus.acquisition.trajectory import Trajectory
from resus.planning.checks import CheckResult, place_at
from resus.planning.sampling import PathSamples
from sim.robot import kinematics
from sim.robot.scene_config import SceneConfig
from sim.robot.ur3e import HOME_JOINTS
from sim.transforms import invert_pose

MIN_CONTACT_FORCE = 1.0
"""Least force (N) that keeps gel coupling under the probe."""
STALL = 0.25
"""How long each simulated stall of the scanner's stream lasts (s)."""
STALL_INTERVAL = 1.0
"""Time between the starts of simulated stalls (s)."""


@dataclass(frozen=True)
class ForceProfile:
    """The contact force read every control period of a simulated scan of a plan."""

    times: np.ndarray
    """(P,) robot-clock seconds of each period's reading."""
    forces: np.ndarray
    """(P,) magnitude of the contact force (N)."""
    poses: np.ndarray
    """(P, 4, 4) TCP pose at each reading."""
    aborted: str | None
    """Why the simulated scan stopped early (a safety limit, a protective stop), or None."""

    @property
    def peak(self) -> int:
        """Index of the largest force."""
        return int(np.argmax(self.forces))


class _StallingRobot(SimulatedRobot):
    """The simulated robot as the scanner sees a remote one on a busy host: at most once per
    STALL_INTERVAL a `wait_period` lasts STALL (the scanner's loop was not scheduled); the
    wrench of every period is kept. It starts at rest at `start` when that is reachable (the
    move there through free air does not touch anything)."""

    def __init__(self, scene: SceneConfig, start: np.ndarray) -> None:
        super().__init__(scene)
        joints = kinematics.inverse_kinematics(
            start @ invert_pose(self.ur3e.get_tcp()), HOME_JOINTS
        )
        if joints is not None:
            self.ur3e.reset(joints)
        self._next_stall = 0.0
        self.times: list[float] = []
        self.forces: list[float] = []
        self.poses: list[np.ndarray] = []

    def wait_period(self) -> None:
        periods = 1
        if self.time() >= self._next_stall:
            periods = round(STALL / self.control_period)
            self._next_stall = self.time() + STALL_INTERVAL
        for _ in range(periods):
            super().wait_period()
            self.times.append(self.time())
            self.forces.append(float(np.linalg.norm(self.tcp_wrench()[:3])))
            self.poses.append(self.tcp_pose())


class _NoImages(Probe):
    """A probe that takes no frames: the prediction needs the robot only."""

    image_to_probe = np.eye(4)
    shape = (1, 1)

    def poll(self) -> list:
        return []


def simulate_force(
    trajectory: Trajectory, scene: SceneConfig, limits: SafetyLimits
) -> ForceProfile:
    """Scan `trajectory` on the simulated UR3e in `scene` under `limits`, with a stalling
    stream, and return the force of every control period (see the module doc)."""
    robot = _StallingRobot(scene, trajectory.approach_pose(trajectory.pose_at(0.0)))
    scanner = Scanner(robot, _NoImages(), limits, ScannerSettings(progress=False))
    aborted = None
    with tempfile.TemporaryDirectory(prefix="resus-plan-force-") as folder:
        try:
            scanner.run(trajectory, Path(folder) / "force.h5", source="sim")
        except ScanAborted as error:
            aborted = error.reason
        except SafetyViolation as error:  # refused before moving: the safety limits check
            aborted = str(error)
    return ForceProfile(
        np.array(robot.times), np.array(robot.forces), np.array(robot.poses), aborted
    )


def check_contact_force(
    trajectory: Trajectory, profile: ForceProfile, limits: SafetyLimits
) -> CheckResult:
    """The set force (every value of a force profile) lies between MIN_CONTACT_FORCE and the
    limit, and the force the simulated scan reads (the profile's setpoints re-sent as the
    scanner does) stays under the limit all the way (position control: only that)."""
    forces = trajectory.force_range
    held = "position control"
    if forces is not None:
        low, high = forces
        held = f"{low:.1f} N set" if low == high else f"{low:.1f}-{high:.1f} N set (profile)"
        bad = low if low < MIN_CONTACT_FORCE else high
        if not MIN_CONTACT_FORCE <= low <= high <= limits.max_force:
            target = MIN_CONTACT_FORCE if bad < MIN_CONTACT_FORCE else limits.max_force
            return CheckResult(
                "contact force",
                False,
                f"{held} (bounds {MIN_CONTACT_FORCE:.0f}-{limits.max_force:.0f} N)",
                place_at(trajectory, _time_of_force(trajectory, bad)),
                f"set the contact force to {target:.0f} N",
            )
    advice = "slow down (a fan: rock more slowly), lower the contact force or the acceleration"
    if profile.aborted is not None:
        place = None  # where it stopped: at the last reading
        if len(profile.poses):
            place = place_at(trajectory, nearest_path_time(trajectory, profile.poses[-1]))
        if "force" not in profile.aborted:
            advice = "fix what stopped it first (see the other checks)"
        summary = f"{held}; the simulated scan stopped: {profile.aborted}"
        return CheckResult("contact force", False, summary, place, advice)
    peak = profile.peak
    summary = f"{held}, peak {profile.forces[peak]:.1f} N in a simulated scan"
    if profile.forces[peak] <= limits.max_force:
        return CheckResult("contact force", True, f"{summary} (limit {limits.max_force:.0f} N)")
    place = place_at(trajectory, nearest_path_time(trajectory, profile.poses[peak]))
    return CheckResult("contact force", False, summary, place, advice)


def _time_of_force(trajectory: Trajectory, force: float) -> float:
    """The first time (s) the set force is `force`: 0 without a profile."""
    if trajectory.force_profile is None:
        return 0.0
    return next(t for t, value in trajectory.force_profile if value == force)


def nearest_path_time(trajectory: Trajectory, pose: np.ndarray) -> float:
    """Path time (s) of the planned sample nearest `pose`: position offset plus rotation
    counted at the trajectory's rotation radius."""
    samples = PathSamples.of(trajectory)
    return float(samples.times[samples.nearest(pose[None], trajectory.rotation_radius)[0]])
