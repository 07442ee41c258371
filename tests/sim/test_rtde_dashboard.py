"""The dashboard server's line protocol against the controller it drives, without sockets:
the power cycle, programs, protective stops and the commands it only acknowledges, in
PolyScope 5's words (ur_rtde's DashboardClient checks some of them)."""

from __future__ import annotations

import pytest

from sim.rtde import controller as state
from sim.rtde.arm import KinematicArm
from sim.rtde.controller import Controller
from sim.rtde.dashboard import reply


def answer(controller: Controller, line: str) -> str:
    text, closes = reply(controller, line)
    assert not closes
    return text


def test_power_cycle_moves_the_robot_mode_and_ends_a_program() -> None:
    controller = Controller(KinematicArm())
    assert answer(controller, "robotmode") == "Robotmode: RUNNING"
    controller.program_running = True
    assert answer(controller, "programstate") == f"PLAYING {state.CONTROL_PROGRAM}.urp"
    assert answer(controller, "running") == "Program running: true"
    assert answer(controller, "Power Off") == "Powering off"  # without regard to case
    assert controller.robot_mode == state.ROBOT_MODE_POWER_OFF and not controller.program_running
    assert answer(controller, "robotmode") == "Robotmode: POWER_OFF"
    assert answer(controller, "programstate") == "STOPPED <unnamed>"
    assert answer(controller, "power on") == "Powering on"
    assert answer(controller, "robotmode") == "Robotmode: IDLE"
    assert answer(controller, "brake release") == "Brake releasing"
    assert answer(controller, "robotmode") == "Robotmode: RUNNING"


def test_stop_and_protective_stops() -> None:
    controller = Controller(KinematicArm())
    controller.program_running = True
    assert answer(controller, "stop") == "Stopped"
    assert not controller.program_running
    assert answer(controller, "unlock protective stop").startswith("Cannot unlock")
    controller.protective_stop("test")
    assert answer(controller, "safetystatus") == "Safetystatus: PROTECTIVE_STOP"
    assert answer(controller, "safetymode") == "Safetymode: PROTECTIVE_STOP"
    assert answer(controller, "unlock protective stop") == "Protective stop releasing"
    assert controller.safety_mode == state.SAFETY_NORMAL
    assert answer(controller, "safetystatus") == "Safetystatus: NORMAL"


@pytest.mark.parametrize(
    ("line", "expected"),
    [
        ("get robot model", "UR3"),
        ("is in remote control", "true"),
        ("get loaded program", "No program loaded"),
        ("close safety popup", "closing safety popup"),
        ("close popup", "closing popup"),
        ("popup hello", "showing popup"),
        ("addToLog scan started", "Added log message"),
        ("play", "Failed to execute: play (the emulator runs only ur_rtde's control script)"),
        ("load /programs/x.urp", "Failed to execute: load /programs/x.urp (the emulator"),
        ("  fly  ", "Could not understand: 'fly'"),
    ],
)
def test_acknowledged_refused_and_unknown_commands(line: str, expected: str) -> None:
    assert answer(Controller(KinematicArm()), line).startswith(expected)


def test_quit_closes_the_connection() -> None:
    assert reply(Controller(KinematicArm()), "quit") == ("Disconnected", True)
