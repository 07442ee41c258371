"""ur_rtde's register protocol: command ids and the input registers each one fills.

The uploaded `rtde_control` URScript reads a command id from `input_int_register_0` and its
arguments from the following int and double registers, and answers in
`output_int_register_0` (1 ready, 2 done). The ids and layouts below are those of ur_rtde
1.6.5's `RTDE::RobotCommand` and `RTDE::send` (ints packed first, then doubles, then the
async flag); the emulator implements the subset in `IMPLEMENTED` natively.
"""

from __future__ import annotations

COMMAND_NAMES: dict[int, str] = {
    0: "NO_CMD",
    1: "MOVEJ",
    2: "MOVEJ_IK",
    3: "MOVEL",
    4: "MOVEL_FK",
    6: "FORCE_MODE",
    7: "FORCE_MODE_STOP",
    8: "ZERO_FT_SENSOR",
    9: "SPEEDJ",
    10: "SPEEDL",
    11: "SERVOJ",
    12: "SERVOC",
    13: "SET_STD_DIGITAL_OUT",
    14: "SET_TOOL_DIGITAL_OUT",
    15: "SPEED_STOP",
    16: "SERVO_STOP",
    17: "SET_PAYLOAD",
    18: "TEACH_MODE",
    19: "END_TEACH_MODE",
    20: "FORCE_MODE_SET_DAMPING",
    21: "FORCE_MODE_SET_GAIN_SCALING",
    22: "SET_SPEED_SLIDER",
    23: "SET_STD_ANALOG_OUT",
    24: "SERVOL",
    25: "TOOL_CONTACT",
    26: "GET_STEPTIME",
    27: "GET_ACTUAL_JOINT_POSITIONS_HISTORY",
    28: "GET_TARGET_WAYPOINT",
    29: "SET_TCP",
    30: "GET_INVERSE_KINEMATICS_ARGS",
    31: "PROTECTIVE_STOP",
    33: "STOPL",
    34: "STOPJ",
    35: "SET_WATCHDOG",
    36: "IS_POSE_WITHIN_SAFETY_LIMITS",
    37: "IS_JOINTS_WITHIN_SAFETY_LIMITS",
    38: "GET_JOINT_TORQUES",
    39: "POSE_TRANS",
    40: "GET_TCP_OFFSET",
    41: "JOG_START",
    42: "JOG_STOP",
    43: "GET_FORWARD_KINEMATICS_DEFAULT",
    44: "GET_FORWARD_KINEMATICS_ARGS",
    45: "MOVE_PATH",
    46: "GET_INVERSE_KINEMATICS_DEFAULT",
    47: "IS_STEADY",
    48: "SET_CONF_DIGITAL_OUT",
    49: "SET_INPUT_INT_REGISTER",
    50: "SET_INPUT_DOUBLE_REGISTER",
    51: "MOVE_UNTIL_CONTACT",
    52: "FREEDRIVE_MODE",
    53: "END_FREEDRIVE_MODE",
    54: "GET_FREEDRIVE_STATUS",
    55: "SET_EXTERNAL_FORCE_TORQUE",
    56: "FT_RTDE_INPUT_ENABLE",
    57: "ENABLE_EXTERNAL_FT_SENSOR",
    58: "GET_ACTUAL_TOOL_FLANGE_POSE",
    59: "SET_GRAVITY",
    60: "GET_INVERSE_KINEMATICS_HAS_SOLUTION_DEFAULT",
    61: "GET_INVERSE_KINEMATICS_HAS_SOLUTION_ARGS",
    62: "START_CONTACT_DETECTION",
    63: "STOP_CONTACT_DETECTION",
    64: "READ_CONTACT_DETECTION",
    99: "WATCHDOG",
    255: "STOP_SCRIPT",
}

NO_CMD, MOVEJ, MOVEL = 0, 1, 3
FORCE_MODE, FORCE_MODE_STOP, ZERO_FT_SENSOR = 6, 7, 8
SPEEDJ, SPEEDL, SERVOJ = 9, 10, 11
SPEED_STOP, SERVO_STOP, SERVOL = 15, 16, 24
SET_TCP, STOPL, STOPJ, GET_TCP_OFFSET = 29, 33, 34, 40
STOP_SCRIPT = 255

STREAMING = frozenset({FORCE_MODE, SPEEDJ, SPEEDL, SERVOJ, SERVOL})
"""Commands the client sends without waiting for `done`; re-read every cycle while current."""
IMPLEMENTED = STREAMING | {
    MOVEJ,
    MOVEL,
    FORCE_MODE_STOP,
    ZERO_FT_SENSOR,
    SPEED_STOP,
    SERVO_STOP,
    SET_TCP,
    STOPL,
    STOPJ,
    GET_TCP_OFFSET,
    STOP_SCRIPT,
}
"""Command ids served natively (WATCHDOG is sent as NO_CMD, id 0, and needs nothing)."""
MOTION = frozenset({MOVEJ, MOVEL, SERVOJ, SERVOL, SPEEDJ, SPEEDL})
"""Commands that set the arm moving: the first one starts the clock of motion-relative faults."""


def command_name(command: int) -> str:
    """ur_rtde's name for a command id, for log lines."""
    return COMMAND_NAMES.get(command, "UNKNOWN")
