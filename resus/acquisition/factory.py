"""Robots and probes from configs: one frozen config per backend, `make_robot`, `make_probe`.

A caller (the CLI, a script, a test) says which device it wants as a config value; the
factory opens it, so choosing and wiring a backend happens here and nowhere else:

- robots: `SimulatedRobotConfig` (the in-process MuJoCo UR3e) or `RTDERobotConfig` (a UR
  controller over ur_rtde: a real UR3e or `resus emulate`);
- probes: `SimulatedProbeConfig` (synthetic ultrasound at the robot's reported pose),
  `VideoProbeConfig` (the scanner's video through a frame grabber) or `IgtlProbeConfig`
  (IMAGE messages from an OpenIGTLink server such as PLUS).
"""

from __future__ import annotations

from dataclasses import dataclass

from resus.acquisition.backends.igtl import IgtlProbe, IgtlProbeConfig
from resus.acquisition.backends.render_process import RenderProcessProbe
from resus.acquisition.backends.rtde import RTDERobot, RTDERobotConfig
from resus.acquisition.backends.simulated import (
    SimulatedProbe,
    SimulatedProbeConfig,
    SimulatedRobot,
)
from resus.acquisition.backends.video import VideoProbe, VideoProbeConfig
from resus.acquisition.probe import Probe
from resus.acquisition.robot import Robot
from resus.acquisition.simulation import phantom_spec
from sim.phantom import Phantom
from sim.robot.scene_config import SceneConfig


@dataclass(frozen=True)
class SimulatedRobotConfig:
    """The MuJoCo UR3e in this process, on `scene` (its table, mounting and phantom)."""

    scene: SceneConfig


RobotConfig = SimulatedRobotConfig | RTDERobotConfig
ProbeConfig = SimulatedProbeConfig | VideoProbeConfig | IgtlProbeConfig


def make_robot(config: RobotConfig) -> Robot:
    """Open the robot `config` describes (connected; close it, or use it in a `with`)."""
    if isinstance(config, SimulatedRobotConfig):
        return SimulatedRobot(config.scene)
    if isinstance(config, RTDERobotConfig):
        return RTDERobot(config)
    raise TypeError(f"no robot backend for {type(config).__name__}")


def make_probe(config: ProbeConfig, robot: Robot, scene: SceneConfig) -> Probe:
    """Open the probe `config` describes on `robot`, ready for its first frame.

    A simulated probe images `scene`'s phantom at the robot's reported pose: in this process
    on the simulated robot (stepped by the scanner, so rendering time costs nothing), and in
    a worker process on any other robot, whose real-time servo loop a render would stall.
    """
    if isinstance(config, VideoProbeConfig):
        return VideoProbe(config)
    if isinstance(config, IgtlProbeConfig):
        return IgtlProbe(config)
    if isinstance(config, SimulatedProbeConfig):
        phantom = Phantom(phantom_spec(scene))
        if isinstance(robot, SimulatedRobot):
            probe = SimulatedProbe(robot, config, phantom, scene)
            probe.poll()  # the first frame loads the renderer's compiled kernels: not mid-sweep
            return probe
        return RenderProcessProbe(robot, config, phantom, scene)
    raise TypeError(f"no probe backend for {type(config).__name__}")
