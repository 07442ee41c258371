"""`resus plan` end to end, and a saved plan run unchanged in the simulator."""

from pathlib import Path

import numpy as np
from cli_runner import resus

from resus.acquisition.simulation import resolve_scene
from resus.acquisition.trajectory import Trajectory
from resus.planning.simulated import simulate_plan
from resus.sweep.io import read_sweep
from sim.ultrasound.probe import LinearProbe

SMALL_PROBE = LinearProbe(cols=64, rows=64)


def test_good_plan_exits_0_with_a_report_and_a_bad_one_exits_1(tmp_path: Path) -> None:
    good = resus("plan", "--out", tmp_path / "good.yaml", "--report", tmp_path / "report")
    assert good.returncode == 0, good.stdout + good.stderr
    assert "13/13 checks pass" in good.stdout
    for name in ("report.md", "joints.png", "top_view.png", "coverage.png"):
        assert (tmp_path / "report" / name).stat().st_size > 1000
    assert "| frame spacing | **PASS** |" in (tmp_path / "report" / "report.md").read_text()
    fast = resus("plan", "--out", tmp_path / "fast.yaml", "--speed", "0.03")
    assert fast.returncode == 1
    assert "FAIL  frame spacing" in fast.stdout and "slow to 14.2 mm/s" in fast.stdout
    assert Trajectory.from_yaml(tmp_path / "fast.yaml").speed == 0.03


def test_bad_input_is_one_line_and_exit_2(tmp_path: Path) -> None:
    for args, message in (
        (["--pattern", "spiral"], "--pattern must be one of"),
        (["--start", "1"], "--start: expected 2 comma-separated numbers"),
        (["--pattern", "raster", "--passes", "0"], "--passes: RasterPattern.passes must be at"),
        (["--pattern", "fan", "--length", "0.02"], "--length does not apply to --pattern fan"),
        (["--force", "-1"], "--force: LinearPattern.contact_force must be positive"),
        (["--voxel-size", "0"], "--voxel-size"),
    ):
        result = resus("plan", "--out", tmp_path / "plan.yaml", *args)
        assert result.returncode == 2, result.stderr
        assert result.stderr.strip().count("\n") == 0 and message in result.stderr


def test_saved_plan_runs_unchanged_in_the_simulator(tmp_path: Path) -> None:
    scene = resolve_scene("default", None, None)
    resus_result = resus(
        "plan", "--out", tmp_path / "plan.yaml", "--pattern", "raster", "--start", "0,-0.04",
        "--length", "0.012", "--passes", "2", "--offset", "0.004", "--speed", "0.012",
    )  # fmt: skip
    assert resus_result.returncode == 0, resus_result.stdout
    plan = Trajectory.from_yaml(tmp_path / "plan.yaml")
    outcome = simulate_plan(
        tmp_path / "sweep.h5", scene, plan, 0.5e-3, probe=SMALL_PROBE, progress=False
    )
    sweep = read_sweep(outcome.sweep_path)
    # simulate_plan runs the file through `simulate_sweep`: the recorded poses follow the
    # planned path over the skin (within 1 mm: servo lag of about 50 ms at 12 mm/s, and the
    # 2 mm radius U-turn's corner cut) and press 4 N into the gel (about 2 mm).
    planned = plan.poses_at(np.linspace(0, plan.duration, 4000))[:, :3, 3]
    recorded = sweep.probe_to_base[:, :3, 3]
    gaps = np.linalg.norm(recorded[:, None, :2] - planned[None, :, :2], axis=2)
    nearest = gaps.argmin(axis=1)
    assert gaps.min(axis=1).max() < 1e-3
    depth = planned[nearest, 2] - recorded[:, 2]
    assert depth.min() > 0.5e-3 and depth.max() < 3e-3
    assert 0 < outcome.imaging_frames < outcome.frames  # the U-turn frames are set aside
    assert outcome.hole_fraction is not None and outcome.hole_fraction < 0.05


def test_simulate_scans_the_plan_and_reports_the_holes_it_leaves(tmp_path: Path) -> None:
    """`--simulate` runs the plan in the simulator: the sweep goes into the report folder
    (beside the plan without one), its outcome is printed and written into report.md."""
    plan, report = tmp_path / "short.yaml", tmp_path / "report"
    done = resus("plan", "--out", plan, "--length", "0.006", "--simulate", "--report", report)
    assert done.returncode == 0, done.stdout + done.stderr
    sweep = read_sweep(report / "short_sweep.h5")
    outcome = next(line for line in done.stdout.splitlines() if line.startswith("Simulated"))
    assert outcome.startswith(f"Simulated scan `short_sweep.h5`: {len(sweep)} frames (")
    assert "of the swept volume as holes." in outcome
    assert outcome in (report / "report.md").read_text()
    recorded_path = np.linalg.norm(sweep.probe_to_base[-1, :3, 3] - sweep.probe_to_base[0, :3, 3])
    assert 0.004 < recorded_path < 0.0062  # the 6 mm plan, less a frame period at either end

    alone = resus("plan", "--out", tmp_path / "alone.yaml", "--length", "0.006", "--simulate")
    assert alone.returncode == 0, alone.stdout + alone.stderr
    assert (tmp_path / "alone_sweep.h5").is_file()
