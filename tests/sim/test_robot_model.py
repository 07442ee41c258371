"""The UR3e MJCF and the scene: masses, centres of mass, limits, probe, phantom placement."""

import math

import mujoco
import numpy as np
import pytest
from scipy.spatial.transform import Rotation

from sim.phantom import load_phantom
from sim.phantom.spec import BodySpec
from sim.robot import kinematics
from sim.robot.kinematics import LINK_NAMES
from sim.robot.scene import build_scene, scene_xml_path
from sim.robot.scene_config import (
    SceneConfig,
    default_scene_path,
    load_scene_config,
    save_scene_config,
)
from sim.transforms import make_pose

TABLE_MASSES = (1.98, 3.4445, 1.437, 0.871, 0.805, 0.261)
TABLE_COMS = (
    (0, -0.02, 0),
    (0.13, 0, 0.1157),
    (0.05, 0, 0.0238),
    (0, 0, 0.01),
    (0, 0, 0.01),
    (0, 0, -0.02),
)


@pytest.fixture(scope="module")
def robot_model() -> mujoco.MjModel:
    return mujoco.MjModel.from_xml_path(scene_xml_path())


def test_link_masses_match_the_table(robot_model) -> None:
    for name, mass in zip(LINK_NAMES, TABLE_MASSES, strict=True):
        assert robot_model.body(name).mass[0] == pytest.approx(mass)
    assert robot_model.body("base").mass[0] == pytest.approx(2.0)
    assert robot_model.body("probe").mass[0] == pytest.approx(0.2)


def test_centres_of_mass_sit_where_the_table_puts_them_in_the_dh_link_frames(robot_model) -> None:
    data = mujoco.MjData(robot_model)
    q = np.array([0.4, -1.0, 1.2, -0.7, 0.9, -0.3])
    data.qpos[:6] = q
    mujoco.mj_kinematics(robot_model, data)
    frames = kinematics.frame_chain(q)
    for i, (name, com) in enumerate(zip(LINK_NAMES, TABLE_COMS, strict=True)):
        expected = frames[i + 1] @ np.array([*com, 1.0])
        np.testing.assert_allclose(data.xipos[robot_model.body(name).id], expected[:3], atol=1e-9)


def test_limits_and_actuators(robot_model) -> None:
    np.testing.assert_allclose(robot_model.jnt_range[:6, 1], kinematics.JOINT_UPPER)
    assert robot_model.jnt_range[2, 1] == pytest.approx(math.pi)  # elbow +-pi, as ROS configs
    np.testing.assert_allclose(robot_model.actuator_forcerange[:, 1], [54, 54, 28, 9, 9, 9])
    np.testing.assert_allclose(robot_model.jnt_actfrcrange[:6, 1], [54, 54, 28, 9, 9, 9])
    assert robot_model.opt.timestep <= 0.002  # physics at 500 Hz or faster


def test_tcp_is_the_transducer_face_centre(robot_model) -> None:
    data = mujoco.MjData(robot_model)
    mujoco.mj_kinematics(robot_model, data)
    flange, tcp = robot_model.site("flange").id, robot_model.site("tcp").id
    offset = data.site_xmat[flange].reshape(3, 3).T @ (data.site_xpos[tcp] - data.site_xpos[flange])
    np.testing.assert_allclose(offset, [0, 0, 0.135], atol=1e-12)
    face = robot_model.geom("probe_face")
    face_bottom = face.pos[2] + face.size[2]
    assert face_bottom == pytest.approx(robot_model.site("tcp").pos[2])
    assert 2 * face.size[0] == pytest.approx(0.040) and 2 * face.size[1] == pytest.approx(0.012)


def test_default_scene_file_is_the_default_config_and_round_trips(tmp_path) -> None:
    config = load_scene_config()
    assert config == SceneConfig()
    assert default_scene_path().is_file()
    path = tmp_path / "scene.yaml"
    moved = SceneConfig(
        phantom="leg",
        subject=3,
        leg_side="left",
        table_height=-0.05,
        phantom_to_base=make_pose(
            Rotation.from_euler("xyz", [3.0, -0.2, 1.0]).as_matrix(), [0.1, 0.2, 0.3]
        ),
    )
    save_scene_config(moved, path)
    assert load_scene_config(path) == moved


@pytest.mark.parametrize(
    ("text", "message"),
    [
        ("phantom: default\ncolour: red\n", "unknown scene keys"),
        ("leg_side: middle\n", "leg_side"),
        ("phantom_to_base: {xyz: [0, 0]}\n", "phantom_to_base"),
        (
            "phantom_to_base: {matrix: [[2, 0, 0, 0], [0, 1, 0, 0], [0, 0, 1, 0], [0, 0, 0, 1]]}\n",
            "rigid",
        ),
        ("- a\n- b\n", "a scene file holds a mapping of keys, got a list"),
    ],
)
def test_bad_scene_files_name_the_file_and_the_problem(tmp_path, text, message) -> None:
    path = tmp_path / "bad.yaml"
    path.write_text(text)
    with pytest.raises(ValueError, match=message) as error:
        load_scene_config(path)
    assert str(path) in str(error.value)


def test_missing_scene_file() -> None:
    with pytest.raises(ValueError, match="not found"):
        load_scene_config("no/such/scene.yaml")


def box_top(model: mujoco.MjModel, data: mujoco.MjData, name: str) -> float:
    """Highest z of a box geom: centre plus the half sizes projected on the world z axis."""
    geom = model.geom(name).id
    axes_z = data.geom_xmat[geom].reshape(3, 3)[2]
    return float(data.geom_xpos[geom][2] + np.abs(axes_z) @ model.geom_size[geom])


def test_phantom_top_is_the_phantom_frame_and_rests_on_its_table() -> None:
    config = load_scene_config()
    block = load_phantom(config.phantom).body
    model = build_scene(config)
    data = mujoco.MjData(model)
    mujoco.mj_kinematics(model, data)
    top = config.phantom_to_base[2, 3]
    assert box_top(model, data, "phantom") == pytest.approx(top)
    assert box_top(model, data, "phantom_table") == pytest.approx(config.table_height)
    assert top - block.size[2] == pytest.approx(config.table_height)


def test_leg_phantom_is_a_cylinder_along_y_with_its_top_line_at_the_origin() -> None:
    config = load_scene_config(default_scene_path().with_name("leg.yaml"))
    leg = load_phantom(config.phantom).body
    model = build_scene(config)
    data = mujoco.MjData(model)
    mujoco.mj_kinematics(model, data)
    geom = model.geom("phantom").id
    assert model.geom_type[geom] == mujoco.mjtGeom.mjGEOM_CYLINDER
    axis = data.geom_xmat[geom].reshape(3, 3)[:, 2]
    np.testing.assert_allclose(np.abs(axis), [0, 1, 0], atol=1e-12)
    centre = config.phantom_to_base @ np.array([0, 0, -leg.radius, 1.0])
    np.testing.assert_allclose(data.geom_xpos[geom], centre[:3], atol=1e-12)


def test_unknown_phantom_kind_is_rejected() -> None:
    body = BodySpec(kind="block", size=(0.1, 0.1, 0.05))
    object.__setattr__(body, "kind", "sphere")
    with pytest.raises(ValueError, match="kind"):
        build_scene(SceneConfig(), body)
