"""The emulated UR controller: robot, safety and program state, and ur_rtde's control script.

Instead of interpreting the uploaded URScript, the controller runs ur_rtde's register
protocol natively: each 2 ms cycle it reads the command id and arguments from the input
registers, turns motion commands into setpoints (`sim.rtde.motion`) for the arm, steps the
arm, and publishes the state every RTDE output variable is computed from. A command id it
does not implement stops the program with a logged error, as a URScript runtime error would,
so the client sees `isProgramRunning() == False` and the command return False.
"""

from __future__ import annotations

import logging
import re
import threading
from collections import deque
from dataclasses import dataclass
from typing import Any

import numpy as np

from sim.robot.motions import JOINT, LINEAR
from sim.rtde import commands as cmd
from sim.rtde.arm import EmulatedArm, ForceModeCommand
from sim.rtde.motion import Motion, ProfiledMove, ServoTarget, VelocityMove, twist_between
from sim.transforms import pose_from_ur, pose_to_ur

log = logging.getLogger("sim.rtde")

# robot_mode, safety_mode and runtime_state values and status bits from UR's RTDE guide.
ROBOT_MODE_POWER_OFF, ROBOT_MODE_IDLE, ROBOT_MODE_RUNNING = 3, 5, 7
SAFETY_NORMAL, SAFETY_PROTECTIVE_STOP, SAFETY_ROBOT_EMERGENCY_STOP = 1, 3, 7
RUNTIME_STOPPED, RUNTIME_PLAYING = 1, 2
STATUS_POWER_ON, STATUS_PROGRAM_RUNNING = 1 << 0, 1 << 1
SAFETY_BIT_NORMAL, SAFETY_BIT_PROTECTIVE_STOPPED = 1 << 0, 1 << 2
SAFETY_BITS_EMERGENCY_STOPPED = (1 << 6) | (1 << 7)
JOINT_MODE_RUNNING = 253
READY, DONE, BUSY = 1, 2, 0
"""output_int_register_0 handshake: ready for a command, done with it, busy executing it."""
CONTROL_PROGRAM = "rtde_control"
_PROGRAM_NAME = re.compile(r"^\s*def\s+(\w+)\s*\(\s*\)\s*:", re.MULTILINE)
_INT_OFFSET = re.compile(r"# int register offset\n(\d+)")
PROGRAM_START_DELAY = 0.1
"""Seconds from a script's arrival to its first cycle. A real controller compiles a program
before it runs it (a tenth of a second and more); the delay also keeps the order a client
relies on across its two sockets: the register clear ur_rtde sends on RTDE after a failed
command is applied before the re-uploaded script starts, instead of the script serving the
stale command again."""


@dataclass(frozen=True)
class ControllerSettings:
    """Fixed facts the controller reports and its safety reaction to the simulation."""

    version: tuple[int, int, int, int] = (5, 11, 0, 108249)
    """URControl version (major > 3 means e-Series: ur_rtde then runs at 500 Hz)."""
    serial_number: str = "20235500001"


