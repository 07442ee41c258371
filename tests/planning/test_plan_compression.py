"""The compression pattern against its definition, its stops and force profile through the YAML
file, and the planner and `resus plan --pattern compression` on the default scene."""

import numpy as np
import pytest
import yaml
from cli_runner import one_line_error, run_main

from resus.acquisition.patterns import CompressionPattern, compression_sweep
from resus.acquisition.simulation import phantom_spec, resolve_scene
from resus.acquisition.trajectory import Trajectory
from resus.errors import ResusError
from resus.planning.planner import check_plan
from sim.phantom import Phantom
from sim.transforms import invert_pose

SHORT = {"stations": 2, "station_spacing": 0.02, "press_time": 1.0, "hold_time": 0.5,
         "light_time": 0.5}  # fmt: skip
"""Two stations 20 mm apart, each a 3.5 s press: 0.5 s light, 1 s up, 0.5 s held, 1 s down,
0.5 s light."""


@pytest.fixture(scope="module")
def scene():
    config = resolve_scene("default", None, None)
    return config, Phantom(phantom_spec(config))


def test_stations_stops_and_force_profile_follow_the_definition(scene) -> None:
    config, phantom = scene
    plan = compression_sweep(phantom, config.phantom_to_base, start=(0.002, -0.01), **SHORT)
    # Stations at the start and 20 mm distal, on the skin, probe normal to it, array across
    # the leg (transverse images of vessels along y).
    poses = invert_pose(config.phantom_to_base) @ plan.poses_at(plan.stop_times()[:, 0])
    np.testing.assert_allclose(poses[:, :3, 3], [[0.002, -0.01, 0.0], [0.002, 0.01, 0.0]],
                               atol=1e-12)  # fmt: skip
    np.testing.assert_allclose(poses[:, :3, 2], [[0, 0, -1]] * 2, atol=1e-12)
    np.testing.assert_allclose(np.abs(poses[:, :3, 0]), [[1, 0, 0]] * 2, atol=1e-12)
    # Rest to rest: 3.5 s at each station, 20 mm between them at 10 mm/s (0.2 s ramps).
    assert plan.stops == ((0.0, 3.5), (pytest.approx(0.02), 3.5))
    transit = 0.02 / 0.01 + 0.01 / 0.05
    np.testing.assert_allclose(plan.stop_times(), [[0, 3.5], [3.5 + transit, 7 + transit]])
    assert plan.duration == pytest.approx(7 + transit)
    assert plan.imaging_segments == ((0.0, 0.0), plan.stops[1][0:1] * 2)
    assert plan.station_segments == (0, 1)
    resting = plan.stop_times()[1, 0] + np.array([0.0, 1.7, 3.5])
    np.testing.assert_allclose(plan.arc_length_at(resting), 0.02, atol=1e-12)
    segment = plan.imaging_segment_at(np.array([1.0, 3.5 + transit / 2, 6.0 + transit]))
    np.testing.assert_array_equal(segment, [0, -1, 1])
    # The press at each station: 2 N light, a linear rise to 12 N, held, a linear fall.
    for start, _ in plan.stop_times():
        times = start + np.array([0.0, 0.5, 1.0, 1.5, 2.0, 2.5, 3.0, 3.5])
        np.testing.assert_allclose(plan.force_at(times), [2, 2, 7, 12, 12, 7, 2, 2], atol=1e-9)
    assert plan.force_at(3.5 + transit / 2) == pytest.approx(2.0)  # transit at light contact
    assert plan.force_range == (2.0, 12.0)
    assert plan.pattern["pattern"] == "compression" and plan.pattern["press_force"] == 12.0


def test_stops_and_force_profile_survive_the_yaml_file_and_old_files_load(tmp_path, scene):
    config, phantom = scene
    plan = compression_sweep(phantom, config.phantom_to_base, **SHORT)
    plan.to_yaml(tmp_path / "plan.yaml")
    loaded = Trajectory.from_yaml(tmp_path / "plan.yaml")
    assert (loaded.stops, loaded.force_profile) == (plan.stops, plan.force_profile)
    assert loaded.imaging_segments == plan.imaging_segments
    times = np.linspace(0.0, plan.duration, 301)
    np.testing.assert_allclose(loaded.force_at(times), plan.force_at(times))
    np.testing.assert_allclose(loaded.poses_at(times), plan.poses_at(times), atol=1e-12)
    # A file from before stops and force profiles: one move, the contact force throughout.
    document = yaml.safe_load((tmp_path / "plan.yaml").read_text())
    for key in ("stops", "force_profile", "imaging_segments"):
        del document[key]
    (tmp_path / "old.yaml").write_text(yaml.safe_dump(document))
    old = Trajectory.from_yaml(tmp_path / "old.yaml")
    assert old.stops == () and old.force_profile is None and old.force_range == (2.0, 2.0)
    assert old.duration == pytest.approx(0.02 / 0.01 + 0.01 / 0.05)


