"""UR3e kinematics from Universal Robots' published DH table (standard DH convention).

Frames are the controller's: `base_to_flange(q)` is what `getActualTCPPose` reports with a zero
TCP offset. Link transform i is `Rz(q_i) Tz(d_i) Tx(a_i) Rx(alpha_i)`. The analytic inverse
follows Hawkins (2013), "Analytic inverse kinematics for the Universal Robots UR-5/UR-10": two
shoulder, two wrist and two elbow branches give up to 8 solutions, each then shifted by 2 pi
towards a seed within the joint limits.
"""

from __future__ import annotations

import math

import numpy as np
from numba import njit

DH_A = np.array([0.0, -0.24355, -0.2132, 0.0, 0.0, 0.0])
DH_D = np.array([0.15185, 0.0, 0.0, 0.13105, 0.08535, 0.0921])
DH_ALPHA = np.array([math.pi / 2, 0.0, 0.0, math.pi / 2, -math.pi / 2, 0.0])

JOINT_NAMES = ("shoulder_pan", "shoulder_lift", "elbow", "wrist_1", "wrist_2", "wrist_3")
LINK_NAMES = ("shoulder_link", "upper_arm_link", "forearm_link", "wrist_1_link", "wrist_2_link",
              "wrist_3_link")  # fmt: skip
"""The UR3e's moving links as the MJCF names them; link k moves with joint k."""
JOINT_LOWER = np.array(
    [-2 * math.pi, -2 * math.pi, -math.pi, -2 * math.pi, -2 * math.pi, -2 * math.pi]
)
"""Joint limits as in the ROS UR configs: +-360 deg, the elbow +-180 deg (it cannot pass itself)."""
JOINT_UPPER = -JOINT_LOWER
JOINT_SPEED_LIMITS = np.array([math.pi, math.pi, math.pi, 2 * math.pi, 2 * math.pi, 2 * math.pi])
"""180 deg/s for base, shoulder and elbow; 360 deg/s for the wrists (rad/s)."""
JOINT_TORQUE_LIMITS = np.array([54.0, 54.0, 28.0, 9.0, 9.0, 9.0])

SINGULAR_TOLERANCE = 1e-9


def _check_joints(q: np.ndarray) -> np.ndarray:
    q = np.asarray(q, dtype=np.float64)
    if q.shape != (6,) or not np.isfinite(q).all():
        raise ValueError(f"joint vector must be 6 finite numbers (rad), got {q!r}")
    return q


def _check_pose(pose: np.ndarray) -> np.ndarray:
    pose = np.ascontiguousarray(pose, dtype=np.float64)
    if pose.shape != (4, 4) or not np.isfinite(pose).all():
        raise ValueError(f"flange pose must be a finite 4x4 matrix, got shape {pose.shape}")
    return pose


@njit(cache=True)
def _link(index: int, angle: float) -> np.ndarray:
    ct, st = math.cos(angle), math.sin(angle)
    ca, sa = math.cos(DH_ALPHA[index]), math.sin(DH_ALPHA[index])
    a, d = DH_A[index], DH_D[index]
    out = np.zeros((4, 4))
    out[0, 0], out[0, 1], out[0, 2], out[0, 3] = ct, -st * ca, st * sa, a * ct
    out[1, 0], out[1, 1], out[1, 2], out[1, 3] = st, ct * ca, -ct * sa, a * st
    out[2, 1], out[2, 2], out[2, 3] = sa, ca, d
    out[3, 3] = 1.0
    return out


@njit(cache=True)
def _chain(q: np.ndarray) -> np.ndarray:
    frames = np.zeros((7, 4, 4))
    frames[0] = np.eye(4)
    for i in range(6):
        frames[i + 1] = frames[i] @ _link(i, q[i])
    return frames


@njit(cache=True)
def _rigid_inverse(pose: np.ndarray) -> np.ndarray:
    out = np.zeros((4, 4))
    rotation_t = np.ascontiguousarray(pose[:3, :3].T)
    out[:3, :3] = rotation_t
    out[:3, 3] = -(rotation_t @ np.ascontiguousarray(pose[:3, 3]))
    out[3, 3] = 1.0
    return out


@njit(cache=True)
def _wrap(angle: float) -> float:
    return (angle + math.pi) % (2 * math.pi) - math.pi


