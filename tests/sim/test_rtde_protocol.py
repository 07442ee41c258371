"""The RTDE emulator's pieces without sockets: wire format, faults, the register protocol."""

from __future__ import annotations

import numpy as np
import pytest

from sim.robot.kinematics import forward_kinematics
from sim.rtde import commands as cmd
from sim.rtde import protocol
from sim.rtde.arm import KinematicArm
from sim.rtde.controller import DONE, PROGRAM_START_DELAY, READY, Controller
from sim.rtde.faults import FaultPlan
from sim.transforms import pose_to_ur

# Every output ur_rtde 1.6.5 asks for: its receive interface's default list, its control
# interface's recipe, and the registers both add.
UR_RTDE_OUTPUTS = [
    "timestamp",
    "target_q",
    "target_qd",
    "target_qdd",
    "target_current",
    "target_moment",
    "actual_q",
    "actual_qd",
    "actual_current",
    "joint_control_output",
    "actual_TCP_pose",
    "actual_TCP_speed",
    "actual_TCP_force",
    "target_TCP_pose",
    "target_TCP_speed",
    "actual_digital_input_bits",
    "joint_temperatures",
    "actual_execution_time",
    "robot_mode",
    "joint_mode",
    "safety_mode",
    "actual_tool_accelerometer",
    "speed_scaling",
    "target_speed_fraction",
    "actual_momentum",
    "actual_main_voltage",
    "actual_robot_voltage",
    "actual_robot_current",
    "actual_joint_voltage",
    "actual_digital_output_bits",
    "runtime_state",
    "standard_analog_input0",
    "standard_analog_input1",
    "standard_analog_output0",
    "standard_analog_output1",
    "robot_status_bits",
    "safety_status_bits",
    "ft_raw_wrench",
    "payload",
    "payload_cog",
    "payload_inertia",
    "output_int_register_2",
    "output_double_register_19",
]


def test_every_output_ur_rtde_asks_for_has_a_type():
    assert [name for name in UR_RTDE_OUTPUTS if protocol.output_type(name) is None] == []
    assert protocol.output_type("actual_TCP_pose") == "VECTOR6D"
    assert protocol.output_type("runtime_state") == "UINT32"
    assert protocol.output_type("output_int_register_48") is None
    assert protocol.output_type("no_such_variable") is None
    assert protocol.input_type("input_double_register_47") == "DOUBLE"
    assert protocol.input_type("output_int_register_0") is None


def test_recipe_packs_big_endian_and_round_trips():
    recipe = protocol.Recipe(3, ("input_int_register_0", "actual_q"), ("INT32", "VECTOR6D"))
    packet = recipe.pack({"input_int_register_0": -2, "actual_q": (1.0, 2, 3, 4, 5, 6.5)})
    assert packet[:3] == bytes([0, 3 + 1 + 4 + 48, ord("U")])
    assert packet[3] == 3 and packet[4:8] == (-2).to_bytes(4, "big", signed=True)
    values = recipe.unpack(packet[3:])
    assert values == {"input_int_register_0": -2, "actual_q": (1.0, 2.0, 3.0, 4.0, 5.0, 6.5)}
    assert protocol.split_names(b"a,b,") == ("a", "b")


def test_fault_plan_parses_items_and_names_a_bad_one():
    plan = FaultPlan.parse(["drop@2.5+1", "protective-stop@1.25", "latency=0.004", "jitter=0.001"])
    assert (plan.drop_at, plan.drop_for, plan.protective_stop_at) == (2.5, 1.0, 1.25)
    assert (plan.latency, plan.jitter, plan.delays_data) == (0.004, 0.001, True)
    assert plan.refusing(3.0) and not plan.refusing(3.5) and not plan.refusing(2.0)
    assert not FaultPlan().delays_data
    with pytest.raises(ValueError, match="--fault 'drop@soon'"):
        FaultPlan.parse(["drop@soon"])