def test_bad_stops_profiles_and_presses_are_clear_errors(scene) -> None:
    config, phantom = scene
    plan = compression_sweep(phantom, config.phantom_to_base, **SHORT)
    waypoints = plan.waypoints
    cases = [
        ({"stops": ((0.01, 1.0), (0.005, 1.0))}, "stops must lie at increasing arc lengths"),
        ({"stops": ((0.01, 0.0),)}, "stops must last a positive time"),
        ({"imaging_segments": ((0.01, 0.01),)}, "of zero length only at a stop"),
        ({"force_profile": ((0.0, 4.0), (1.0, 8.0)), "contact_force": None}, "needs force mode"),
        ({"force_profile": ((0.0, 3.0), (1.0, 8.0))}, "starts at 3.0 N, not at contact_force"),
        ({"force_profile": ((0.0, 4.0), (0.0, 8.0))}, "knots at increasing times"),
        ({"force_profile": ((0.0, 4.0), (1.0, -1.0))}, "forces must be positive"),
        ({"force_profile": "12 N"}, "force_profile must be a list of pairs"),
    ]
    for settings, message in cases:
        with pytest.raises(ResusError, match=message):
            Trajectory(waypoints=waypoints, **settings)
    with pytest.raises(ResusError, match=r"press_force must lie .* at most 16 N .*got 17"):
        CompressionPattern(press_force=17.0)
    with pytest.raises(ResusError, match=r"press_force must lie above the light contact"):
        CompressionPattern(contact_force=5.0, press_force=4.0)
    with pytest.raises(ResusError, match=r"CompressionPattern\.stations must be at least 2"):
        CompressionPattern(stations=1)
    with pytest.raises(ResusError, match=r"CompressionPattern\.contact_force must be set"):
        CompressionPattern(contact_force=None)


def test_the_planner_passes_the_default_compression_and_simulates_its_press(scene) -> None:
    config, phantom = scene
    plan = compression_sweep(phantom, config.phantom_to_base)
    analysis = check_plan(plan, config, phantom)
    assert analysis.passed, [check.line() for check in analysis.checks if not check.passed]
    force = analysis.check("contact force").summary
    assert force.startswith("2.0-12.0 N set (profile), peak ")
    # The simulated scan pressed: its force rose to the press force (measured 12.4 N) on
    # the way, well under the limit.
    assert 11.0 < analysis.force.forces.max() < 0.8 * 20.0
    assert analysis.check("progress").summary == "imaging at 3 stations only"
    assert analysis.check("reconstruction holes").summary.endswith("no volume swept")


def test_plan_command_writes_a_compression_plan_and_refuses_bad_flags(
    tmp_path, monkeypatch, capsys
) -> None:
    out = tmp_path / "plan.yaml"
    flags = ["--stations", "2", "--station-spacing", "0.02", "--press-force", "10",
             "--press-time", "1", "--hold-time", "0.5", "--light-time", "0.5"]  # fmt: skip
    status, stdout, _ = run_main(monkeypatch, capsys, "plan", "--pattern", "compression",
                                 *flags, "--out", out)  # fmt: skip
    assert status == 0, stdout
    assert "13/13 checks pass" in stdout
    written = Trajectory.from_yaml(out)
    assert written.force_range == (2.0, 10.0) and len(written.stops) == 2
    for args, fragments in [
        (["--press-force", "19"], ("--press-force", "at most 16 N", "got 19.0")),
        (["--force", "0"], ("--force", "contact_force must be set")),
        (["--stations", "1"], ("--stations", "at least 2")),
        (["--hold-time", "-1"], ("--hold-time", "hold_time must be >= 0")),
        (["--length", "0.05"], ("--length does not apply to --pattern compression",)),
    ]:
        outcome = run_main(monkeypatch, capsys, "plan", "--pattern", "compression", *args,
                           "--out", out)  # fmt: skip
        one_line_error(outcome, *fragments)
    one_line_error(
        run_main(monkeypatch, capsys, "plan", "--stations", "3", "--out", out),
        "--stations does not apply to --pattern linear",
    )


def test_a_scan_that_sweeps_no_volume_reports_no_holes_rather_than_none(tmp_path):
    """A compression scan images at stations: its simulated outcome has no hole fraction, and
    says why instead of printing 0 %."""
    from resus.planning.simulated import SimulatedOutcome

    stations = SimulatedOutcome(tmp_path / "press.h5", 500, 480, None).describe()
    assert "swept no volume" in stations and "%" not in stations
    swept = SimulatedOutcome(tmp_path / "sweep.h5", 500, 480, 0.0123).describe()
    assert "1.23% of the swept volume as holes" in swept
