"""The robot/probe factory behind `resus scan --robot/--probe`, and the executor flags of
`simulate` and `experiment` (`--executor`, `--address`): one line naming the flag, exit 2."""

from __future__ import annotations

import pytest
from cli_runner import free_port, one_line_error, resus, run_main

from resus.acquisition.backends.simulated import SimulatedProbe, SimulatedRobot
from resus.acquisition.factory import (
    RTDERobotConfig,
    SimulatedProbeConfig,
    SimulatedRobotConfig,
    VideoProbeConfig,
    make_probe,
    make_robot,
)
from resus.acquisition.simulation import resolve_scene
from resus.cli.scan import parse_probe, parse_robot
from resus.errors import ResusError
from sim.ultrasound.probe import LinearProbe


def test_flags_become_configs(tmp_path):
    scene = resolve_scene("default", None, None)
    assert parse_robot("sim", scene) == SimulatedRobotConfig(scene)
    assert parse_robot("192.168.0.5", scene) == RTDERobotConfig(host="192.168.0.5")
    assert parse_probe("sim", 25.0, None, None) == SimulatedProbeConfig(frame_rate=25.0)
    small = parse_probe("sim:48x32", 30.0, None, None)
    assert (small.probe.cols, small.probe.rows) == (48, 32)
    calibration = tmp_path / "probe.yaml"
    video = parse_probe("video:2", 30.0, calibration, "1,2,30,40")
    assert video == VideoProbeConfig(2, calibration, crop=(1, 2, 30, 40))
    assert parse_probe("video:clip.mp4", 30.0, calibration, None).source == "clip.mp4"
    for text, calibration_path, crop, message in (
        ("sim", calibration, None, "--calibration and --crop apply to --probe video only"),
        ("video:0", None, None, "--probe video needs --calibration"),
        ("video:0", calibration, "1,2,3", "--crop: expected 4 comma-separated integers"),
        ("video:0", calibration, "0,0,0,10", "--crop"),
        ("sim:0x9", None, None, "--probe: expected sim or sim:COLSxROWS"),
        ("usb", None, None, "--probe: expected sim, sim:COLSxROWS or video:"),
    ):
        with pytest.raises(ResusError, match=message):
            parse_probe(text, 30.0, calibration_path, crop)


def test_the_factory_opens_the_simulated_robot_and_its_probe():
    scene = resolve_scene("default", None, None)
    with make_robot(SimulatedRobotConfig(scene)) as robot:
        assert isinstance(robot, SimulatedRobot)
        probe = make_probe(SimulatedProbeConfig(probe=LinearProbe(cols=32, rows=24)), robot, scene)
        assert isinstance(probe, SimulatedProbe) and probe.shape == (24, 32)
        probe.close()
    with pytest.raises(TypeError, match="no robot backend for str"):
        make_robot("sim")
    with pytest.raises(TypeError, match="no probe backend for str"):
        make_probe("sim", robot, scene)


NOWHERE = "127.0.0.1:{port}"
"""A cluster address where nothing listens (`{port}`: a free port)."""
COMMANDS = {
    "simulate": ["simulate", "--subjects", "0-1", "--out", "{tmp}/sweeps"],
    "experiment phantom": ["experiment", "phantom", "--out", "{tmp}/report"],
    "experiment subjects": ["experiment", "subjects", "--out", "{tmp}/report"],
    "experiment sim2real": ["experiment", "sim2real", "--real", "{tmp}/r", "--out", "{tmp}/o"],
}
BAD_FLAGS = [
    (["--executor", "foo"], "--executor: unknown executor 'foo', expected local or ray"),
    (["--address", "auto"], "--address: only the ray executor takes an address, got executor"),
    (["--executor", "ray", "--address", "head"], "--address: RayExecutor address must be auto"),
    (["--executor", "ray", "--address", NOWHERE], "--address: cannot reach a Ray cluster at"),
    (["--executor", "ray", "--address", "ray://" + NOWHERE], "--address: cannot reach a Ray"),
]


@pytest.mark.parametrize("command", list(COMMANDS))
@pytest.mark.parametrize(
    ("flags", "message"), BAD_FLAGS, ids=["name", "local", "form", "gcs", "client"]
)
def test_a_bad_executor_flag_is_one_line_before_any_work(
    monkeypatch, capsys, tmp_path, command, flags, message
):
    port = free_port()
    arguments = [a.format(tmp=tmp_path, port=port) for a in COMMANDS[command] + flags]
    one_line_error(run_main(monkeypatch, capsys, *arguments), message)
    assert list(tmp_path.iterdir()) == []  # nothing made


def test_one_sweep_runs_here_whatever_the_executor(monkeypatch, capsys, tmp_path):
    arguments = ["simulate", "--out", tmp_path / "s.h5", "--executor", "ray"]
    one_line_error(run_main(monkeypatch, capsys, *arguments), "--executor ray runs the sweeps")


def test_an_unreachable_cluster_for_real(tmp_path):
    address = f"ray://127.0.0.1:{free_port()}"
    done = resus("experiment", "subjects", "--out", tmp_path / "r", "--executor", "ray",
                 "--address", address)  # fmt: skip
    one_line_error((done.returncode, done.stdout, done.stderr), f"'{address}'")
    assert "Traceback" not in done.stderr and not (tmp_path / "r").exists()
