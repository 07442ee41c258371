"""Safety limits refuse what they should and name why."""

import re

import numpy as np
import pytest

from resus.acquisition.safety import SafetyLimits, SafetyViolation
from resus.errors import ResusError
from sim.transforms import make_pose


def test_target_outside_box_is_refused_with_the_axis() -> None:
    limits = SafetyLimits(workspace_min=(-0.1, -0.1, 0.0), workspace_max=(0.1, 0.1, 0.2))
    inside = make_pose(np.eye(3), [0.0, 0.0, 0.1])
    limits.check_target(inside, inside, 0.002)
    outside = make_pose(np.eye(3), [0.0, 0.15, 0.1])
    with pytest.raises(SafetyViolation, match=re.escape("TCP y = 0.150 m leaves")):
        limits.check_target(outside, outside, 0.002)


def test_fast_target_and_high_force_are_refused() -> None:
    limits = SafetyLimits(max_speed=0.1, max_force=20.0)
    here = make_pose(np.eye(3), [0.0, 0.0, 0.1])
    jump = make_pose(np.eye(3), [0.001, 0.0, 0.1])  # 1 mm in 2 ms = 0.5 m/s
    with pytest.raises(SafetyViolation, match=re.escape("speed 0.500 m/s")):
        limits.check_target(jump, here, 0.002)
    limits.check_wrench(np.array([0.0, 0.0, 19.0, 0, 0, 0]))
    with pytest.raises(SafetyViolation, match=re.escape("contact force 25.0 N")):
        limits.check_wrench(np.array([0.0, 15.0, 20.0, 0, 0, 0]))


def test_plan_violations_list_every_reason() -> None:
    limits = SafetyLimits(max_speed=0.05, max_force=10.0)
    poses = np.stack([make_pose(np.eye(3), [0.0, 0.0, z]) for z in (0.1, 0.5)])
    reasons = limits.plan_violations(poses, speed=0.2, force=15.0)
    assert len(reasons) == 3
    assert reasons[0].startswith("pose 1:")


@pytest.mark.parametrize(
    ("limits", "message"),
    [
        ({"max_speed": 0.0}, "SafetyLimits.max_speed must be positive, got 0.0"),
        ({"max_force": -1.0}, "SafetyLimits.max_force must be positive, got -1.0"),
        (
            {"workspace_min": (0.0, 0.0, 0.0), "workspace_max": (0.1, 0.0, 0.1)},
            "workspace_min must be below workspace_max on every axis, got (0.0, 0.0, 0.0) and "
            "(0.1, 0.0, 0.1)",
        ),
    ],
)
def test_bad_limits_are_refused_naming_the_setting_and_value(limits, message) -> None:
    with pytest.raises(ResusError, match=re.escape(message)):
        SafetyLimits(**limits)
