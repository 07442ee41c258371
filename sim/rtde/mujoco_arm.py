"""The MuJoCo UR3e (`sim.robot.ur3e.SimulatedUR3e`) as the emulator's arm.

The emulator's controller plans the motion and streams one setpoint per period (a client's
servo stream already smoothed by its servo and lookahead times, `sim.rtde.motion.ServoTarget`);
they reach the simulated robot as servo commands that arrive within the period (servo time one
period, no lookahead), so the robot's own joint-speed limits, force mode (admittance on its
wrist force/torque sensor), contact with the phantom and protective stops all stay in the
simulation.
"""

from __future__ import annotations

import numpy as np

from sim.robot.scene_config import SceneConfig, load_scene_config, scene_path
from sim.robot.ur3e import CONTROL_PERIOD, SimulatedUR3e
from sim.rtde.arm import ForceModeCommand


class MujocoArm:
    """Adapter from the emulator's per-period setpoints to SimulatedUR3e."""

    control_period = CONTROL_PERIOD

    def __init__(self, robot: SimulatedUR3e) -> None:
        self.robot = robot

    @classmethod
    def from_scene(cls, scene: str | None) -> MujocoArm:
        """The robot in a scene (a YAML path or name); None is SceneConfig's defaults."""
        config = SceneConfig() if scene is None else load_scene_config(scene_path(scene))
        return cls(SimulatedUR3e(config))

    def time(self) -> float:
        return self.robot.time()

    def joint_positions(self) -> np.ndarray:
        return self.robot.joint_positions()

    def tcp_pose(self) -> np.ndarray:
        return self.robot.tcp_pose()

    def tcp_wrench(self) -> np.ndarray:
        return self.robot.tcp_wrench()

    def set_tcp(self, flange_to_tcp: np.ndarray) -> None:
        self.robot.set_tcp(flange_to_tcp)

    def servo_joint(self, q: np.ndarray) -> None:
        self.robot.servo_joint(q, time=CONTROL_PERIOD, lookahead_time=0.0)

    def servo_linear(self, pose: np.ndarray) -> None:
        self.robot.servo_linear(pose, time=CONTROL_PERIOD, lookahead_time=0.0)

    def force_mode(self, command: ForceModeCommand) -> None:
        self.robot.force_mode(
            command.task_frame,
            command.selection,
            command.wrench,
            command.force_type,
            command.limits,
        )

    def force_mode_stop(self) -> None:
        self.robot.force_mode_stop()

    def zero_ft_sensor(self) -> None:
        self.robot.zero_ft_sensor()

    def step(self) -> None:
        self.robot.step()

    def protective_stop_reason(self) -> str | None:
        return self.robot.protective_stop_reason

    def unlock_protective_stop(self) -> None:
        self.robot.unlock_protective_stop()
