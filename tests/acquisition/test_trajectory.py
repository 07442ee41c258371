"""Trajectory time law, interpolation and file format against hand computations."""

import numpy as np
import pytest
from scipy.spatial.transform import Rotation

from resus.acquisition.trajectory import Trajectory
from resus.errors import ResusError
from sim.transforms import make_pose

DOWN = np.diag([1.0, -1.0, -1.0])  # probe z pointing down into the tissue


def straight(length: float = 0.08, **kwargs) -> Trajectory:
    start = make_pose(DOWN, [0.3, -length / 2, 0.1])
    end = make_pose(DOWN, [0.3, length / 2, 0.1])
    return Trajectory(waypoints=np.stack([start, end]), **kwargs)


def test_trapezoid_duration_and_midpoint() -> None:
    trajectory = straight(0.08, speed=0.01, acceleration=0.05)
    # Ramp 0.2 s covers 1 mm each end; cruise covers 78 mm at 10 mm/s.
    assert trajectory.duration == pytest.approx(0.4 + 7.8)
    assert trajectory.arc_length_at(0.2) == pytest.approx(0.001)
    mid = trajectory.pose_at(trajectory.duration / 2)
    np.testing.assert_allclose(mid[:3, 3], [0.3, 0.0, 0.1], atol=1e-12)
    np.testing.assert_allclose(trajectory.pose_at(trajectory.duration)[:3, 3], [0.3, 0.04, 0.1])
    speeds = np.diff(trajectory.arc_length_at(np.linspace(0, trajectory.duration, 2001)))
    assert speeds.max() / (trajectory.duration / 2000) == pytest.approx(0.01, rel=1e-6)


def test_short_path_uses_a_triangular_profile() -> None:
    trajectory = straight(0.001, speed=0.05, acceleration=0.05)
    # Never reaches cruise: peak sqrt(L a) = sqrt(5e-5), duration 2 peak / a.
    assert trajectory.duration == pytest.approx(2 * np.sqrt(0.001 * 0.05) / 0.05)
    assert trajectory.arc_length_at(trajectory.duration) == pytest.approx(0.001)


def test_rotation_counts_as_arc_length_and_slerps() -> None:
    tilted = DOWN @ Rotation.from_euler("x", 20, degrees=True).as_matrix()
    start, end = make_pose(DOWN, [0.3, 0.0, 0.1]), make_pose(tilted, [0.3, 0.0, 0.1])
    trajectory = Trajectory(waypoints=np.stack([start, end]), rotation_radius=0.05)
    assert trajectory.path_length == pytest.approx(np.radians(20) * 0.05)
    mid = trajectory.pose_at(trajectory.duration / 2)
    angle = Rotation.from_matrix(DOWN.T @ mid[:3, :3]).magnitude()
    assert np.degrees(angle) == pytest.approx(10.0)


def test_approach_pose_lifts_against_the_probe_axis() -> None:
    trajectory = straight(approach_height=0.02)
    lifted = trajectory.approach_pose(trajectory.pose_at(0.0))
    assert lifted[2, 3] == pytest.approx(0.12)  # probe z points down, so up is +z


def test_yaml_round_trip(tmp_path) -> None:
    trajectory = straight(speed=0.02, contact_force=None, pattern={"pattern": "linear"})
    trajectory.to_yaml(tmp_path / "plan.yaml")
    loaded = Trajectory.from_yaml(tmp_path / "plan.yaml")
    np.testing.assert_allclose(loaded.waypoints, trajectory.waypoints, atol=1e-12)
    assert (loaded.speed, loaded.contact_force, loaded.pattern) == (
        0.02,
        None,
        {"pattern": "linear"},
    )


@pytest.mark.parametrize(
    ("content", "message"),
    [
        ("[unclosed", "not a readable YAML"),
        ("schema: other/1\n", "not a trajectory file"),
        ("schema: resus.trajectory/1\nspeed: 1\n", "bad trajectory field"),
    ],
)
def test_bad_files_name_the_file_and_problem(tmp_path, content: str, message: str) -> None:
    path = tmp_path / "bad.yaml"
    path.write_text(content)
    with pytest.raises(ResusError, match=message) as error:
        Trajectory.from_yaml(path)
    assert str(path) in str(error.value)
    with pytest.raises(ResusError, match="not found"):
        Trajectory.from_yaml(tmp_path / "missing.yaml")


def test_rejects_degenerate_paths_naming_the_field() -> None:
    pose = make_pose(DOWN, [0.3, 0.0, 0.1])
    with pytest.raises(ResusError, match=r"^Trajectory\.waypoints do not move"):
        Trajectory(waypoints=np.stack([pose, pose]))
    with pytest.raises(ResusError, match=r"^Trajectory\.speed must be positive, got 0\.0"):
        straight(speed=0.0)
    sheared = pose.copy()
    sheared[0, 1] = 0.5
    with pytest.raises(ResusError, match=r"^Trajectory\.waypoints\[1\] is not a rigid transform"):
        Trajectory(waypoints=np.stack([pose, sheared]))


POSE = make_pose(DOWN, [0.3, 0.0, 0.1])
THREE = np.stack([POSE, make_pose(DOWN, [0.3, 0.01, 0.1]), make_pose(DOWN, [0.3, 0.01, 0.1])])


REFUSED = {
    "one pose": (
        lambda: Trajectory(waypoints=POSE[None]),
        r"waypoints must be at least 2 poses of 4x4, got \(1, 4, 4\)",
    ),
    "coinciding": (lambda: Trajectory(waypoints=THREE), r"waypoints\[1\] and \[2\] coincide"),
    "force": (lambda: straight(contact_force=-1.0), r"contact_force must be positive, got -1\.0"),
    "approach": (
        lambda: straight(approach_height=-0.01),
        r"approach_height must be >= 0, got -0\.01",
    ),
    "nan knot": (
        lambda: straight(force_profile=[(0.0, 4.0), (1.0, np.nan)]),
        r"force_profile must be finite numbers, got \[\(0\.0, 4\.0\), \(1\.0, nan\)\]",
    ),
    "triple": (
        lambda: straight(force_profile=[(0.0, 4.0, 1.0)]),
        r"force_profile must be a list of pairs, got \[\(0\.0, 4\.0, 1\.0\)\]",
    ),
    "first knot": (
        lambda: straight(force_profile=[(0.0, 3.0), (1.0, 5.0)]),
        r"force_profile starts at 3\.0 N, not at contact_force 4\.0 N",
    ),
    "same time": (
        lambda: straight(force_profile=[(0.0, 4.0), (0.0, 5.0)]),
        r"force_profile must be \(time s, force N\) knots at increasing times >= 0",
    ),
    "no force mode": (
        lambda: straight(contact_force=None, force_profile=[(0.0, 4.0)]),
        r"force_profile needs force mode: set contact_force",
    ),
}


@pytest.mark.parametrize("case", REFUSED)
def test_every_refused_field_is_named(case: str) -> None:
    make, message = REFUSED[case]
    with pytest.raises(ResusError, match=rf"^Trajectory\.{message}"):
        make()


def test_a_refused_field_in_a_file_names_the_file_too(tmp_path) -> None:
    path = tmp_path / "plan.yaml"
    straight(contact_force=4.0).to_yaml(path)
    path.write_text(path.read_text().replace("contact_force: 4.0", "contact_force: -2.0"))
    with pytest.raises(ResusError) as error:
        Trajectory.from_yaml(path)
    assert str(error.value) == f"{path}: Trajectory.contact_force must be positive, got -2.0"
