"""The MuJoCo UR3e with an ultrasound probe, and a simulated UR controller driving it.

`SimulatedUR3e(load_scene_config())` builds the scene (robot, probe, F/T sensor, phantom on its
table) and offers UR's command set in ur_rtde's vocabulary; `kinematics` holds the DH model.
"""

from sim.robot.force_mode import ForceModeController
from sim.robot.kinematics import (
    forward_kinematics,
    inverse_kinematics,
    inverse_kinematics_all,
    jacobian,
    manipulability,
)
from sim.robot.scene import build_scene, build_scene_spec, load_scene_phantom
from sim.robot.scene_config import SceneConfig, load_scene_config, save_scene_config
from sim.robot.ur3e import CONTROL_PERIOD, HOME_JOINTS, ProtectiveStopError, SimulatedUR3e

__all__ = [
    "CONTROL_PERIOD",
    "HOME_JOINTS",
    "ForceModeController",
    "ProtectiveStopError",
    "SceneConfig",
    "SimulatedUR3e",
    "build_scene",
    "build_scene_spec",
    "forward_kinematics",
    "inverse_kinematics",
    "inverse_kinematics_all",
    "jacobian",
    "load_scene_config",
    "load_scene_phantom",
    "manipulability",
    "save_scene_config",
]
