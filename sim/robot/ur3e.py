"""A simulated UR3e with a UR controller's command set, stepping MuJoCo at 500 Hz.

Vocabulary follows ur_rtde (moveL -> `move_linear`, servoL -> `servo_linear`, forceMode ->
`force_mode`, getActualTCPPose -> `tcp_pose`, ...), with 4x4 poses instead of UR's rotation-vector
lists. Blocking commands step the simulation until they finish, as fast as the machine allows;
streaming commands (servo, speed) set a target and `step()` advances one control period.

Control: every period the running motion yields a joint reference (Cartesian ones through the
analytic inverse kinematics); force mode, when on, first moves the TCP reference along its
compliant axes. Position actuators track the reference with velocity feed-forward (the control
input is `q_ref + kv / kp * qd_ref`), gravity is compensated through the actuators, and torques
are limited to UR's joint torque limits. Sustained torque saturation or a contact force above
`force_limit` puts the robot in a protective stop: it holds still and refuses motion commands
until `unlock_protective_stop()`.
"""

from __future__ import annotations

import math

import mujoco
import numpy as np
from numba import njit

from sim.phantom import Phantom
from sim.robot import kinematics
from sim.robot.force_mode import (
    DEFAULT_DAMPING,
    FORCE_MODE_TYPE_FIXED_FRAME,
    ForceModeController,
    check_force_mode_arguments,
)
from sim.robot.motions import (
    JOINT,
    LINEAR,
    CartesianVelocity,
    JointDeceleration,
    JointPath,
    LinearPath,
    Motion,
    Servo,
)
from sim.robot.scene import build_scene, load_scene_phantom
from sim.robot.scene_config import SceneConfig
from sim.transforms import invert_pose, is_rigid
from sim.ultrasound.skin_pose import probe_pose_on_skin

CONTROL_PERIOD = 0.002
"""UR e-Series controller period (500 Hz)."""
HOME_JOINTS = np.array([0.0, -math.pi / 2, math.pi / 2, -math.pi / 2, -math.pi / 2, 0.0])
"""Tool pointing down, about 0.3 m in front of the base."""
GRAVITY = np.array([0.0, 0.0, -9.81])
DEFAULT_FORCE_LIMIT = 50.0
"""Contact force (N) above which the robot stops protectively."""
STEADY_SPEED = 1e-3
"""Joint speed (rad/s) below which a robot with no running command counts as steady."""
STOP_SETTLE_TIME = 1.0
"""Longest wait (s) for the servos to come to rest after a stop's reference has stopped."""
TORQUE_SATURATION_TIME = 0.02
"""How long a joint may demand more than its torque limit before a protective stop (s)."""


class ProtectiveStopError(RuntimeError):
    """The robot is in a protective stop; motion commands are refused until it is unlocked."""


