"""RTDE wire format (protocol version 2): packet framing, field types and the variable table.

Every packet is a 2-byte big-endian size (header included), a 1-byte type and a payload.
Data packets carry a recipe id byte and then the recipe's values, big-endian, in recipe
order. The variable table lists every controller output and input that a PolyScope 5.x
controller serves, with its wire type; names outside it are answered `NOT_FOUND`, as a real
controller does.
"""

from __future__ import annotations

import re
import struct
from dataclasses import dataclass

HEADER = struct.Struct(">HB")
PROTOCOL_VERSION = 2

REQUEST_PROTOCOL_VERSION = ord("V")
GET_URCONTROL_VERSION = ord("v")
TEXT_MESSAGE = ord("M")
DATA_PACKAGE = ord("U")
SETUP_OUTPUTS = ord("O")
SETUP_INPUTS = ord("I")
START = ord("S")
PAUSE = ord("P")

TYPE_FORMATS: dict[str, str] = {
    "DOUBLE": "d",
    "UINT32": "I",
    "INT32": "i",
    "UINT64": "Q",
    "UINT8": "B",
    "BOOL": "?",
    "VECTOR3D": "3d",
    "VECTOR6D": "6d",
    "VECTOR6INT32": "6i",
    "VECTOR6UINT32": "6I",
}
"""struct codes of the RTDE field types."""

_VECTOR6D_OUTPUTS = [
    "target_q",
    "target_qd",
    "target_qdd",
    "target_current",
    "target_moment",
    "actual_q",
    "actual_qd",
    "actual_current",
    "actual_current_window",
    "joint_control_output",
    "actual_TCP_pose",
    "actual_TCP_speed",
    "actual_TCP_force",
    "target_TCP_pose",
    "target_TCP_speed",
    "joint_temperatures",
    "actual_joint_voltage",
    "payload_inertia",
    "ft_raw_wrench",
    "actual_current_as_torque",
]
_DOUBLE_OUTPUTS = [
    "timestamp",
    "actual_execution_time",
    "speed_scaling",
    "target_speed_fraction",
    "actual_momentum",
    "actual_main_voltage",
    "actual_robot_voltage",
    "actual_robot_current",
    "standard_analog_input0",
    "standard_analog_input1",
    "standard_analog_output0",
    "standard_analog_output1",
    "io_current",
    "euromap67_24V_voltage",
    "euromap67_24V_current",
    "tool_analog_input0",
    "tool_analog_input1",
    "tool_output_current",
    "tool_temperature",
    "tcp_force_scalar",
    "payload",
    "joint_position_deviation_ratio",
    "collision_detection_ratio",
]
_UINT32_OUTPUTS = [
    "runtime_state",
    "robot_status_bits",
    "safety_status_bits",
    "analog_io_types",
    "euromap67_input_bits",
    "euromap67_output_bits",
    "tool_mode",
    "tool_analog_input_types",
    "output_bit_registers0_to_31",
    "output_bit_registers32_to_63",
    "script_control_line",
    "time_scale_source",
]

OUTPUT_TYPES: dict[str, str] = {
    **dict.fromkeys(_VECTOR6D_OUTPUTS, "VECTOR6D"),
    **dict.fromkeys(_DOUBLE_OUTPUTS, "DOUBLE"),
    **dict.fromkeys(_UINT32_OUTPUTS, "UINT32"),
    "actual_digital_input_bits": "UINT64",
    "actual_digital_output_bits": "UINT64",
    "robot_mode": "INT32",
    "safety_mode": "INT32",
    "safety_status": "INT32",
    "tool_output_voltage": "INT32",
    "joint_mode": "VECTOR6INT32",
    "actual_tool_accelerometer": "VECTOR3D",
    "elbow_position": "VECTOR3D",
    "elbow_velocity": "VECTOR3D",
    "payload_cog": "VECTOR3D",
    "tool_output_mode": "UINT8",
    "tool_digital_output0_mode": "UINT8",
    "tool_digital_output1_mode": "UINT8",
}
"""Controller outputs by name (registers are matched by pattern in `output_type`)."""

INPUT_TYPES: dict[str, str] = {
    "speed_slider_mask": "UINT32",
    "speed_slider_fraction": "DOUBLE",
    "standard_digital_output_mask": "UINT8",
    "standard_digital_output": "UINT8",
    "configurable_digital_output_mask": "UINT8",
    "configurable_digital_output": "UINT8",
    "tool_digital_output_mask": "UINT8",
    "tool_digital_output": "UINT8",
    "standard_analog_output_mask": "UINT8",
    "standard_analog_output_type": "UINT8",
    "standard_analog_output_0": "DOUBLE",
    "standard_analog_output_1": "DOUBLE",
    "input_bit_registers0_to_31": "UINT32",
    "input_bit_registers32_to_63": "UINT32",
    "external_force_torque": "VECTOR6D",
}
"""Controller inputs by name (registers are matched by pattern in `input_type`)."""

_REGISTER = re.compile(r"(input|output)_(int|double|bit)_register_(\d+)$")
REGISTER_COUNT = 48
"""General-purpose int and double registers 0..47 in each direction (bit registers 64..127)."""


def _register_type(name: str, direction: str) -> str | None:
    match = _REGISTER.match(name)
    if match is None or match.group(1) != direction:
        return None
    kind, index = match.group(2), int(match.group(3))
    if kind == "bit":
        return "BOOL" if 64 <= index <= 127 else None
    if index >= REGISTER_COUNT:
        return None
    return "INT32" if kind == "int" else "DOUBLE"


def output_type(name: str) -> str | None:
    """Wire type of a controller output (inputs may be read back as outputs too), or None."""
    return OUTPUT_TYPES.get(name) or _register_type(name, "output") or input_type(name)


def input_type(name: str) -> str | None:
    """Wire type of a controller input, or None."""
    return INPUT_TYPES.get(name) or _register_type(name, "input")


@dataclass(frozen=True)
class Recipe:
    """An agreed list of variables and the struct that packs their values after the id byte."""

    recipe_id: int
    names: tuple[str, ...]
    types: tuple[str, ...]

    @property
    def layout(self) -> struct.Struct:
        return struct.Struct(">B" + "".join(TYPE_FORMATS[t] for t in self.types))

    def pack(self, values: dict[str, object]) -> bytes:
        """A complete data packet with the recipe's values taken from `values` by name."""
        flat: list[object] = [self.recipe_id]
        for name, kind in zip(self.names, self.types, strict=True):
            value = values[name]
            if kind.startswith("VECTOR"):
                flat.extend(value)  # type: ignore[arg-type]
            else:
                flat.append(value)
        return packet(DATA_PACKAGE, self.layout.pack(*flat))

    def unpack(self, payload: bytes) -> dict[str, object]:
        """Values by name from a data packet's payload (id byte included)."""
        flat = self.layout.unpack(payload)[1:]
        values: dict[str, object] = {}
        position = 0
        for name, kind in zip(self.names, self.types, strict=True):
            width = int(TYPE_FORMATS[kind][0]) if kind.startswith("VECTOR") else 1
            chunk = flat[position : position + width]
            values[name] = tuple(chunk) if width > 1 else chunk[0]
            position += width
        return values


def packet(kind: int, payload: bytes = b"") -> bytes:
    """Frame a payload as one RTDE packet."""
    return HEADER.pack(HEADER.size + len(payload), kind) + payload


def split_names(payload: bytes) -> tuple[str, ...]:
    """Comma-separated variable names (ur_rtde leaves a trailing comma)."""
    return tuple(name for name in payload.decode("ascii").split(",") if name)