_CONSTANT_OUTPUTS: dict[str, object] = {
    "target_current": (0.0,) * 6,
    "target_moment": (0.0,) * 6,
    "actual_current": (0.0,) * 6,
    "actual_current_window": (0.0,) * 6,
    "actual_current_as_torque": (0.0,) * 6,
    "joint_control_output": (0.0,) * 6,
    "joint_temperatures": (30.0,) * 6,
    "actual_joint_voltage": (48.0,) * 6,
    "actual_digital_input_bits": 0,
    "actual_digital_output_bits": 0,
    "actual_execution_time": 0.1,
    "joint_mode": (JOINT_MODE_RUNNING,) * 6,
    "actual_tool_accelerometer": (0.0, 0.0, 9.81),
    "speed_scaling": 1.0,
    "target_speed_fraction": 1.0,
    "actual_momentum": 0.0,
    "actual_main_voltage": 48.0,
    "actual_robot_voltage": 48.0,
    "actual_robot_current": 0.5,
    "standard_analog_input0": 0.0,
    "standard_analog_input1": 0.0,
    "standard_analog_output0": 0.0,
    "standard_analog_output1": 0.0,
    "io_current": 0.0,
    "euromap67_24V_voltage": 0.0,
    "euromap67_24V_current": 0.0,
    "tool_analog_input0": 0.0,
    "tool_analog_input1": 0.0,
    "tool_output_current": 0.0,
    "tool_temperature": 30.0,
    "analog_io_types": 0,
    "euromap67_input_bits": 0,
    "euromap67_output_bits": 0,
    "tool_mode": 0,
    "tool_analog_input_types": 0,
    "output_bit_registers0_to_31": 0,
    "output_bit_registers32_to_63": 0,
    "script_control_line": 0,
    "time_scale_source": 0,
    "tool_output_voltage": 0,
    "tool_output_mode": 0,
    "tool_digital_output0_mode": 0,
    "tool_digital_output1_mode": 0,
    "payload": 0.0,
    "payload_cog": (0.0, 0.0, 0.0),
    "payload_inertia": (0.0,) * 6,
    "joint_position_deviation_ratio": 0.0,
    "collision_detection_ratio": 0.0,
    "elbow_position": (0.0, 0.0, 0.0),
    "elbow_velocity": (0.0, 0.0, 0.0),
}
"""Readings the simulation does not model, at nominal values (48 V bus, 30 degC joints)."""