class SimulatedUR3e:
    """The MuJoCo UR3e with its probe in a scene, driven like a UR controller."""

    def __init__(
        self,
        scene: SceneConfig | None = None,
        *,
        initial_joints: np.ndarray = HOME_JOINTS,
        force_limit: float = DEFAULT_FORCE_LIMIT,
        force_mode_damping: float = DEFAULT_DAMPING,
    ) -> None:
        self.scene = SceneConfig() if scene is None else scene
        self.phantom = Phantom(load_scene_phantom(self.scene))
        """The scanned phantom (`sim.phantom.Phantom`), its frame at `phantom_to_base`."""
        self.model = build_scene(self.scene, self.phantom.spec.body)
        self.data = mujoco.MjData(self.model)
        self.force_limit = force_limit
        self.force_mode_damping = force_mode_damping
        self._substeps = max(1, round(CONTROL_PERIOD / self.model.opt.timestep))
        self._kp = self.model.actuator_gainprm[:6, 0].copy()
        self._kv = -self.model.actuator_biasprm[:6, 2].copy()
        self._sensor_site = self.model.site("ft_sensor").id
        probe = self.model.body("probe").id
        self._payload_mass = float(self.model.body_mass[probe])
        self._payload_com = self.model.body_ipos[probe].copy()
        self._ft_force_adr = self.model.sensor("ft_force").adr[0]
        self._ft_torque_adr = self.model.sensor("ft_torque").adr[0]
        self._model_tcp = self._model_flange_to_tcp()
        self.reset(initial_joints)

    # ----------------------------------------------------------------- state and reading

    def reset(self, joints: np.ndarray = HOME_JOINTS) -> None:
        """Put the robot at rest at `joints`: time 0, no command, the probe's TCP, sensor
        unzeroed, no protective stop."""
        joints = _checked_joints(joints, "reset")
        mujoco.mj_resetData(self.model, self.data)
        self.data.qpos[:6] = joints
        self.data.ctrl[:6] = joints
        mujoco.mj_forward(self.model, self.data)
        self.set_tcp(self._model_tcp)
        self._q_ref = joints.copy()
        self._qd_ref = np.zeros(6)
        self._motion: Motion | None = None
        self._force_mode: ForceModeController | None = None
        self._wrench_offset = np.zeros(6)
        self._saturated_time = np.zeros(6)
        self._protective_stop_reason: str | None = None
        self._wrench = self._compensated_wrench()

    def time(self) -> float:
        """Simulated time (s) since reset."""
        return float(self.data.time)

    def joint_positions(self) -> np.ndarray:
        """Actual joint angles (rad), like getActualQ."""
        return self.data.qpos[:6].copy()

    def joint_velocities(self) -> np.ndarray:
        """Actual joint velocities (rad/s), like getActualQd."""
        return self.data.qvel[:6].copy()

    def flange_pose(self) -> np.ndarray:
        """Actual flange (tool0) pose in the base frame, 4x4."""
        return kinematics.forward_kinematics(self.data.qpos[:6])

    def tcp_pose(self) -> np.ndarray:
        """Actual TCP pose in the base frame, 4x4 (getActualTCPPose)."""
        return self.flange_pose() @ self._flange_to_tcp

    def tcp_velocity(self) -> np.ndarray:
        """Actual TCP velocity [vx, vy, vz, wx, wy, wz] in the base frame (getActualTCPSpeed)."""
        return kinematics.jacobian(self.data.qpos[:6], self._flange_to_tcp) @ self.data.qvel[:6]

    def target_joint_positions(self) -> np.ndarray:
        """The controller's joint reference (rad), like getTargetQ."""
        return self._q_ref.copy()

    def target_tcp_pose(self) -> np.ndarray:
        """TCP pose of the joint reference, base frame 4x4 (getTargetTCPPose)."""
        return self._reference_tcp_pose()

    @property
    def phantom_to_base(self) -> np.ndarray:
        """Pose of the phantom frame in the base frame, 4x4."""
        return self.scene.phantom_to_base.copy()

    def probe_pose_on_skin(
        self, x: float, y: float, lift: float = 0.0, rotation: float = 0.0, tilt: float = 0.0
    ) -> np.ndarray:
        """Base-frame TCP pose with the probe face on the phantom's skin above phantom point
        (x, y), lifted `lift` m off it (see `sim.ultrasound.skin_pose.probe_pose_on_skin`)."""
        on_skin = probe_pose_on_skin(self.phantom, x, y, rotation=rotation, tilt=tilt, lift=lift)
        return self.scene.phantom_to_base @ on_skin

    def tcp_pose_in_phantom(self) -> np.ndarray:
        """Actual TCP pose in the phantom frame, 4x4."""
        return invert_pose(self.scene.phantom_to_base) @ self.tcp_pose()

    def tcp_wrench(self) -> np.ndarray:
        """Wrench the robot exerts on the environment at the TCP (getActualTCPForce).

        Base frame, [Fx, Fy, Fz, Tx, Ty, Tz] in N and N m, probe weight compensated, minus the
        offset taken by `zero_ft_sensor()`.
        """
        return self._wrench - self._wrench_offset

    def get_tcp(self) -> np.ndarray:
        """The TCP offset: pose of the TCP in the flange frame, 4x4."""
        return self._flange_to_tcp.copy()

    def is_protective_stopped(self) -> bool:
        """True while the robot is in a protective stop."""
        return self._protective_stop_reason is not None

    @property
    def protective_stop_reason(self) -> str | None:
        """Why the robot stopped, or None."""
        return self._protective_stop_reason

    def is_steady(self) -> bool:
        """True when no motion command runs and every joint is (nearly) at rest."""
        return self._motion is None and float(np.abs(self.data.qvel[:6]).max()) < STEADY_SPEED

    def in_force_mode(self) -> bool:
        """True while force mode is on."""
        return self._force_mode is not None

    # ----------------------------------------------------------------- configuration

    def set_tcp(self, flange_to_tcp: np.ndarray) -> None:
        """Set the TCP offset (setTcp): pose of the TCP in the flange frame, 4x4."""
        flange_to_tcp = np.asarray(flange_to_tcp, dtype=np.float64)
        if flange_to_tcp.shape != (4, 4) or not is_rigid(flange_to_tcp):
            raise ValueError("set_tcp needs a rigid 4x4 pose of the TCP in the flange frame")
        self._flange_to_tcp = flange_to_tcp.copy()
        self._tcp_to_flange = invert_pose(flange_to_tcp)

    def zero_ft_sensor(self) -> None:
        """Take the present wrench reading as zero (zeroFtSensor)."""
        self._wrench_offset = self._wrench.copy()

    def unlock_protective_stop(self) -> None:
        """Leave the protective stop (the dashboard's unlock); the robot stays where it is."""
        self._protective_stop_reason = None
        self._saturated_time[:] = 0.0

    # ----------------------------------------------------------------- motion commands

    def move_joint(
        self,
        joints: np.ndarray,
        speed: float = 1.05,
        acceleration: float = 1.4,
        asynchronous: bool = False,
    ) -> None:
        """moveJ: joint-space trapezoidal move to `joints` (rad; speed rad/s, accel rad/s^2)."""
        self._check_ready()
        joints = _checked_joints(joints, "move_joint")
        self._motion = JointPath(self._q_ref, joints, speed, acceleration, self.time())
        if not asynchronous:
            self._run_motion()

    def move_linear(
        self,
        pose: np.ndarray,
        speed: float = 0.25,
        acceleration: float = 1.2,
        asynchronous: bool = False,
    ) -> None:
        """moveL: straight-line TCP move to `pose` (base frame 4x4; m/s, m/s^2).

        The whole path is checked for reachability (every 5 mm and 0.02 rad) before the robot
        moves; the tool's rotation is limited to 1 rad/s (see `motions.LinearPath`).
        """
        self._check_ready()
        goal = self._check_pose(pose, "move_linear")
        path = LinearPath(self._reference_tcp_pose(), goal, speed, acceleration, self.time())
        seed = self._q_ref
        steps = np.linalg.norm(path.translation) / 0.005 + np.linalg.norm(path.rotvec) / 0.02
        for u in np.linspace(0.0, 1.0, math.ceil(steps) + 2):
            joints = self._inverse(path.pose_at_fraction(u), seed)
            if joints is None:
                raise ValueError(f"move_linear: the path leaves the workspace at fraction {u:.2f}")
            seed = joints
        self._motion = path
        if not asynchronous:
            self._run_motion()

    def servo_joint(
        self, joints: np.ndarray, time: float = CONTROL_PERIOD, lookahead_time: float = 0.1
    ) -> None:
        """servoJ: stream a joint target, reached over `time`, smoothed by `lookahead_time`."""
        self._check_ready()
        joints = _checked_joints(joints, "servo_joint")
        self._servo_command(JOINT, joints, time, lookahead_time)

    def servo_linear(
        self, pose: np.ndarray, time: float = CONTROL_PERIOD, lookahead_time: float = 0.1
    ) -> None:
        """servoL: stream a TCP pose target (base frame 4x4), smoothed in tool space (the RTDE
        emulator's servo, `motions.Servo`); joints by inverse kinematics every period."""
        self._check_ready()
        goal = self._check_pose(pose, "servo_linear")
        if self._inverse(goal, self._q_ref) is None:
            raise ValueError("servo_linear: target pose is out of reach")
        self._servo_command(LINEAR, goal, time, lookahead_time)

    def speed_linear(self, velocity: np.ndarray, acceleration: float = 0.25) -> None:
        """speedL: TCP velocity [vx, vy, vz, wx, wy, wz] (m/s, rad/s, base frame), held until
        another command; it ramps at `acceleration` (m/s^2 and rad/s^2)."""
        self._check_ready()
        velocity = np.asarray(velocity, dtype=np.float64)
        if velocity.shape != (6,) or not np.isfinite(velocity).all():
            raise ValueError(f"speed_linear velocity must be six finite numbers, got {velocity}")
        if not acceleration > 0:
            raise ValueError(f"speed_linear acceleration must be positive, got {acceleration}")
        if not isinstance(self._motion, CartesianVelocity):
            self._motion = CartesianVelocity(self._reference_tcp_pose())
        self._motion.command(velocity, acceleration)

    def stop(self, deceleration: float = 2.0) -> None:
        """Brake every joint from its present reference speed at `deceleration` (rad/s^2)
        and wait until the robot is at rest (stopJ; also ends servo and speed commands)."""
        if not deceleration > 0:
            raise ValueError(f"stop deceleration must be positive, got {deceleration}")
        if self._protective_stop_reason is not None:
            return  # already stopped and holding
        self._motion = JointDeceleration(self._q_ref, self._qd_ref, deceleration)
        self._run_motion()
        settle_end = self.time() + STOP_SETTLE_TIME
        while not self.is_steady() and self.time() < settle_end:
            self._control_period()

    def force_mode(
        self,
        task_frame: np.ndarray,
        selection_vector: np.ndarray,
        wrench: np.ndarray,
        force_type: int = FORCE_MODE_TYPE_FIXED_FRAME,
        limits: np.ndarray | tuple[float, ...] = (0.1, 0.1, 0.1, 0.1, 0.1, 0.1),
    ) -> None:
        """forceMode: be compliant along the selected task-frame axes, pushing `wrench`.

        `task_frame` is a base-frame 4x4 pose; `selection_vector` six 0/1 flags (translations
        only); `wrench` the force to exert on the environment (N, task frame); `limits` the
        maximum TCP speed along compliant axes (m/s). Other axes follow motion commands.
        Sent again while force mode is on, it continues from the present reference (a new
        setpoint mid-press).
        """
        self._check_ready()
        task_frame = np.asarray(task_frame, dtype=np.float64)
        selection_vector = np.asarray(selection_vector)
        wrench = np.asarray(wrench, dtype=np.float64)
        limits = np.asarray(limits, dtype=np.float64)
        check_force_mode_arguments(task_frame, selection_vector, wrench, force_type, limits)
        self._force_mode = ForceModeController(
            task_frame, selection_vector, wrench, limits, self._reference_tcp_pose()[:3, 3],
            self.force_mode_damping, previous=self._force_mode,
        )  # fmt: skip

    def force_mode_stop(self) -> None:
        """forceModeStop: leave force mode and any motion; the robot holds its reference."""
        self._force_mode = None
        self._motion = None

    # ----------------------------------------------------------------- stepping

    def step(self, periods: int = 1) -> None:
        """Advance `periods` control periods (2 ms each)."""
        for _ in range(periods):
            self._control_period()

    def _run_motion(self) -> None:
        while self._motion is not None:
            self._control_period()
            if self._protective_stop_reason is not None:
                raise ProtectiveStopError(f"protective stop: {self._protective_stop_reason}")

    def _control_period(self) -> None:
        t = self.time()
        nominal, finished = self._nominal_reference(t)
        reference = nominal
        if self._force_mode is not None and nominal is not None:
            if nominal.shape == (6,):
                nominal = kinematics.forward_kinematics(nominal) @ self._flange_to_tcp
            reference = self._force_mode.reference_pose(nominal, self.tcp_wrench(), CONTROL_PERIOD)
        if reference is not None and reference.shape == (4, 4):
            reference = self._inverse(reference, self._q_ref)
            if reference is None:
                self._protect("inverse kinematics failed: the reference left the workspace")
        if reference is not None:
            step_limit = kinematics.JOINT_SPEED_LIMITS * CONTROL_PERIOD
            change = np.clip(reference - self._q_ref, -step_limit, step_limit)
            self._qd_ref = change / CONTROL_PERIOD
            self._q_ref = self._q_ref + change
        else:
            self._qd_ref = np.zeros(6)
        if finished:
            self._motion = None
        self.data.ctrl[:6] = self._q_ref + self._kv / self._kp * self._qd_ref
        for _ in range(self._substeps):
            mujoco.mj_step(self.model, self.data)
        self._wrench = self._compensated_wrench()
        self._check_safety()

    def _nominal_reference(self, t: float) -> tuple[np.ndarray | None, bool]:
        """The running motion's reference (6 joints or a 4x4 TCP pose) and whether it ends.

        With no motion the reference holds, and force mode still moves it along its axes."""
        if self._motion is None:
            return (self._q_ref if self._force_mode is not None else None), False
        return self._motion.reference(t, CONTROL_PERIOD)

    # ----------------------------------------------------------------- safety

    def _check_safety(self) -> None:
        if self._protective_stop_reason is not None:
            return
        force = float(np.linalg.norm(self.tcp_wrench()[:3]))
        if force > self.force_limit:
            self._protect(f"TCP force {force:.1f} N exceeds the limit {self.force_limit:.1f} N")
            return
        demand = self._torque_demand()
        over = np.abs(demand) > kinematics.JOINT_TORQUE_LIMITS
        self._saturated_time = np.where(over, self._saturated_time + CONTROL_PERIOD, 0.0)
        if (self._saturated_time >= TORQUE_SATURATION_TIME).any():
            joint = int(np.argmax(self._saturated_time))
            self._protect(
                f"joint {kinematics.JOINT_NAMES[joint]} needs {demand[joint]:.1f} N m, beyond its "
                f"limit {kinematics.JOINT_TORQUE_LIMITS[joint]:.0f} N m"
            )

    def _torque_demand(self) -> np.ndarray:
        """Joint torques the servos ask for before the torque limits clip them (N m)."""
        q, qd = self.data.qpos[:6], self.data.qvel[:6]
        servo = self._kp * (self.data.ctrl[:6] - q) - self._kv * qd
        return servo + self.data.qfrc_gravcomp[:6]

    def _protect(self, reason: str) -> None:
        """Enter a protective stop: drop force mode and hold the actual joint positions."""
        self._protective_stop_reason = reason
        self._force_mode = None
        self._motion = None
        self._q_ref = self.data.qpos[:6].copy()
        self._qd_ref = np.zeros(6)

    def _check_ready(self) -> None:
        if self._protective_stop_reason is not None:
            raise ProtectiveStopError(
                f"robot is in a protective stop ({self._protective_stop_reason}); "
                "call unlock_protective_stop() first"
            )

    # ----------------------------------------------------------------- helpers

    def _servo_command(
        self, space: str, target: np.ndarray, time: float, lookahead_time: float
    ) -> None:
        if not time > 0 or not lookahead_time >= 0:
            raise ValueError(
                f"servo time must be > 0 and lookahead_time >= 0, got {time}, {lookahead_time}"
            )
        if not (isinstance(self._motion, Servo) and self._motion.space == space):
            start = self._q_ref if space == JOINT else self._reference_tcp_pose()
            self._motion = Servo(space, start)
        self._motion.command(target, time, lookahead_time)

    def _check_pose(self, pose: np.ndarray, command: str) -> np.ndarray:
        pose = np.asarray(pose, dtype=np.float64)
        if pose.shape != (4, 4) or not np.isfinite(pose).all():
            raise ValueError(f"{command} pose must be a finite 4x4 TCP pose in the base frame")
        return pose

    def _inverse(self, tcp_pose: np.ndarray, seed: np.ndarray) -> np.ndarray | None:
        """Joints for a TCP pose nearest to `seed`, or None when out of reach."""
        return kinematics.inverse_kinematics(tcp_pose @ self._tcp_to_flange, seed)

    def _reference_tcp_pose(self) -> np.ndarray:
        return kinematics.forward_kinematics(self._q_ref) @ self._flange_to_tcp

    def _model_flange_to_tcp(self) -> np.ndarray:
        mujoco.mj_kinematics(self.model, self.data)
        flange, tcp = self.model.site("flange").id, self.model.site("tcp").id
        poses = []
        for site in (flange, tcp):
            pose = np.eye(4)
            pose[:3, :3] = self.data.site_xmat[site].reshape(3, 3)
            pose[:3, 3] = self.data.site_xpos[site]
            poses.append(pose)
        return invert_pose(poses[0]) @ poses[1]

    def _compensated_wrench(self) -> np.ndarray:
        """Wrench on the environment at the TCP (base frame) from the wrist F/T sensor."""
        force = self.data.sensordata[self._ft_force_adr : self._ft_force_adr + 3]
        torque = self.data.sensordata[self._ft_torque_adr : self._ft_torque_adr + 3]
        return _contact_wrench(
            self.data.site_xmat[self._sensor_site].reshape(3, 3),
            self.data.site_xpos[self._sensor_site],
            force,
            torque,
            self._payload_mass,
            self._payload_com,
            self.tcp_pose()[:3, 3],
        )


