"""Checks of the arm along the path: reach, joint limits, IK branch flips, joint speeds and
torques, distance from singularities, and collisions.

Torques are MuJoCo inverse dynamics (`mj_inverse`) on the scene's own model with gravity
compensation, actuators and contacts switched off (so they are the full rigid-body torques:
inertia, Coriolis and gravity, payload included), plus `J^T F` for the contact force the probe
pushes with. Collisions are MuJoCo contacts at configurations every `COLLISION_STEP` of path
between any robot geom and the tables, floor or phantom (the probe face on the phantom is the
scan itself and is allowed), plus robot self-distances (`mj_geomDistance`) between
collision geoms of links that are not neighbours (the model's links do not collide with each
other in simulation).
"""

from __future__ import annotations

import copy
from collections.abc import Callable
from dataclasses import dataclass

import mujoco
import numpy as np

from resus.acquisition.trajectory import Trajectory
from resus.planning.checks import CheckResult, place_at
from resus.planning.joint_path import JointPath, branch_flips, solve_joint_path
from resus.planning.sampling import PathSamples
from sim.robot import kinematics
from sim.robot.ur3e import HOME_JOINTS, SimulatedUR3e
from sim.transforms import invert_pose

MIN_MANIPULABILITY = 0.004
"""Yoshikawa manipulability below which a configuration counts as near-singular (the UR3e
has about 0.015 over the default phantom and 0.001 with its wrist 5 mm off the base axis)."""
COLLISION_STEP = 0.002
"""Path length between configurations checked for collisions (m)."""
SHIFT_STEP = 0.005
"""Step of the search for a shift of the path that fixes reach or singularity (m)."""
MAX_SHIFT = 0.25
"""Largest shift of the path that the search tries (m)."""
SPEED_MARGIN = 0.9
"""Advice aims this fraction of a limit."""


@dataclass(frozen=True)
class RobotMotion:
    """The arm's motion along the path samples (NaN where IK failed)."""

    joint_path: JointPath
    speeds: np.ndarray
    """(T, 6) joint speeds (rad/s)."""
    torques: np.ndarray
    """(T, 6) joint torques (N m)."""
    manipulability: np.ndarray
    """(T,) Yoshikawa manipulability."""


def analyse_motion(
    trajectory: Trajectory, samples: PathSamples, ur3e: SimulatedUR3e
) -> RobotMotion:
    """Joints, speeds, torques and manipulability along `samples`."""
    approach = trajectory.approach_pose(samples.poses[0])
    joint_path = solve_joint_path(samples.poses, ur3e.get_tcp(), HOME_JOINTS, approach)
    joints = joint_path.joints
    count = len(samples.times)
    speeds = np.full((count, 6), np.nan)
    torques = np.full((count, 6), np.nan)
    manipulability = np.full(count, np.nan)
    solved = int(joint_path.solved.sum()) if joint_path.failure is None else joint_path.failure
    if solved >= 2:
        times = samples.times[:solved]
        speeds[:solved] = np.gradient(joints[:solved], times, axis=0)
        accelerations = np.gradient(speeds[:solved], times, axis=0)
        torques[:solved] = _torques(
            ur3e, joints[:solved], speeds[:solved], accelerations, trajectory.force_at(times)
        )
    for i in range(solved):
        manipulability[i] = kinematics.manipulability(joints[i])
    return RobotMotion(joint_path, speeds, torques, manipulability)


def _torques(
    ur3e: SimulatedUR3e,
    joints: np.ndarray,
    speeds: np.ndarray,
    accelerations: np.ndarray,
    contact_forces: np.ndarray,
) -> np.ndarray:
    """Joint torques at each sample, the set contact force (NaN: none) pushing on the TCP."""
    model = copy.deepcopy(ur3e.model)
    model.body_gravcomp[:] = 0.0
    model.opt.disableflags |= int(mujoco.mjtDisableBit.mjDSBL_ACTUATION)
    model.opt.disableflags |= int(mujoco.mjtDisableBit.mjDSBL_CONTACT)
    data = mujoco.MjData(model)
    flange_to_tcp = ur3e.get_tcp()
    out = np.empty_like(joints)
    samples = zip(joints, speeds, accelerations, contact_forces, strict=True)
    for i, (q, qd, qdd, force) in enumerate(samples):
        data.qpos[:6], data.qvel[:6], data.qacc[:6] = q, qd, qdd
        mujoco.mj_inverse(model, data)
        out[i] = data.qfrc_inverse[:6]
        if np.isfinite(force):
            tcp = kinematics.forward_kinematics(q) @ flange_to_tcp
            linear = kinematics.jacobian(q, flange_to_tcp)[:3]
            out[i] += linear.T @ (force * tcp[:3, 2])
    return out


