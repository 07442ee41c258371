"""`resus scan` refusals with the in-process simulated robot: nothing moves, one line, exit 2."""

from __future__ import annotations

import subprocess
import sys

import pytest
from scan_session import write_linear_plan


def resus_scan(*args: object) -> subprocess.CompletedProcess:
    command = [sys.executable, "-c", "from resus.cli.app import main; main()", "scan"]
    return subprocess.run(
        [*command, *map(str, args)], capture_output=True, text=True, timeout=120,
        stdin=subprocess.DEVNULL,
    )  # fmt: skip


@pytest.fixture(scope="module")
def plan(tmp_path_factory):
    folder = tmp_path_factory.mktemp("plan")
    return write_linear_plan(folder / "plan.yaml", (0.0, -0.006), (0.0, 1.0), 0.012)


@pytest.mark.parametrize(
    ("extra", "message"),
    [
        ([], "error: refusing to move the robot without confirmation: no terminal; pass --yes"),
        (
            ["--yes", "--max-speed", "0.005", "--approach-speed", "0.005"],
            "error: unsafe plan 'linear': speed 0.01 m/s exceeds the limit 0.005 m/s",
        ),
        (
            ["--yes", "--max-force", "3"],
            "error: unsafe plan 'linear': contact force 4.0 N exceeds the limit 3.0 N",
        ),
    ],
)
def test_refuses_before_moving(tmp_path, plan, extra, message):
    out = tmp_path / "sweep.h5"
    result = resus_scan(
        "--robot", "sim", "--probe", "sim:32x32", "--trajectory", plan, "--out", out, *extra
    )
    assert result.returncode == 2
    assert result.stderr.strip() == message
    assert "plan 'linear'" in result.stdout and "limits" in result.stdout  # shown first
    assert not out.exists()


@pytest.mark.parametrize(
    ("extra", "message"),
    [
        (["--probe", "camera"], "--probe: expected sim, sim:COLSxROWS or video:"),
        (["--probe", "sim:1x9"], "--probe: expected sim or sim:COLSxROWS"),
        (["--probe", "video:0"], "--probe video needs a real robot clock"),
        (["--probe", "sim", "--workspace", "1,2,3"], "--workspace: expected 6 comma-separated"),
        (["--probe", "sim", "--calibration", "p.yaml"], "--calibration and --crop apply to"),
    ],
)
def test_bad_arguments_are_one_line(tmp_path, plan, extra, message):
    result = resus_scan("--robot", "sim", "--trajectory", plan, "--out", tmp_path / "s.h5", *extra)
    assert result.returncode == 2
    assert result.stderr.count("\n") == 1 and message in result.stderr
