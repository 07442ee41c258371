"""Force/torque sensing and force mode: the probe pressed into the gel phantom."""

import mujoco
import numpy as np
import pytest

from sim.robot import SimulatedUR3e, load_scene_config
from sim.robot.scene_config import default_scene_path

FORCE = 5.0


def press(robot: SimulatedUR3e, y: float = -0.04) -> None:
    """Hover 3 mm above the phantom, zero the sensor, push 5 N along the probe axis, settle."""
    robot.move_linear(robot.probe_pose_on_skin(0.0, y, 0.003))
    robot.step(100)
    robot.zero_ft_sensor()
    robot.force_mode(robot.tcp_pose(), [0, 0, 1, 0, 0, 0], [0, 0, FORCE, 0, 0, 0])
    robot.step(1500)


def probe_axis_force(robot: SimulatedUR3e) -> float:
    return float(robot.tcp_wrench()[:3] @ robot.tcp_pose()[:3, 2])


def test_payload_is_compensated_in_any_orientation(robot) -> None:
    for pose in (
        robot.probe_pose_on_skin(0.0, 0.0, 0.06),
        robot.probe_pose_on_skin(0.0, 0.0, 0.06)
        @ np.array([[1, 0, 0, 0], [0, 0, -1, 0], [0, 1, 0, 0], [0, 0, 0, 1.0]]),
    ):
        robot.move_linear(pose)
        robot.step(300)
        np.testing.assert_allclose(robot.tcp_wrench(), 0.0, atol=0.02)


def test_force_mode_holds_the_commanded_force(robot) -> None:
    press(robot)
    assert probe_axis_force(robot) == pytest.approx(FORCE, rel=0.05)
    # UR sign: the force the robot exerts on the phantom points down, into it.
    assert robot.tcp_wrench()[2] == pytest.approx(-FORCE, rel=0.05)
    depth = -robot.tcp_pose_in_phantom()[2, 3]
    assert 0.5e-3 < depth < 5e-3  # gel-like: about 1-3 N/mm
    contacts = {robot.model.geom(c.geom2).name for c in robot.data.contact[: robot.data.ncon]}
    assert "phantom" in contacts


def test_sensor_force_matches_mujoco_contact_force(robot) -> None:
    press(robot)
    total = np.zeros(3)
    for i, contact in enumerate(robot.data.contact[: robot.data.ncon]):
        local = np.zeros(6)
        mujoco.mj_contactForce(robot.model, robot.data, i, local)
        total += contact.frame.reshape(3, 3).T @ local[:3]
    # Contact frame normals point from geom1 (the probe) to geom2 (the phantom): the force on
    # the phantom is +normal force, which the sensor must report (after zeroing).
    np.testing.assert_allclose(robot.tcp_wrench()[:3], total, atol=0.05)


@pytest.mark.parametrize("scene", ["default.yaml", "leg.yaml"])
def test_sweep_in_force_mode_keeps_contact(shared_robot, scene) -> None:
    path = default_scene_path().with_name(scene)
    robot = shared_robot if scene == "default.yaml" else SimulatedUR3e(load_scene_config(path))
    robot.reset()
    press(robot)
    periods = 2500
    forces, depths = [], []
    for i in range(periods):
        y = -0.04 + 0.08 * (i + 1) / periods
        robot.servo_linear(robot.probe_pose_on_skin(0.0, y, 0.0))
        robot.step()
        forces.append(probe_axis_force(robot))
        depths.append(-robot.tcp_pose_in_phantom()[2, 3])
    assert min(forces) > 0.8 * FORCE and max(forces) < 1.2 * FORCE
    assert min(depths) > 0.0
    assert robot.tcp_pose_in_phantom()[1, 3] == pytest.approx(0.04, abs=2e-3)
    robot.force_mode_stop()
    assert not robot.in_force_mode()


def test_force_mode_arguments_are_checked(robot) -> None:
    frame = robot.tcp_pose()
    with pytest.raises(ValueError, match="rotational"):
        robot.force_mode(frame, [0, 0, 1, 1, 0, 0], [0, 0, 5, 0, 0, 0])
    with pytest.raises(ValueError, match="type"):
        robot.force_mode(frame, [0, 0, 1, 0, 0, 0], [0, 0, 5, 0, 0, 0], force_type=1)
    with pytest.raises(ValueError, match="selection_vector"):
        robot.force_mode(frame, [0, 0, 2, 0, 0, 0], [0, 0, 5, 0, 0, 0])
    with pytest.raises(ValueError, match="limits"):
        robot.force_mode(frame, [0, 0, 1, 0, 0, 0], [0, 0, 5, 0, 0, 0], limits=[0.1] * 5)
    assert not robot.in_force_mode()
