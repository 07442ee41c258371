"""The dashboard server's line protocol (TCP 29999): one command line in, one reply line out.

Replies use PolyScope 5's wording, which ur_rtde's DashboardClient checks for some commands
("Starting program", "Stopped", "Protective stop releasing"). Commands are matched without
regard to case; unknown ones get PolyScope's "Could not understand" reply.
"""

from __future__ import annotations

from sim.rtde import controller as state
from sim.rtde.controller import Controller

WELCOME = "Connected: Universal Robots Dashboard Server"
ROBOT_MODE_NAMES = {
    state.ROBOT_MODE_POWER_OFF: "POWER_OFF",
    state.ROBOT_MODE_IDLE: "IDLE",
    state.ROBOT_MODE_RUNNING: "RUNNING",
}
SAFETY_MODE_NAMES = {
    state.SAFETY_NORMAL: "NORMAL",
    state.SAFETY_PROTECTIVE_STOP: "PROTECTIVE_STOP",
    state.SAFETY_ROBOT_EMERGENCY_STOP: "ROBOT_EMERGENCY_STOP",
}


def reply(controller: Controller, line: str) -> tuple[str, bool]:
    """The reply to one command line, and whether the server closes the connection after it."""
    command = line.strip()
    key = command.lower()
    settings = controller.settings
    if key == "quit":
        return "Disconnected", True
    if key == "polyscopeversion":
        return "URSoftware " + ".".join(map(str, settings.version)) + " (emulated)", False
    if key == "get serial number":
        return settings.serial_number, False
    if key == "get robot model":
        return "UR3", False
    if key == "is in remote control":
        return "true", False
    if key == "robotmode":
        return "Robotmode: " + ROBOT_MODE_NAMES[controller.robot_mode], False
    if key in ("safetymode", "safetystatus"):
        label = "Safetymode" if key == "safetymode" else "Safetystatus"
        return f"{label}: {SAFETY_MODE_NAMES[controller.safety_mode]}", False
    if key == "running":
        return f"Program running: {str(controller.program_running).lower()}", False
    if key == "programstate":
        if controller.program_running:
            return f"PLAYING {state.CONTROL_PROGRAM}.urp", False
        return "STOPPED <unnamed>", False
    if key == "get loaded program":
        return "No program loaded", False
    if key == "power on":
        controller.set_robot_mode(state.ROBOT_MODE_IDLE)
        return "Powering on", False
    if key == "power off":
        controller.set_robot_mode(state.ROBOT_MODE_POWER_OFF)
        return "Powering off", False
    if key == "brake release":
        controller.set_robot_mode(state.ROBOT_MODE_RUNNING)
        return "Brake releasing", False
    if key == "stop":
        controller.stop_program("dashboard stop")
        return "Stopped", False
    if key == "unlock protective stop":
        if controller.unlock_protective_stop():
            return "Protective stop releasing", False
        return "Cannot unlock protective stop: the robot is not protective stopped", False
    if key == "close safety popup":
        return "closing safety popup", False
    if key == "close popup":
        return "closing popup", False
    if key.startswith("popup "):
        return "showing popup", False
    if key.startswith("addtolog "):
        return "Added log message", False
    if key in ("play", "pause") or key.startswith("load "):
        return (
            f"Failed to execute: {command} (the emulator runs only ur_rtde's control script)",
            False,
        )
    return f"Could not understand: '{command}'", False