# ----------------------------------------------------------------- advice: shift the path


def _shift_advice(
    trajectory: Trajectory,
    samples: PathSamples,
    ur3e: SimulatedUR3e,
    toward_base: bool,
    acceptable: Callable[[JointPath], bool],
) -> str:
    """Smallest shift of the path toward (or away from) the base that makes it acceptable."""
    phantom_to_base = ur3e.scene.phantom_to_base
    base_in_phantom = invert_pose(phantom_to_base)[:3, 3]
    positions = (invert_pose(phantom_to_base) @ samples.poses)[:, :3, 3]
    toward = base_in_phantom[:2] - positions[:, :2].mean(axis=0)
    toward /= np.linalg.norm(toward)
    direction = toward if toward_base else -toward
    words = "toward" if toward_base else "away from"
    subset = samples.poses[:: max(1, len(samples.poses) // 200)]
    approach = trajectory.approach_pose(samples.poses[0])
    for distance in np.arange(SHIFT_STEP, MAX_SHIFT + 1e-9, SHIFT_STEP):
        shift = phantom_to_base[:3, :3] @ np.array([*(distance * direction), 0.0])
        poses = subset.copy()
        poses[:, :3, 3] += shift
        lead = approach.copy()
        lead[:3, 3] += shift
        if acceptable(solve_joint_path(poses, ur3e.get_tcp(), HOME_JOINTS, lead)):
            return _move_words(trajectory, distance * direction, words)
    return (
        f"no shift {words} the robot base up to {MAX_SHIFT * 100:.0f} cm helps: "
        "move the phantom in the scene"
    )


def _move_words(trajectory: Trajectory, shift: np.ndarray, words: str) -> str:
    text = f"move the path {np.linalg.norm(shift) * 100:.1f} cm {words} the robot base"
    start = trajectory.pattern.get("start")
    if start is not None:
        new = np.asarray(start, dtype=np.float64) + shift
        text += f" (start {new[0]:.3f},{new[1]:.3f})"
    return text


# ----------------------------------------------------------------- the checks


def check_reach(
    trajectory: Trajectory, samples: PathSamples, motion: RobotMotion, ur3e
) -> CheckResult:
    """Every pose has an inverse-kinematics solution."""
    path = motion.joint_path
    if path.failure is None or path.failure_kind != "reach":
        return CheckResult("reach", True, "every pose on the path is reachable")
    place = place_at(trajectory, samples.times[path.failure])
    position = samples.poses[path.failure][:3, 3]
    advice = _shift_advice(trajectory, samples, ur3e, True, lambda p: p.failure is None)
    return CheckResult(
        "reach",
        False,
        f"no IK solution for the TCP at ({position[0]:.3f}, {position[1]:.3f}, "
        f"{position[2]:.3f}) m" + (" on the way in" if path.failure == 0 else ""),
        place,
        advice,
    )


def check_joint_limits(
    trajectory: Trajectory, samples: PathSamples, motion: RobotMotion
) -> CheckResult:
    """The continuous solution stays within the joint position limits."""
    path = motion.joint_path
    if path.failure is not None and path.failure_kind == "limits":
        return CheckResult(
            "joint limits",
            False,
            "the pose needs a joint outside its range (elbow +-180 deg, others +-360 deg)",
            place_at(trajectory, samples.times[path.failure]),
            "rotate the probe about its axis or start the robot nearer the path",
        )
    solved = path.joints[path.solved]
    if not len(solved):
        return CheckResult("joint limits", False, "no pose was solved")
    margin = np.minimum(solved - kinematics.JOINT_LOWER, kinematics.JOINT_UPPER - solved)
    worst = np.unravel_index(np.argmin(margin), margin.shape)
    return CheckResult(
        "joint limits",
        True,
        f"smallest margin {np.degrees(margin[worst]):.0f} deg ({kinematics.JOINT_NAMES[worst[1]]})",
    )


def check_continuity(
    trajectory: Trajectory, samples: PathSamples, motion: RobotMotion
) -> CheckResult:
    """No switch between IK branches along the path."""
    flips = branch_flips(motion.joint_path)
    if not len(flips):
        return CheckResult("IK continuity", True, "one continuous joint solution")
    first = int(flips[0])
    jump = np.abs(np.diff(motion.joint_path.joints[first : first + 2], axis=0))[0]
    joint = int(np.argmax(jump))
    return CheckResult(
        "IK continuity",
        False,
        f"{kinematics.JOINT_NAMES[joint]} jumps {np.degrees(jump[joint]):.0f} deg between "
        "neighbouring samples (IK branch flip)",
        place_at(trajectory, samples.times[first]),
        "keep the path away from singularities (see the singularity check) or shorten it",
    )


def check_joint_speeds(
    trajectory: Trajectory, samples: PathSamples, motion: RobotMotion
) -> CheckResult:
    """Joint speeds stay within UR's limits (180 deg/s base/shoulder/elbow, 360 deg/s wrists)."""
    ratio = np.abs(motion.speeds) / kinematics.JOINT_SPEED_LIMITS
    if not np.isfinite(ratio).any():
        return CheckResult("joint speeds", False, "no joint motion could be computed")
    worst = np.unravel_index(np.nanargmax(ratio), ratio.shape)
    peak, joint = float(ratio[worst]), kinematics.JOINT_NAMES[worst[1]]
    summary = (
        f"max {peak:.2f} of the limit ({joint}, {np.degrees(abs(motion.speeds[worst])):.0f} deg/s)"
    )
    if peak <= 1.0:
        return CheckResult("joint speeds", True, summary)
    over = int(np.flatnonzero(np.nanmax(ratio, axis=1) > 1.0)[0])
    tcp_speed = np.gradient(trajectory.arc_length_at(samples.times), samples.times)[worst[0]]
    advice = f"slow to {tcp_speed * SPEED_MARGIN / peak * 1e3:.1f} mm/s"
    return CheckResult(
        "joint speeds", False, summary, place_at(trajectory, samples.times[over]), advice
    )


def check_torques(trajectory: Trajectory, samples: PathSamples, motion: RobotMotion) -> CheckResult:
    """Joint torques (inverse dynamics plus contact force) within UR's limits."""
    ratio = np.abs(motion.torques) / kinematics.JOINT_TORQUE_LIMITS
    if not np.isfinite(ratio).any():
        return CheckResult("joint torques", False, "no joint torques could be computed")
    worst = np.unravel_index(np.nanargmax(ratio), ratio.shape)
    peak, joint = float(ratio[worst]), kinematics.JOINT_NAMES[worst[1]]
    summary = f"max {peak:.2f} of the limit ({joint}, {abs(motion.torques[worst]):.1f} N m)"
    if peak <= 1.0:
        return CheckResult("joint torques", True, summary)
    return CheckResult(
        "joint torques",
        False,
        summary,
        place_at(trajectory, samples.times[worst[0]]),
        "lower the acceleration, speed or contact force, or move the path nearer the robot base",
    )


def singularity_kind(q: np.ndarray) -> str:
    """Which singularity `q` is nearest: 'wrist' (wrist 2 near 0), 'elbow' (arm stretched) or
    'shoulder' (wrist centre near the base axis)."""
    wrist_centre = kinematics.frame_chain(q)[5][:3, 3]
    shoulder = (np.hypot(*wrist_centre[:2]) - abs(kinematics.DH_D[3])) / 0.1
    measures = {"wrist": abs(np.sin(q[4])), "elbow": abs(np.sin(q[2])), "shoulder": shoulder}
    return min(measures, key=measures.__getitem__)


def check_singularity(
    trajectory: Trajectory, samples: PathSamples, motion: RobotMotion, ur3e
) -> CheckResult:
    """The path keeps its manipulability above MIN_MANIPULABILITY."""
    values = motion.manipulability
    if not np.isfinite(values).any():
        return CheckResult("singularity", False, "no pose was solved")
    worst = int(np.nanargmin(values))
    kind = singularity_kind(motion.joint_path.joints[worst])
    summary = (
        f"min manipulability {values[worst]:.4f} (limit {MIN_MANIPULABILITY}, nearest: {kind})"
    )
    low = np.flatnonzero(values < MIN_MANIPULABILITY)
    if not len(low):
        return CheckResult("singularity", True, summary)
    if kind == "wrist":
        advice = "turn the probe (its direction or tilt) so wrist 2 stays away from 0 deg"
    else:

        def acceptable(path: JointPath) -> bool:
            if path.failure is not None or len(branch_flips(path)):
                return False
            return min(kinematics.manipulability(q) for q in path.joints) >= MIN_MANIPULABILITY

        advice = _shift_advice(trajectory, samples, ur3e, kind == "elbow", acceptable)
    return CheckResult(
        "singularity",
        False,
        f"{kind} singularity: " + summary,
        place_at(trajectory, samples.times[int(low[0])], samples.times[int(low[-1])]),
        advice,
    )


def _collision_geoms(model: mujoco.MjModel) -> tuple[list[int], list[int]]:
    """Robot collision geoms (contype 1) and environment geoms (conaffinity 1)."""
    robot = [g for g in range(model.ngeom) if model.geom_contype[g]]
    world = [g for g in range(model.ngeom) if model.geom_conaffinity[g]]
    return robot, world


def _self_pairs(model: mujoco.MjModel, robot: list[int]) -> list[tuple[int, int]]:
    """Robot geom pairs on links that are neither the same nor parent and child."""
    pairs = []
    for i, a in enumerate(robot):
        for b in robot[i + 1 :]:
            body_a, body_b = model.geom_bodyid[a], model.geom_bodyid[b]
            related = {body_a, model.body_parentid[body_a]} & {body_b, model.body_parentid[body_b]}
            if body_a != body_b and not related:
                pairs.append((a, b))
    return pairs


def check_collisions(
    trajectory: Trajectory, samples: PathSamples, motion: RobotMotion, ur3e: SimulatedUR3e
) -> CheckResult:
    """No robot geom touches the environment (bar the probe face on the phantom) or itself."""
    model = ur3e.model
    data = mujoco.MjData(model)
    robot, _ = _collision_geoms(model)
    allowed = {(model.geom("probe_face").id, model.geom("phantom").id)}
    pairs = _self_pairs(model, robot)
    arc = trajectory.arc_length_at(samples.times)
    marks = np.arange(0.0, arc[-1] + COLLISION_STEP, COLLISION_STEP)
    indices = np.unique(np.clip(np.searchsorted(arc, marks), 0, len(arc) - 1))
    fromto = np.zeros(6)
    checked = 0
    for index in indices:
        q = motion.joint_path.joints[index]
        if not np.isfinite(q).all():
            continue
        checked += 1
        data.qpos[:6] = q
        mujoco.mj_fwdPosition(model, data)
        for contact in data.contact[: data.ncon]:
            pair = (int(contact.geom1), int(contact.geom2))
            if contact.dist < 0 and pair not in allowed and pair[::-1] not in allowed:
                return _collision_failure(trajectory, samples.times[index], model, pair)
        for a, b in pairs:
            if mujoco.mj_geomDistance(model, data, a, b, 0.01, fromto) < 0:
                return _collision_failure(trajectory, samples.times[index], model, (a, b))
    return CheckResult("collisions", True, f"none at {checked} configurations, 2 mm apart")


def _geom_label(model: mujoco.MjModel, geom: int) -> str:
    return model.geom(geom).name or f"{model.body(model.geom_bodyid[geom]).name} geom"


def _collision_failure(trajectory, time, model, pair) -> CheckResult:
    names = " and ".join(_geom_label(model, g) for g in pair)
    return CheckResult(
        "collisions",
        False,
        f"{names} collide",
        place_at(trajectory, time),
        "change the direction or tilt, or move the path so the arm clears the table and phantom",
    )
