"""Plan checks: a good sweep passes every check; each kind of bad plan fails the right check
at the right place, judged against independent computations."""

import dataclasses

import numpy as np
import pytest

from resus.acquisition.patterns import fan_sweep, linear_sweep
from resus.acquisition.simulation import phantom_spec, resolve_scene
from resus.acquisition.trajectory import Trajectory
from resus.planning.planner import PlanSettings, check_plan
from resus.planning.robot_checks import MIN_MANIPULABILITY
from sim.phantom import Phantom
from sim.robot import kinematics
from sim.robot.scene_config import SceneConfig
from sim.robot.ur3e import SimulatedUR3e
from sim.transforms import make_pose


def scene_at(x: float, y: float) -> tuple[SceneConfig, Phantom]:
    scene = SceneConfig(phantom_to_base=make_pose(np.eye(3), [x, y, 0.06]))
    return scene, Phantom(phantom_spec(scene))


@pytest.fixture(scope="module")
def default_scene() -> tuple[SceneConfig, Phantom]:
    scene = resolve_scene("default", None, None)
    return scene, Phantom(phantom_spec(scene))


def failing(analysis) -> set[str]:
    return {check.name for check in analysis.checks if not check.passed}


def test_reachable_linear_sweep_passes_every_check(default_scene) -> None:
    scene, phantom = default_scene
    analysis = check_plan(linear_sweep(phantom, scene.phantom_to_base), scene, phantom)
    assert analysis.passed, [c.line() for c in analysis.checks if not c.passed]
    assert len(analysis.checks) == 13
    assert analysis.holes.fraction < 0.01


def test_path_beyond_reach_fails_reach_where_ik_stops() -> None:
    scene, phantom = scene_at(-0.50, -0.13)
    trajectory = linear_sweep(
        phantom, scene.phantom_to_base, start=(0.03, -0.02), direction=(-1, 0), length=0.07
    )
    analysis = check_plan(trajectory, scene, phantom)
    reach = analysis.check("reach")
    assert not reach.passed and "toward the robot base" in reach.advice
    # Independently: the analytic IK has no solution just after the reported time, and has one
    # just before it.
    to_flange = np.linalg.inv(SimulatedUR3e(scene).get_tcp())
    solutions = [
        kinematics.inverse_kinematics_all(trajectory.pose_at(t) @ to_flange)
        for t in (reach.place.time - 0.02, reach.place.time)
    ]
    assert solutions[0] and not solutions[1]


def test_path_near_the_base_axis_fails_singularity() -> None:
    scene, phantom = scene_at(-0.20, -0.05)
    trajectory = linear_sweep(
        phantom, scene.phantom_to_base, start=(0.0, 0.06), direction=(1, 0), length=0.045
    )
    analysis = check_plan(trajectory, scene, phantom)
    singular = analysis.check("singularity")
    assert not singular.passed and "shoulder singularity" in singular.summary
    assert "away from the robot base" in singular.advice
    # Independently: manipulability of the joint solution at the reported start is below the
    # limit, and the TCP is nearer the base axis there than at the start of the path.
    q = kinematics.inverse_kinematics(
        trajectory.pose_at(singular.place.time) @ np.linalg.inv(SimulatedUR3e(scene).get_tcp()),
        analysis.motion.joint_path.joints[0],
    )
    assert kinematics.manipulability(q) < MIN_MANIPULABILITY * 1.05
    radius = [np.hypot(*trajectory.pose_at(t)[:2, 3]) for t in (0.0, singular.place.time)]
    assert radius[1] < radius[0]


def test_fast_fan_fails_joint_speeds_with_a_slower_speed_advised(default_scene) -> None:
    scene, phantom = default_scene
    trajectory = fan_sweep(phantom, scene.phantom_to_base, fan_deg=60, speed=0.4, acceleration=20)
    analysis = check_plan(trajectory, scene, phantom)
    speeds = analysis.check("joint speeds")
    assert not speeds.passed
    ratio = np.abs(analysis.motion.speeds) / kinematics.JOINT_SPEED_LIMITS
    first_over = analysis.path.times[np.flatnonzero(np.nanmax(ratio, axis=1) > 1)[0]]
    assert speeds.place.time == pytest.approx(first_over)
    advised = float(speeds.advice.split("slow to ")[1].split(" mm/s")[0]) * 1e-3
    slower = check_plan(
        fan_sweep(phantom, scene.phantom_to_base, fan_deg=60, speed=advised, acceleration=20),
        scene,
        phantom,
    )
    assert slower.check("joint speeds").passed


def test_frames_wider_than_the_voxel_fail_spacing_when_cruise_passes_the_limit(
    default_scene,
) -> None:
    scene, phantom = default_scene
    trajectory = linear_sweep(phantom, scene.phantom_to_base, speed=0.03)
    spacing = check_plan(trajectory, scene, phantom).check("frame spacing")
    assert not spacing.passed and "1.00 mm" in spacing.summary
    # Spacing passes 0.5 mm when speed passes 0.5 mm * 30 Hz = 15 mm/s, reached at 15/50 s.
    assert spacing.place.time == pytest.approx(0.015 / 0.05, abs=1 / 30)
    assert "slow to 14.2 mm/s" in spacing.advice
    coarse = check_plan(trajectory, scene, phantom, PlanSettings(voxel_size=1.2e-3))
    assert coarse.check("frame spacing").passed