def _checked_joints(joints: np.ndarray, command: str) -> np.ndarray:
    """Six finite joint angles inside the limits, or a ValueError naming the command."""
    joints = np.asarray(joints, dtype=np.float64)
    if (
        joints.shape != (6,)
        or not np.isfinite(joints).all()
        or not kinematics.within_limits(joints)
    ):
        raise ValueError(
            f"{command}: joints must be 6 angles (rad) within the limits, got {joints}"
        )
    return joints


@njit(cache=True)
def _cross(a: np.ndarray, b: np.ndarray) -> np.ndarray:
    return np.array(
        [a[1] * b[2] - a[2] * b[1], a[2] * b[0] - a[0] * b[2], a[0] * b[1] - a[1] * b[0]]
    )


@njit(cache=True)
def _contact_wrench(
    rotation: np.ndarray,
    site: np.ndarray,
    sensed_force: np.ndarray,
    sensed_torque: np.ndarray,
    payload_mass: float,
    payload_com: np.ndarray,
    tcp: np.ndarray,
) -> np.ndarray:
    """MuJoCo's force/torque sensors give the wrist's wrench on the probe at the sensor site,
    in the site frame. Adding the probe's weight (the payload the controller knows) leaves the
    wrench the probe exerts on the environment; it is returned in the base frame, about the
    TCP."""
    weight = payload_mass * GRAVITY
    force = rotation @ sensed_force + weight
    torque = rotation @ sensed_torque + _cross(rotation @ payload_com, weight)
    out = np.empty(6)
    out[:3] = force
    out[3:] = torque + _cross(site - tcp, force)
    return out
