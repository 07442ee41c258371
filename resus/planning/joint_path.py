"""Inverse kinematics along a path, the way the controller follows it: one continuous solution.

The robot starts at its home configuration and reaches the first approach pose by a straight
TCP move, as the scanner does, so the IK branch is the one that move ends on; from there each
sample takes the solution nearest the previous one (max-abs joint distance). A jump of more than
`BRANCH_JUMP` between samples less than a millimetre apart is a switch to another IK branch
(or a pass through a singularity), which a real arm would turn into a violent swing.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from sim.robot import kinematics
from sim.transforms import interpolate_poses

APPROACH_STEP = 0.005
"""Step of the straight move from home to the approach pose (m)."""
BRANCH_JUMP = 0.5
"""Joint change (rad) between neighbouring samples that counts as a branch flip."""


@dataclass(frozen=True)
class JointPath:
    """Joint angles along the samples; NaN from the first sample that could not be solved."""

    joints: np.ndarray
    """(T, 6) radians."""
    failure: int | None
    """First sample with no solution within the joint limits, or None."""
    failure_kind: str = ""
    """'reach' (no IK solution at all) or 'limits' (solutions only outside the joint limits)."""

    @property
    def solved(self) -> np.ndarray:
        return np.isfinite(self.joints[:, 0])


def _solve(pose: np.ndarray, flange_to_tcp_inverse: np.ndarray, seed: np.ndarray):
    return kinematics.inverse_kinematics(pose @ flange_to_tcp_inverse, seed)


def _failure_kind(pose: np.ndarray, flange_to_tcp_inverse: np.ndarray) -> str:
    return "limits" if kinematics.inverse_kinematics_all(pose @ flange_to_tcp_inverse) else "reach"


def solve_joint_path(
    poses: np.ndarray,
    flange_to_tcp: np.ndarray,
    home: np.ndarray,
    approach_pose: np.ndarray | None = None,
) -> JointPath:
    """Continuous joints for TCP `poses` (T, 4, 4), reached from `home` via `approach_pose`."""
    inverse_tcp = np.linalg.inv(flange_to_tcp)
    joints = np.full((len(poses), 6), np.nan)
    seed = np.asarray(home, dtype=np.float64)
    lead_in = [poses[0]] if approach_pose is None else [approach_pose, poses[0]]
    current = kinematics.forward_kinematics(seed) @ flange_to_tcp
    for target in lead_in:
        distance = np.linalg.norm(target[:3, 3] - current[:3, 3])
        steps = np.linspace(0.0, 1.0, int(np.ceil(distance / APPROACH_STEP)) + 2)
        for pose in interpolate_poses(np.array([0.0, 1.0]), np.stack([current, target]), steps):
            solution = _solve(pose, inverse_tcp, seed)
            if solution is None:
                return JointPath(joints, 0, _failure_kind(pose, inverse_tcp))
            seed = solution
        current = target
    for index, pose in enumerate(poses):
        solution = _solve(pose, inverse_tcp, seed)
        if solution is None:
            return JointPath(joints, index, _failure_kind(pose, inverse_tcp))
        joints[index] = seed = solution
    return JointPath(joints, None)


def branch_flips(joint_path: JointPath) -> np.ndarray:
    """Indices i where the solution jumps by more than BRANCH_JUMP from sample i to i + 1."""
    steps = np.abs(np.diff(joint_path.joints, axis=0)).max(axis=1)
    return np.flatnonzero(steps > BRANCH_JUMP)