def test_sweep_beside_the_vessels_fails_coverage_and_the_advice_fixes_it(default_scene) -> None:
    scene, phantom = default_scene
    missed = linear_sweep(phantom, scene.phantom_to_base, start=(0.045, -0.04))
    coverage = check_plan(missed, scene, phantom).check("coverage")
    assert not coverage.passed and "artery at 0%" in coverage.summary
    assert coverage.place.time == 0.0 and coverage.place.until == pytest.approx(
        missed.duration, abs=0.04
    )
    advised = coverage.advice.split("(start ")[1].rstrip(")").split(",")
    moved = linear_sweep(phantom, scene.phantom_to_base, start=tuple(float(v) for v in advised))
    assert check_plan(moved, scene, phantom).check("coverage").passed


def test_zig_zag_within_a_sweep_fails_progress_at_the_reversal(default_scene) -> None:
    scene, phantom = default_scene
    base = linear_sweep(phantom, scene.phantom_to_base, length=0.04)
    there = base.waypoints
    back = there[::-1][1:5]  # 20 mm back along the same line, in one imaging segment
    zig = Trajectory(waypoints=np.concatenate([there, back]), speed=0.01)
    progress = check_plan(zig, scene, phantom).check("progress")
    assert not progress.passed and "backwards" in progress.summary
    times = np.linspace(0, zig.duration, 20001)
    turn = times[np.searchsorted(zig.arc_length_at(times), 0.04)]
    assert progress.place.time == pytest.approx(turn, abs=1 / 30 + 1e-6)


def test_the_force_check_runs_the_plan_and_fails_a_fan_pressed_too_hard(default_scene) -> None:
    """The force check scans the plan on the simulated UR3e (the emulator's servo and force
    controller, a stream that stalls like a busy host's): pressing 18 N, a linear sweep peaks
    under the 20 N limit, but a fan, whose probe rocks about its face, is stopped at the limit
    during its rocking. A check of the set force alone passed both."""
    scene, phantom = default_scene
    linear = check_plan(
        linear_sweep(phantom, scene.phantom_to_base, length=0.02, contact_force=18.0),
        scene,
        phantom,
    )
    assert linear.check("contact force").passed, linear.check("contact force").line()
    assert 18.0 < linear.force.forces.max() < 20.0
    fan = fan_sweep(phantom, scene.phantom_to_base, contact_force=18.0)
    analysis = check_plan(fan, scene, phantom)
    assert failing(analysis) == {"contact force"}
    force = analysis.check("contact force")
    assert "the simulated scan stopped: contact force" in force.summary
    assert "exceeds the limit 20.0 N" in force.summary and "rock more slowly" in force.advice
    assert analysis.force.forces.max() > 20.0
    assert 0.0 < force.place.time < fan.duration  # while rocking, not pressing on


def sunk(trajectory: Trajectory, depth: float) -> Trajectory:
    """`trajectory` lowered by `depth` into the phantom, in position control."""
    waypoints = trajectory.waypoints.copy()
    waypoints[:, 2, 3] -= depth
    return dataclasses.replace(trajectory, waypoints=waypoints, contact_force=None)


def test_a_probe_sunk_into_the_phantom_collides_once_its_housing_reaches_it(default_scene):
    """The probe's face may touch the phantom (it images through it), its housing may not.
    The housing starts 44.5 mm above the lens (the TCP): sunk 30 mm into the 60 mm block the
    housing stays above the phantom's top, and only the force the simulated scan reads stops
    the plan; sunk 50 mm it is 5.5 mm inside, and the collision check names the two."""
    scene, phantom = default_scene
    path = linear_sweep(phantom, scene.phantom_to_base, length=0.02)
    shallow = check_plan(sunk(path, 0.03), scene, phantom)
    assert shallow.check("collisions").passed
    force = shallow.check("contact force")
    assert force.summary.startswith(
        "position control; the simulated scan stopped: protective stop: TCP force"
    )  # once: the simulated robot's fault no longer says "protective stop" twice
    deep = check_plan(sunk(path, 0.05), scene, phantom)
    collisions = deep.check("collisions")
    assert not collisions.passed and collisions.summary == "probe geom and phantom collide"
    assert collisions.place.time == 0.0 and "clears the table and phantom" in collisions.advice


@pytest.mark.parametrize(("force", "advised"), [(25.0, 20), (0.5, 1)])
def test_a_contact_force_outside_its_bounds_fails_before_any_scan(default_scene, force, advised):
    scene, phantom = default_scene
    plan = linear_sweep(phantom, scene.phantom_to_base, length=0.02, contact_force=force)
    check = check_plan(plan, scene, phantom).check("contact force")
    assert not check.passed
    assert check.summary == f"{force:.1f} N set (bounds 1-20 N)"
    assert check.advice == f"set the contact force to {advised} N" and check.place.time == 0.0
