"""Simulated backends: the MuJoCo UR3e as a `Robot`, synthetic ultrasound as a `Probe`.

The simulated probe renders at the robot's true TCP pose in the phantom frame at the moment
it takes a frame, so a Sweep recorded through the scanner can be checked against the ground
truth; a phantom with mechanics deforms under the contact force the robot measures then. It
can also deliver frames late (`latency`) and stamp them on a clock offset from the robot's
(`clock_offset`), as a real scanner's video does, to exercise temporal alignment.
"""

from __future__ import annotations

from dataclasses import dataclass, field

import numpy as np

from resus.acquisition.probe import Frame, SyntheticProbe
from resus.acquisition.robot import Robot, RobotFault
from resus.errors import ResusError
from sim.phantom import Phantom
from sim.robot.scene import load_scene_phantom
from sim.robot.scene_config import SceneConfig
from sim.robot.ur3e import CONTROL_PERIOD, ProtectiveStopError, SimulatedUR3e
from sim.transforms import invert_pose
from sim.ultrasound.deformation import TissueLoad
from sim.ultrasound.persistence import Persistence
from sim.ultrasound.probe import LinearProbe
from sim.ultrasound.settings import UltrasoundSettings
from sim.ultrasound.simulator import UltrasoundSimulator

FORCE_MODE_SPEED_LIMIT = 0.05
"""Highest TCP speed along the compliant probe axis in force mode (m/s)."""


class SimulatedRobot(Robot):
    """`Robot` on the MuJoCo UR3e; `wait_period` advances the simulation by one period."""

    control_period = CONTROL_PERIOD

    def __init__(self, scene: SceneConfig | None = None) -> None:
        self.ur3e = SimulatedUR3e(scene)
        self.scene = self.ur3e.scene

    def tcp_pose(self) -> np.ndarray:
        return self.ur3e.tcp_pose()

    def joint_positions(self) -> np.ndarray:
        return self.ur3e.joint_positions()

    def tcp_wrench(self) -> np.ndarray:
        return self.ur3e.tcp_wrench()

    def time(self) -> float:
        return self.ur3e.time()

    def move_linear(self, pose: np.ndarray, speed: float, acceleration: float) -> None:
        self._command(self.ur3e.move_linear, pose, speed, acceleration)

    def servo_linear(self, pose: np.ndarray) -> None:
        self._command(self.ur3e.servo_linear, pose)

    def wait_period(self) -> None:
        self.ur3e.step()

    def force_mode(self, force: float) -> None:
        self._command(
            self.ur3e.force_mode,
            self.ur3e.tcp_pose(),
            np.array([0, 0, 1, 0, 0, 0]),
            np.array([0.0, 0.0, force, 0.0, 0.0, 0.0]),
            2,
            np.full(6, FORCE_MODE_SPEED_LIMIT),
        )

    def force_mode_stop(self) -> None:
        self.ur3e.force_mode_stop()

    def stop(self) -> None:
        self.ur3e.stop()

    def fault(self) -> str | None:
        reason = self.ur3e.protective_stop_reason
        return None if reason is None else f"protective stop: {reason}"

    def _command(self, method, *args) -> None:
        """Run a motion command; a robot that refuses it raises RobotFault."""
        try:
            method(*args)
        except ProtectiveStopError as error:  # its message says it is a protective stop
            raise RobotFault(str(error)) from None
        except ValueError as error:
            raise RobotFault(str(error)) from None


@dataclass(frozen=True)
class SimulatedProbeConfig:
    """A synthetic linear probe on the simulated robot."""

    probe: LinearProbe = field(default_factory=LinearProbe)
    settings: UltrasoundSettings = field(default_factory=UltrasoundSettings)
    frame_rate: float = 30.0
    """Frames per second (Hz)."""
    latency: float = 0.0
    """How long after it is taken a frame is delivered (s)."""
    clock_offset: float = 0.0
    """Offset of the probe's clock from the robot's (s): timestamp = robot time + offset."""
    rigid: bool = False
    """Image the rigid world even if the phantom has mechanics (no deformation)."""

    def __post_init__(self) -> None:
        where = "SimulatedProbeConfig"
        if not self.frame_rate > 0:
            raise ResusError(f"{where}.frame_rate must be positive, got {self.frame_rate}")
        if not self.latency >= 0:
            raise ResusError(f"{where}.latency must be >= 0, got {self.latency}")


class SimulatedProbe(SyntheticProbe):
    """Synthetic ultrasound of the scene's phantom at the robot's reported TCP pose, through
    the settings' persistence (frame averaging; the labels are those of the frame's own pose).

    The robot may be the in-process MuJoCo arm or any other `Robot` on the same scene (e.g.
    `RTDERobot` talking to the emulator), since the probe only reads its TCP pose and clock.
    """

    def __init__(
        self,
        robot: Robot,
        config: SimulatedProbeConfig | None = None,
        phantom: Phantom | None = None,
        scene: SceneConfig | None = None,
    ) -> None:
        """`scene` defaults to the simulated robot's; `phantom` overrides the scene's (e.g.
        another seed), with the same body."""
        self.robot = robot
        self.config = config or SimulatedProbeConfig()
        if scene is None:
            if not isinstance(robot, SimulatedRobot):
                raise TypeError("SimulatedProbe needs a scene unless its robot is a SimulatedRobot")
            scene = robot.scene
        self.scene = scene
        self.phantom = phantom or Phantom(load_scene_phantom(self.scene))
        self._base_to_phantom = invert_pose(self.scene.phantom_to_base)
        self.simulator = UltrasoundSimulator(self.phantom, self.config.probe, self.config.settings)
        self.persistence = Persistence(self.config.settings.persistence)
        self.geometry = self.config.probe
        self._next_frame_time = robot.time()
        self._in_flight: list[tuple[float, Frame]] = []

    def poll(self) -> list[Frame]:
        """Take a frame if one is due at the robot's present time; deliver those now late enough."""
        now = self.robot.time()
        if now >= self._next_frame_time - 1e-9:
            image, label = self.simulator.render(
                self._base_to_phantom @ self.robot.tcp_pose(), self._load(now)
            )
            frame = Frame(now + self.config.clock_offset, self.persistence(image), label)
            self._in_flight.append((now + self.config.latency, frame))
            self._next_frame_time = max(self._next_frame_time + 1 / self.config.frame_rate, now)
        delivered = [frame for due, frame in self._in_flight if due <= now + 1e-9]
        self._in_flight = [(due, frame) for due, frame in self._in_flight if due > now + 1e-9]
        return delivered

    def _load(self, now: float) -> TissueLoad | None:
        """What deforms the tissue in the frame taken now: the contact force the robot
        measures along the probe axis (the force the Sweep records) at the robot's time."""
        if self.config.rigid or self.simulator.deformation is None:
            return None
        return TissueLoad(self.robot.probe_force(), now)