def _registers(command: int, doubles=(), ints=()) -> dict[str, object]:
    values: dict[str, object] = {"input_int_register_0": command}
    values.update({f"input_double_register_{i}": float(v) for i, v in enumerate(doubles)})
    values.update({f"input_int_register_{i + 1}": int(v) for i, v in enumerate(ints)})
    return values


CONTROL_SCRIPT = "def rtde_control():\n  sync()\nend\n"


def _start(controller: Controller) -> None:
    """Upload the control script and cycle until it runs (PROGRAM_START_DELAY)."""
    controller.start_program(CONTROL_SCRIPT)
    for _ in range(round(PROGRAM_START_DELAY / controller.arm.control_period) + 2):
        controller.cycle()


def _running_controller() -> Controller:
    controller = Controller(KinematicArm())
    _start(controller)
    assert controller.program_running and controller.output_value("output_int_register_0") == READY
    return controller


def test_a_script_runs_after_the_start_delay_and_not_a_command_cleared_meanwhile():
    controller = Controller(KinematicArm())
    controller.write_inputs(_registers(18))  # a command left in the register by a failed call
    controller.start_program(CONTROL_SCRIPT)
    cycles = round(PROGRAM_START_DELAY / controller.arm.control_period)
    for _ in range(cycles - 1):
        controller.cycle()
    assert not controller.program_running
    controller.write_inputs({"input_int_register_0": 0})  # ur_rtde's clear, late on RTDE
    for _ in range(3):
        controller.cycle()
    assert controller.program_running and controller.program_error is None
    assert controller.output_value("runtime_state") == 2


def test_blocking_move_handshake_ready_busy_done_ready():
    controller = _running_controller()
    goal = controller.arm.tcp_pose()
    goal[2, 3] -= 0.02
    controller.write_inputs(_registers(cmd.MOVEL, [*pose_to_ur(goal), 0.1, 1.0], [0]))
    controller.cycle()
    assert controller.output_value("output_int_register_0") == 0  # busy
    for _ in range(400):
        controller.cycle()
        if controller.output_value("output_int_register_0") == DONE:
            break
    assert controller.output_value("output_int_register_0") == DONE
    np.testing.assert_allclose(controller.arm.tcp_pose(), goal, atol=1e-9)
    controller.cycle()
    assert controller.output_value("output_int_register_0") == DONE  # until the client clears
    controller.write_inputs({"input_int_register_0": 0})
    controller.cycle()
    assert controller.output_value("output_int_register_0") == READY


def test_published_pose_is_forward_kinematics_of_published_joints():
    controller = _running_controller()
    q = np.array(controller.output_value("actual_q"))
    expected = pose_to_ur(forward_kinematics(q))
    np.testing.assert_allclose(controller.output_value("actual_TCP_pose"), expected, atol=1e-12)
    assert controller.output_value("runtime_state") == 2
    assert controller.output_value("robot_status_bits") == 0b11
    assert controller.output_value("safety_status_bits") == 1


def test_unimplemented_command_stops_the_program_with_a_reason():
    controller = _running_controller()
    controller.write_inputs(_registers(18))  # TEACH_MODE
    controller.cycle()
    assert not controller.program_running
    assert controller.output_value("runtime_state") == 1
    assert "command id 18 (TEACH_MODE) is not implemented" in controller.program_error


def test_other_programs_are_refused_not_interpreted():
    controller = Controller(KinematicArm())
    controller.start_program("def my_program():\n  movej([0,0,0,0,0,0])\nend\n")
    assert not controller.program_running
    assert "not a URScript interpreter" in controller.program_error


def test_protective_stop_sets_safety_bits_and_stops_the_program():
    controller = _running_controller()
    controller.protective_stop("test")
    controller.cycle()
    assert controller.output_value("safety_mode") == 3
    assert controller.output_value("safety_status_bits") == 1 << 2
    assert controller.output_value("runtime_state") == 1
    assert controller.unlock_protective_stop()
    controller.cycle()
    assert controller.output_value("safety_status_bits") == 1
