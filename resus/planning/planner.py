"""Run every check on a trajectory in a scene and gather what the report shows."""

from __future__ import annotations

from dataclasses import dataclass, field

from resus.acquisition.safety import SafetyLimits
from resus.acquisition.trajectory import Trajectory
from resus.errors import ResusError
from resus.planning import imaging_checks, robot_checks
from resus.planning.checks import CheckResult
from resus.planning.coverage import Coverage, analyse_coverage, check_coverage
from resus.planning.force import ForceProfile, check_contact_force, simulate_force
from resus.planning.holes import HoleEstimate, check_holes, default_radius_voxels, estimate_holes
from resus.planning.robot_checks import RobotMotion, analyse_motion
from resus.planning.sampling import FrameSamples, PathSamples
from sim.phantom import ARTERY, VEIN, Phantom
from sim.robot.scene_config import SceneConfig
from sim.robot.ur3e import SimulatedUR3e
from sim.ultrasound.probe import LinearProbe


@dataclass(frozen=True)
class PlanSettings:
    """What the plan is checked against."""

    voxel_size: float = 0.5e-3
    """Intended reconstruction voxel size (m)."""
    targets: tuple[int, ...] = (ARTERY, VEIN)
    """Vessel classes the scan must show."""
    probe: LinearProbe = field(default_factory=LinearProbe)
    limits: SafetyLimits = field(default_factory=SafetyLimits)

    def __post_init__(self) -> None:
        if not self.voxel_size > 0:
            raise ResusError(f"PlanSettings.voxel_size must be positive, got {self.voxel_size}")


@dataclass(frozen=True)
class PlanAnalysis:
    """Every check's result and the data behind them."""

    trajectory: Trajectory
    scene: SceneConfig
    phantom: Phantom
    settings: PlanSettings
    path: PathSamples
    frames: FrameSamples
    motion: RobotMotion
    coverage: Coverage
    holes: HoleEstimate
    force: ForceProfile
    checks: list[CheckResult]

    @property
    def passed(self) -> bool:
        return all(check.passed for check in self.checks)

    def check(self, name: str) -> CheckResult:
        """The result of the check called `name`."""
        return next(check for check in self.checks if check.name == name)


def check_plan(
    trajectory: Trajectory,
    scene: SceneConfig,
    phantom: Phantom,
    settings: PlanSettings | None = None,
) -> PlanAnalysis:
    """Check `trajectory` on the scene's UR3e over `phantom` (the scene's, possibly a subject)."""
    settings = settings or PlanSettings()
    ur3e = SimulatedUR3e(scene)
    path = PathSamples.of(trajectory)
    frames = FrameSamples.of(trajectory)
    motion = analyse_motion(trajectory, path, ur3e)
    coverage = analyse_coverage(
        frames, phantom, scene.phantom_to_base, settings.probe, settings.targets
    )
    holes = estimate_holes(frames, settings.probe, settings.voxel_size, default_radius_voxels())
    force = simulate_force(trajectory, scene, settings.limits)
    probe, voxel = settings.probe, settings.voxel_size
    checks = [
        robot_checks.check_reach(trajectory, path, motion, ur3e),
        robot_checks.check_joint_limits(trajectory, path, motion),
        robot_checks.check_continuity(trajectory, path, motion),
        robot_checks.check_singularity(trajectory, path, motion, ur3e),
        robot_checks.check_joint_speeds(trajectory, path, motion),
        robot_checks.check_torques(trajectory, path, motion),
        robot_checks.check_collisions(trajectory, path, motion, ur3e),
        imaging_checks.check_safety(trajectory, path, settings.limits),
        check_contact_force(trajectory, force, settings.limits),
        imaging_checks.check_frame_spacing(trajectory, frames, probe, voxel),
        imaging_checks.check_progress(trajectory, frames, probe, voxel),
        check_coverage(trajectory, frames, coverage, probe, scene.phantom_to_base),
        check_holes(trajectory, frames, holes),
    ]
    return PlanAnalysis(
        trajectory, scene, phantom, settings, path, frames, motion, coverage, holes, force, checks
    )
