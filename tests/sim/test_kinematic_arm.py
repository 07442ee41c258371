"""The emulator's kinematic arm in force mode: with no contact model it behaves as a real UR
in free space, moving each compliant axis at its speed limit towards the commanded force,
while the other axes follow their targets."""

from __future__ import annotations

import numpy as np
import pytest

from sim.rtde.arm import ForceModeCommand, KinematicArm, UnreachableTarget

STEPS = 50
SPEED = 0.01
"""The compliant axis's speed limit (m/s)."""


def press_down(arm: KinematicArm, force_type: int = 2) -> None:
    arm.force_mode(
        ForceModeCommand(
            task_frame=np.eye(4),
            selection=np.array([0, 0, 1, 0, 0, 0]),
            wrench=np.array([0.0, 0.0, -5.0, 0.0, 0.0, 0.0]),
            force_type=force_type,
            limits=np.array([0.1, 0.1, SPEED, 0.5, 0.5, 0.5]),
        )
    )


def test_a_compliant_axis_moves_at_its_speed_limit_towards_the_force() -> None:
    arm = KinematicArm()
    start = arm.tcp_pose()
    press_down(arm)
    target = start.copy()
    target[:3, 3] += [0.001, 0.0, 0.0]  # 1 mm along x, a position-controlled axis
    for _ in range(STEPS):
        arm.servo_linear(target)
        arm.step()
    moved = arm.tcp_pose()[:3, 3] - start[:3, 3]
    # z: each command asks for one period at the speed limit, down, which the arm then takes
    np.testing.assert_allclose(moved[2], -SPEED * arm.control_period * STEPS, atol=1e-8)
    np.testing.assert_allclose(moved[:2], [0.001, 0.0], atol=1e-6)
    np.testing.assert_allclose(arm.tcp_wrench(), 0.0)  # nothing to push against

    arm.force_mode_stop()  # every axis position-controlled again: back to the target's z
    for _ in range(STEPS):
        arm.servo_linear(target)
        arm.step()
    np.testing.assert_allclose(arm.tcp_pose()[:3, 3], target[:3, 3], atol=1e-6)


def test_refused_force_mode_and_unreachable_targets() -> None:
    arm = KinematicArm()
    with pytest.raises(ValueError, match="force mode type must be 1, 2 or 3, got 4"):
        press_down(arm, force_type=4)
    far = arm.tcp_pose()
    far[:3, 3] = [2.0, 0.0, 0.3]  # a UR3e reaches 0.5 m
    with pytest.raises(UnreachableTarget, match="no joint solution reaches TCP position"):
        arm.servo_linear(far)
