"""UR force mode as an admittance controller on the wrist force/torque reading.

Along the selected (compliant) axes of the task frame the TCP moves at a velocity proportional
to the force error, `v = (F_target - F_measured) / damping`, capped at the axis's speed limit;
along the other axes it follows the position reference of the running motion command. Forces
are UR's: the wrench the robot exerts on the environment. Only UR's force-mode type 2 (task
frame used as given) and translational compliance are simulated. Force mode sent again while
it is on (a new setpoint, as a force profile does every few cycles) continues from where the
last one left the TCP and its force filter, as UR's does: no jump, no ringing.
"""

from __future__ import annotations

import numpy as np

FORCE_MODE_TYPE_FIXED_FRAME = 2
DEFAULT_DAMPING = 400.0
"""Admittance damping (N s/m): 5 N of error moves the TCP at 12.5 mm/s."""
FORCE_FILTER_TIME = 0.01
"""Time constant (s) of the low-pass on the measured force. The servos' damping makes the
sensed force answer a reference velocity change at once; without the filter that loop rings
at half the control rate."""


class ForceModeController:
    """Admittance along the compliant axes of a task frame fixed in the base frame."""

    def __init__(
        self,
        task_frame: np.ndarray,
        selection_vector: np.ndarray,
        wrench: np.ndarray,
        limits: np.ndarray,
        start_position: np.ndarray,
        damping: float = DEFAULT_DAMPING,
        previous: ForceModeController | None = None,
    ) -> None:
        """`previous`: the force mode this one replaces, whose reference position (instead of
        `start_position`) and filtered force it continues."""
        self.rotation = task_frame[:3, :3].copy()
        self.selected = selection_vector[:3].astype(bool)
        self.force = wrench[:3].copy()
        self.speed_limits = limits[:3].copy()
        self.damping = damping
        self.reference_position = start_position.copy()
        """Base-frame TCP position of the last reference (the start until the first)."""
        self.filtered_force: np.ndarray | None = None
        if previous is not None:
            self.reference_position = previous.reference_position.copy()
            if previous.filtered_force is not None:
                world = previous.rotation @ previous.filtered_force
                self.filtered_force = self.rotation.T @ world
        self.compliant_position = self.rotation.T @ self.reference_position

    def reference_pose(
        self, nominal: np.ndarray, measured_wrench: np.ndarray, dt: float
    ) -> np.ndarray:
        """The TCP reference: `nominal`, with compliant axes moved by the admittance law."""
        measured = self.rotation.T @ measured_wrench[:3]
        if self.filtered_force is None:
            self.filtered_force = measured
        self.filtered_force = self.filtered_force + dt / (FORCE_FILTER_TIME + dt) * (
            measured - self.filtered_force
        )
        measured = self.filtered_force
        velocity = np.clip(
            (self.force - measured) / self.damping, -self.speed_limits, self.speed_limits
        )
        self.compliant_position += np.where(self.selected, velocity * dt, 0.0)
        task = np.where(self.selected, self.compliant_position, self.rotation.T @ nominal[:3, 3])
        pose = nominal.copy()
        pose[:3, 3] = self.rotation @ task
        self.reference_position = pose[:3, 3].copy()
        return pose


def check_force_mode_arguments(
    task_frame: np.ndarray,
    selection_vector: np.ndarray,
    wrench: np.ndarray,
    force_type: int,
    limits: np.ndarray,
) -> None:
    """Raise ValueError naming the argument that force mode cannot use."""
    if task_frame.shape != (4, 4) or not np.isfinite(task_frame).all():
        raise ValueError("force_mode task_frame must be a finite 4x4 pose in the base frame")
    if selection_vector.shape != (6,) or not np.isin(selection_vector, (0, 1)).all():
        raise ValueError(
            f"force_mode selection_vector must be six 0/1 flags, got {selection_vector}"
        )
    if selection_vector[3:].any():
        raise ValueError("force_mode selection_vector: rotational compliance is not simulated")
    if wrench.shape != (6,) or not np.isfinite(wrench).all():
        raise ValueError(f"force_mode wrench must be six finite numbers, got {wrench}")
    if force_type != FORCE_MODE_TYPE_FIXED_FRAME:
        raise ValueError(f"force_mode type must be 2 (task frame as given), got {force_type}")
    if limits.shape != (6,) or not (limits[:3][selection_vector[:3] == 1] > 0).all():
        raise ValueError(
            f"force_mode limits must be six numbers, positive on compliant axes: {limits}"
        )
