"""UR3e DH kinematics against the MuJoCo model and against numerical differentiation."""

import math

import mujoco
import numpy as np
import pytest

from sim.robot import kinematics
from sim.robot.scene import scene_xml_path

RNG = np.random.default_rng(11)


@pytest.fixture(scope="module")
def model_and_data() -> tuple[mujoco.MjModel, mujoco.MjData]:
    model = mujoco.MjModel.from_xml_path(scene_xml_path())
    return model, mujoco.MjData(model)


def site_pose(model: mujoco.MjModel, data: mujoco.MjData, name: str) -> np.ndarray:
    site = model.site(name).id
    pose = np.eye(4)
    pose[:3, :3] = data.site_xmat[site].reshape(3, 3)
    pose[:3, 3] = data.site_xpos[site]
    return pose


def test_model_flange_matches_dh_forward_kinematics(model_and_data) -> None:
    model, data = model_and_data
    for q in RNG.uniform(kinematics.JOINT_LOWER, kinematics.JOINT_UPPER, size=(50, 6)):
        data.qpos[:6] = q
        mujoco.mj_kinematics(model, data)
        flange = site_pose(model, data, "flange")
        expected = kinematics.forward_kinematics(q)
        assert np.abs(flange[:3, 3] - expected[:3, 3]).max() < 1e-4  # 0.1 mm
        assert np.abs(flange[:3, :3] - expected[:3, :3]).max() < 1e-9


def test_home_pose_points_the_tool_down() -> None:
    pose = kinematics.forward_kinematics(
        np.array([0, -math.pi / 2, math.pi / 2, -math.pi / 2, -math.pi / 2, 0])
    )
    np.testing.assert_allclose(pose[:3, 2], [0, 0, -1], atol=1e-12)
    # Upper arm straight up (a2), forearm along -x (a3), wrist 2 down to the flange (d5, d6),
    # the wrist-1 offset (d4) along -y.
    expected = [-(0.2132 + 0.08535), -0.13105, 0.15185 + 0.24355 - 0.0921]
    np.testing.assert_allclose(pose[:3, 3], expected, atol=1e-12)


def test_inverse_kinematics_round_trip() -> None:
    for q in RNG.uniform(-math.pi, math.pi, size=(200, 6)):
        pose = kinematics.forward_kinematics(q)
        solutions = kinematics.inverse_kinematics_all(pose)
        assert len(solutions) >= 1
        for solution in solutions:
            np.testing.assert_allclose(kinematics.forward_kinematics(solution), pose, atol=1e-9)
        nearest = kinematics.inverse_kinematics(pose, q + 0.01)
        np.testing.assert_allclose(nearest, q, atol=1e-8)


def test_pose_well_inside_reach_has_eight_distinct_solutions() -> None:
    q = np.array([0.3, -1.9, 1.0, -0.5, 1.2, 0.4])
    solutions = kinematics.inverse_kinematics_all(kinematics.forward_kinematics(q))
    assert len(solutions) == 8
    assert len({tuple(np.round(s, 6)) for s in solutions}) == 8


def test_inverse_picks_the_two_pi_representation_nearest_the_seed() -> None:
    q = np.array([-0.3, -1.2, 1.4, -1.7, -1.3, 0.4])
    seed = q + np.array([2 * math.pi, 0, 0, 0, 0, -2 * math.pi])
    solution = kinematics.inverse_kinematics(kinematics.forward_kinematics(q), seed)
    np.testing.assert_allclose(solution, seed, atol=1e-8)
    assert kinematics.within_limits(solution)


def test_out_of_reach_pose_has_no_solution() -> None:
    far = np.eye(4)
    far[:3, 3] = (0.8, 0.0, 0.2)
    assert kinematics.inverse_kinematics_all(far) == []
    assert kinematics.inverse_kinematics(far, np.zeros(6)) is None


def test_jacobian_matches_finite_differences_and_mujoco(model_and_data) -> None:
    model, data = model_and_data
    q = np.array([0.2, -1.1, 1.3, -1.9, -1.4, 0.5])
    tcp = np.eye(4)
    tcp[2, 3] = 0.135
    jacobian = kinematics.jacobian(q, tcp)
    step = 1e-7
    for j in range(6):
        dq = np.zeros(6)
        dq[j] = step
        plus = kinematics.forward_kinematics(q + dq) @ tcp
        minus = kinematics.forward_kinematics(q - dq) @ tcp
        np.testing.assert_allclose(
            (plus[:3, 3] - minus[:3, 3]) / (2 * step), jacobian[:3, j], atol=1e-6
        )
    data.qpos[:6] = q
    mujoco.mj_forward(model, data)
    linear, angular = np.zeros((3, model.nv)), np.zeros((3, model.nv))
    mujoco.mj_jacSite(model, data, linear, angular, model.site("tcp").id)
    np.testing.assert_allclose(jacobian[:3], linear[:, :6], atol=1e-9)
    np.testing.assert_allclose(jacobian[3:], angular[:, :6], atol=1e-9)


def test_manipulability_vanishes_at_singularities() -> None:
    regular = np.array([0.2, -1.1, 1.3, -1.9, -1.4, 0.5])
    assert kinematics.manipulability(regular) > 1e-3
    wrist_singular = regular.copy()
    wrist_singular[4] = 0.0
    elbow_singular = regular.copy()
    elbow_singular[2] = 0.0
    assert kinematics.manipulability(wrist_singular) < 1e-9
    assert kinematics.manipulability(elbow_singular) < 1e-9


def test_bad_input_is_rejected() -> None:
    with pytest.raises(ValueError, match="6 finite"):
        kinematics.forward_kinematics(np.zeros(5))
    with pytest.raises(ValueError, match="4x4"):
        kinematics.inverse_kinematics(np.eye(3), np.zeros(6))