@njit(cache=True)
def _solutions(pose: np.ndarray, wrist3_fallback: float) -> tuple[np.ndarray, np.ndarray]:
    """All analytic branches (angles wrapped to [-pi, pi)) and which of them exist."""
    a2, a3, d4, d6 = DH_A[1], DH_A[2], DH_D[3], DH_D[5]
    solutions = np.zeros((8, 6))
    valid = np.zeros(8, dtype=np.bool_)
    p = pose[:3, 3]
    wx, wy = p[0] - d6 * pose[0, 2], p[1] - d6 * pose[1, 2]
    radius = math.hypot(wx, wy)
    if radius < abs(d4):
        return solutions, valid
    psi = math.atan2(wy, wx)
    offset = math.asin(d4 / radius)
    for shoulder in range(2):
        q1 = psi + offset if shoulder == 0 else psi + math.pi - offset
        s1, c1 = math.sin(q1), math.cos(q1)
        cos5 = (p[0] * s1 - p[1] * c1 - d4) / d6
        if abs(cos5) > 1.0 + 1e-9:
            continue
        base5 = math.acos(min(1.0, max(-1.0, cos5)))
        for wrist in range(2):
            q5 = base5 if wrist == 0 else -base5
            s5 = math.sin(q5)
            if abs(s5) < SINGULAR_TOLERANCE:
                q6 = wrist3_fallback
            else:
                q6 = math.atan2(
                    -(pose[0, 1] * s1 - pose[1, 1] * c1) / s5,
                    (pose[0, 0] * s1 - pose[1, 0] * c1) / s5,
                )
            frame4_to_6 = _link(4, q5) @ _link(5, q6)
            frame1_to_4 = _rigid_inverse(_link(0, q1)) @ pose @ _rigid_inverse(frame4_to_6)
            planar_x, planar_y = frame1_to_4[0, 3], frame1_to_4[1, 3]
            cos3 = (planar_x**2 + planar_y**2 - a2**2 - a3**2) / (2 * a2 * a3)
            if abs(cos3) > 1.0 + 1e-9:
                continue
            base3 = math.acos(min(1.0, max(-1.0, cos3)))
            sum234 = math.atan2(frame1_to_4[1, 0], frame1_to_4[0, 0])
            for elbow in range(2):
                q3 = base3 if elbow == 0 else -base3
                q2 = math.atan2(planar_y, planar_x) - math.atan2(
                    a3 * math.sin(q3), a2 + a3 * math.cos(q3)
                )
                index = 4 * shoulder + 2 * wrist + elbow
                row = solutions[index]
                row[0], row[1], row[2] = _wrap(q1), _wrap(q2), _wrap(q3)
                row[3], row[4], row[5] = _wrap(sum234 - q2 - q3), _wrap(q5), _wrap(q6)
                valid[index] = True
    return solutions, valid


@njit(cache=True)
def _nearest(pose: np.ndarray, seed: np.ndarray) -> tuple[np.ndarray, bool]:
    """The branch nearest `seed` (max-abs distance), each angle shifted by 2 pi towards the
    seed and kept inside the joint limits."""
    solutions, valid = _solutions(pose, seed[5])
    best = np.zeros(6)
    best_distance = np.inf
    for k in range(8):
        if not valid[k]:
            continue
        candidate = np.empty(6)
        inside = True
        for j in range(6):
            turns = np.round((seed[j] - solutions[k, j]) / (2 * math.pi))
            value = solutions[k, j] + 2 * math.pi * turns
            if value > JOINT_UPPER[j]:
                value -= 2 * math.pi
            if value < JOINT_LOWER[j]:
                value += 2 * math.pi
            inside = inside and JOINT_LOWER[j] <= value <= JOINT_UPPER[j]
            candidate[j] = value
        if not inside:
            continue
        distance = np.max(np.abs(candidate - seed))
        if distance < best_distance:
            best, best_distance = candidate, distance
    return best, best_distance < np.inf


def frame_chain(q: np.ndarray) -> np.ndarray:
    """Base-frame poses of DH frames 0..6, shape (7, 4, 4); frame 6 is the flange (tool0)."""
    return _chain(_check_joints(q))


def forward_kinematics(q: np.ndarray) -> np.ndarray:
    """Flange pose in the controller's base frame (4x4) at joints `q` (rad)."""
    return _chain(_check_joints(q))[6]


def jacobian(q: np.ndarray, flange_to_point: np.ndarray | None = None) -> np.ndarray:
    """Geometric Jacobian (6x6, rows: linear then angular velocity, base frame).

    The linear part is for the point `flange_to_point` (a 4x4 TCP offset; the flange if None).
    """
    frames = frame_chain(q)
    point = frames[6] if flange_to_point is None else frames[6] @ flange_to_point
    end = point[:3, 3]
    result = np.empty((6, 6))
    for i in range(6):
        axis = frames[i][:3, 2]
        result[:3, i] = np.cross(axis, end - frames[i][:3, 3])
        result[3:, i] = axis
    return result


def manipulability(q: np.ndarray) -> float:
    """Yoshikawa's manipulability sqrt(det(J J^T)); zero at a singularity."""
    j = jacobian(q)
    return math.sqrt(max(np.linalg.det(j @ j.T), 0.0))


def within_limits(q: np.ndarray) -> bool:
    """True when every joint lies inside its position range."""
    q = np.asarray(q)
    return bool(np.all(q >= JOINT_LOWER) and np.all(q <= JOINT_UPPER))


def inverse_kinematics_all(pose: np.ndarray, wrist3_fallback: float = 0.0) -> list[np.ndarray]:
    """Every analytic solution for flange pose `pose` (4x4), angles wrapped to [-pi, pi).

    At a wrist singularity (q5 = 0) wrist 1 and wrist 3 are coupled; wrist 3 is then set to
    `wrist3_fallback`. Returns an empty list when the pose is out of reach.
    """
    solutions, valid = _solutions(_check_pose(pose), float(wrist3_fallback))
    return [solutions[k] for k in range(8) if valid[k]]


def inverse_kinematics(pose: np.ndarray, seed: np.ndarray) -> np.ndarray | None:
    """The solution for flange pose `pose` nearest to `seed` (max-abs joint distance).

    Each candidate is moved by multiples of 2 pi towards the seed and kept only inside the
    joint limits. Returns None when no solution reaches the pose within the limits.
    """
    solution, found = _nearest(_check_pose(pose), _check_joints(seed))
    return solution if found else None
