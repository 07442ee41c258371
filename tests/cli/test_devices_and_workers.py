"""The robot/probe factory behind `resus scan --robot/--probe`, and the shared process pool."""

from __future__ import annotations

import pytest

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
from resus.workers import available_cores, map_in_processes
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


def test_map_in_processes_keeps_order_in_and_out_of_process():
    assert available_cores() >= 1
    items = [-3, 1, -2]
    assert map_in_processes(abs, items, 1, desc="t", unit="x", progress=False) == [3, 1, 2]
    assert map_in_processes(abs, items, 2, desc="t", unit="x", progress=False) == [3, 1, 2]
    assert map_in_processes(abs, [], 2, desc="t", unit="x", progress=False) == []