class Controller:
    """Robot, safety and program state plus the native control script; thread-safe.

    RTDE sessions write input variables with `write_inputs`; the server calls `cycle()`
    once per control period and sends `outputs` to the clients.
    """

    def __init__(self, arm: EmulatedArm, settings: ControllerSettings = ControllerSettings()):
        self.arm = arm
        self.settings = settings
        self.lock = threading.RLock()
        self.inputs: dict[str, Any] = {}  # decoded RTDE input fields: numbers by name
        self._pending_inputs: deque[dict[str, Any]] = deque()
        self.registers: dict[str, object] = {}
        self.robot_mode = ROBOT_MODE_RUNNING
        self.safety_mode = SAFETY_NORMAL
        self.program_running = False
        self.program_error: str | None = None
        self._program_starts_at: tuple[float, int] | None = None  # (arm time, register offset)
        self.handshake = READY
        self.register_offset = 0
        self.motion: Motion | None = None
        self.motion_started_at: float | None = None
        """Arm time (s) of the first motion command, for motion-relative faults."""
        self.async_motion: Motion | None = None
        self._async_id = 0
        self._async_writes = 0
        self.force_mode_active = False
        self.hold_pose = arm.tcp_pose()
        self.tcp_offset = np.eye(4)
        self._previous_q = arm.joint_positions()
        self._previous_pose = self.hold_pose
        self.outputs: dict[str, object] = {}
        self._hold_cache: tuple[np.ndarray | None, tuple[float, ...]] = (None, ())
        self._publish()

    # -- inputs from RTDE clients and the dashboard ------------------------------------

    def write_inputs(self, values: dict[str, object]) -> None:
        """Input variables from a client's data packet, applied in order by the next cycles
        (see `_apply_inputs`)."""
        with self.lock:
            self._pending_inputs.append(values)

    def _apply_inputs(self) -> None:
        """Apply the packets received since the last cycle, but at most one change of the
        command register per cycle: every command a client sends is served at least once, as
        by a controller that keeps its 2 ms cycle. An emulator running late on a loaded
        machine would otherwise apply two packets in one cycle and lose the first command
        (ur_rtde's forceMode, overwritten by the servoL sent two periods later)."""
        command = f"input_int_register_{self.register_offset}"
        changed = False
        while self._pending_inputs:
            values = self._pending_inputs[0]
            if command in values and values[command] != self.inputs.get(command, 0):
                if changed:
                    return
                changed = True
            self.inputs.update(self._pending_inputs.popleft())

    def start_program(self, script: str) -> None:
        """A URScript program arrived on the script port: it runs `PROGRAM_START_DELAY` later."""
        with self.lock:
            match = _PROGRAM_NAME.search(script)
            name = match.group(1) if match else "<no def>"
            if name != CONTROL_PROGRAM:
                self._fail_program(
                    f"program {name!r} ignored: the emulator runs only ur_rtde's "
                    f"{CONTROL_PROGRAM} natively, it is not a URScript interpreter"
                )
                return
            offset = _INT_OFFSET.search(script)
            start = self.arm.time() + PROGRAM_START_DELAY
            self._program_starts_at = (start, int(offset.group(1)) if offset else 0)

    def _start_due_program(self) -> None:
        if self._program_starts_at is None or self.arm.time() < self._program_starts_at[0]:
            return
        _, self.register_offset = self._program_starts_at
        self._program_starts_at = None
        if self.robot_mode != ROBOT_MODE_RUNNING or self.safety_mode != SAFETY_NORMAL:
            self._fail_program("program not started: robot not running or safety stopped")
            return
        self.registers = {}
        self.program_running, self.program_error = True, None
        self._signal_async(-1)
        self._set_handshake(READY)
        log.info("program %s running (register offset %d)", CONTROL_PROGRAM, self.register_offset)

    def stop_program(self, reason: str) -> None:
        """End the program and bring the arm to rest where it is."""
        with self.lock:
            if self.program_running:
                log.info("program stopped: %s", reason)
            self.program_running, self._program_starts_at = False, None
            self._halt()

    def protective_stop(self, reason: str) -> None:
        """Safety stop: motion aborted, program stopped, `safety_mode` 3 until unlocked."""
        with self.lock:
            if self.safety_mode == SAFETY_PROTECTIVE_STOP:
                return
            log.warning("protective stop: %s", reason)
            self.safety_mode = SAFETY_PROTECTIVE_STOP
            self.stop_program("protective stop")

    def unlock_protective_stop(self) -> bool:
        with self.lock:
            if self.safety_mode != SAFETY_PROTECTIVE_STOP:
                return False
            self.safety_mode = SAFETY_NORMAL
            self.arm.unlock_protective_stop()
            return True

    def set_robot_mode(self, mode: int) -> None:
        with self.lock:
            self.robot_mode = mode
            if mode != ROBOT_MODE_RUNNING:
                self.stop_program("robot not running")

    # -- the control cycle -------------------------------------------------------------

    def cycle(self) -> None:
        """One control period: serve the register protocol, drive and step the arm, publish."""
        with self.lock:
            self._apply_inputs()
            self._start_due_program()
            if self.program_running:
                self._serve_command()
            self._drive()
            self.arm.step()
            reason = self.arm.protective_stop_reason()
            if reason is not None:
                self.protective_stop(reason)
            self._publish()

    def _fail_program(self, message: str) -> None:
        log.error("%s", message)
        self.program_error = message
        self.stop_program(message)

    def _set_handshake(self, state: int) -> None:
        self.handshake = state
        self.registers[f"output_int_register_{self.register_offset}"] = state

    def _signal_async(self, progress: int) -> None:
        """ur_rtde's async progress register (output_int_register_2): operation id in bits
        24-30, a write counter in bits 16-23, bit 15 and a progress value while running."""
        self._async_writes = (self._async_writes + 1) % 128
        if progress == 0:
            self._async_id = (self._async_id + 1) % 128
        value = self._async_writes * 65536 + self._async_id * 16777216
        if progress >= 0:
            value += min(progress, 32767) + 32768
        self.registers[f"output_int_register_{self.register_offset + 2}"] = value

    def _int(self, index: int) -> int:
        return int(self.inputs.get(f"input_int_register_{self.register_offset + index}", 0))

    def _doubles(self, start: int, count: int) -> np.ndarray:
        names = (
            f"input_double_register_{self.register_offset + i}" for i in range(start, start + count)
        )
        return np.array([float(self.inputs.get(name, 0.0)) for name in names])

    def _serve_command(self) -> None:
        command = self._int(0)
        if self.handshake == DONE:
            if command == cmd.NO_CMD:
                self._set_handshake(READY)
            return
        if self.handshake == BUSY:
            if self.motion is None or self.motion.finished:
                self._set_handshake(DONE)
            return
        if command == cmd.NO_CMD:
            return
        if command not in cmd.IMPLEMENTED:
            self._fail_program(
                f"command id {command} ({cmd.command_name(command)}) is not implemented by the "
                "RTDE emulator"
            )
            return
        try:
            waits = self._execute(command)
        except ValueError as error:
            self._fail_program(f"{cmd.command_name(command)} failed: {error}")
            return
        if command not in cmd.STREAMING:
            self._set_handshake(BUSY if waits else DONE)

    def _execute(self, command: int) -> bool:
        """Run one command; True when the client must wait for its motion to end."""
        if command in cmd.MOTION and self.motion_started_at is None:
            self.motion_started_at = self.arm.time()
            log.info(
                "first motion command (%s) at t=%.3f s",
                cmd.command_name(command),
                self.motion_started_at,
            )
        if command in (cmd.MOVEJ, cmd.MOVEL):
            speed, acceleration = self._doubles(6, 2)
            if command == cmd.MOVEJ:
                self.motion = ProfiledMove(
                    JOINT, self.arm.joint_positions(), self._doubles(0, 6), speed, acceleration
                )
            else:
                goal = pose_from_ur(self._doubles(0, 6))
                self.motion = ProfiledMove(LINEAR, self.arm.tcp_pose(), goal, speed, acceleration)
            if self._int(1) == 0:
                return True
            self.async_motion = self.motion
            self._signal_async(0)
            return False
        if command in (cmd.SERVOJ, cmd.SERVOL):
            space = JOINT if command == cmd.SERVOJ else LINEAR
            target = self._doubles(0, 6) if space == JOINT else pose_from_ur(self._doubles(0, 6))
            servo_time, lookahead = self._doubles(8, 2)
            if not (isinstance(self.motion, ServoTarget) and self.motion.space == space):
                start = self.arm.joint_positions() if space == JOINT else self.arm.tcp_pose()
                self.motion = ServoTarget(space, start)
            self.motion.command(target, servo_time, lookahead)
            return False
        if command in (cmd.SPEEDJ, cmd.SPEEDL):
            self._ramp_to(
                JOINT if command == cmd.SPEEDJ else LINEAR,
                self._doubles(0, 6),
                self._doubles(6, 1)[0],
            )
            return False
        if command in (cmd.STOPJ, cmd.STOPL, cmd.SERVO_STOP, cmd.SPEED_STOP):
            space = JOINT if command == cmd.STOPJ else LINEAR
            if command == cmd.SPEED_STOP and isinstance(self.motion, VelocityMove):
                space = self.motion.space
            self._ramp_to(space, np.zeros(6), self._doubles(0, 1)[0], replace=True)
            return command in (cmd.SERVO_STOP, cmd.SPEED_STOP) or self._int(1) == 0
        if command == cmd.FORCE_MODE:
            self._force_mode()
            return False
        if command == cmd.FORCE_MODE_STOP:
            self.force_mode_active = False
            self.arm.force_mode_stop()
            self.motion = None
        elif command == cmd.ZERO_FT_SENSOR:
            self.arm.zero_ft_sensor()
        elif command == cmd.SET_TCP:
            self.tcp_offset = pose_from_ur(self._doubles(0, 6))
            self.arm.set_tcp(self.tcp_offset)
            self.hold_pose = self.arm.tcp_pose()
        elif command == cmd.GET_TCP_OFFSET:
            for index, value in enumerate(pose_to_ur(self.tcp_offset)):
                self.registers[f"output_double_register_{self.register_offset + index}"] = float(
                    value
                )
        elif command == cmd.STOP_SCRIPT:
            self.stop_program("stopScript")
        return False

    def _ramp_to(
        self, space: str, velocity: np.ndarray, acceleration: float, replace: bool = False
    ) -> None:
        """Start (or retarget) a velocity ramp from the arm's current velocity."""
        if isinstance(self.motion, VelocityMove) and self.motion.space == space and not replace:
            self.motion.retarget(velocity, acceleration)
            return
        start = self.arm.joint_positions() if space == JOINT else self.arm.tcp_pose()
        current = self.outputs["actual_qd"] if space == JOINT else self.outputs["actual_TCP_speed"]
        self.motion = VelocityMove(space, start, np.array(current), velocity, acceleration)

    def _force_mode(self) -> None:
        command = ForceModeCommand(
            task_frame=pose_from_ur(self._doubles(0, 6)),
            selection=np.array([self._int(i) for i in range(2, 8)]),
            wrench=self._doubles(6, 6),
            force_type=self._int(1),
            limits=self._doubles(12, 6),
        )
        if not self.force_mode_active:
            self.hold_pose = self.arm.tcp_pose()
        self.arm.force_mode(command)
        self.force_mode_active = True

    def _drive(self) -> None:
        """Hand the arm this period's setpoint."""
        if self.motion is None:
            if self.force_mode_active:
                self.arm.servo_linear(self.hold_pose)
            return
        target = self.motion.advance(self.arm.control_period)
        try:
            if self.motion.space == JOINT:
                self.arm.servo_joint(target)
            else:
                self.arm.servo_linear(target)
                self.hold_pose = target
        except ValueError as error:
            self.motion = None
            self._fail_program(f"motion aborted: {error}")
            return
        if self.motion.finished:
            if self.motion is self.async_motion:
                self.async_motion = None
                self._signal_async(-1)
            self.motion = None

    def _halt(self) -> None:
        """End motion and force mode: the arm holds its last setpoint, one period ahead."""
        self.motion = None
        if self.force_mode_active:
            self.force_mode_active = False
            self.arm.force_mode_stop()
        self.hold_pose = self.arm.tcp_pose()

    # -- published state ---------------------------------------------------------------

    def _publish(self) -> None:
        period = self.arm.control_period
        q, pose = self.arm.joint_positions(), self.arm.tcp_pose()
        qd = (q - self._previous_q) / period
        twist = twist_between(self._previous_pose, pose, period)
        self._previous_q, self._previous_pose = q, pose
        protective = self.safety_mode == SAFETY_PROTECTIVE_STOP
        emergency = self.safety_mode == SAFETY_ROBOT_EMERGENCY_STOP
        safety_bits = (SAFETY_BIT_PROTECTIVE_STOPPED if protective else 0) | (
            SAFETY_BITS_EMERGENCY_STOPPED if emergency else 0
        )
        if self.safety_mode == SAFETY_NORMAL:
            safety_bits |= SAFETY_BIT_NORMAL
        status_bits = (STATUS_POWER_ON if self.robot_mode >= ROBOT_MODE_IDLE else 0) | (
            STATUS_PROGRAM_RUNNING if self.program_running else 0
        )
        wrench = tuple(float(v) for v in self.arm.tcp_wrench())
        tcp = tuple(float(v) for v in pose_to_ur(pose))
        if self.motion is None or self.motion.space == JOINT:
            target_tcp = self._hold_pose_ur()
        else:
            target_tcp = tcp
        outputs = dict(_CONSTANT_OUTPUTS)
        outputs.update(self.inputs)
        outputs.update(
            {
                "timestamp": self.arm.time(),
                "actual_q": tuple(float(v) for v in q),
                "target_q": tuple(float(v) for v in q),
                "actual_qd": tuple(float(v) for v in qd),
                "target_qd": tuple(float(v) for v in qd),
                "target_qdd": (0.0,) * 6,
                "actual_TCP_pose": tcp,
                "target_TCP_pose": target_tcp,
                "actual_TCP_speed": tuple(float(v) for v in twist),
                "target_TCP_speed": tuple(float(v) for v in twist),
                "actual_TCP_force": wrench,
                "ft_raw_wrench": wrench,
                "tcp_force_scalar": float(np.linalg.norm(wrench[:3])),
                "robot_mode": self.robot_mode,
                "safety_mode": self.safety_mode,
                "safety_status": self.safety_mode,
                "runtime_state": RUNTIME_PLAYING if self.program_running else RUNTIME_STOPPED,
                "robot_status_bits": status_bits,
                "safety_status_bits": safety_bits,
            }
        )
        outputs.update(self.registers)
        self.outputs = outputs

    def _hold_pose_ur(self) -> tuple[float, ...]:
        """`hold_pose` as a UR pose, converted once per change."""
        if self._hold_cache[0] is not self.hold_pose:
            self._hold_cache = (self.hold_pose, tuple(float(v) for v in pose_to_ur(self.hold_pose)))
        return self._hold_cache[1]

    def output_value(self, name: str) -> object:
        """The current value of an output; registers never written read as zero."""
        value = self.outputs.get(name)
        if value is None:
            return 0.0 if "double" in name else 0
        return value
