"""A scan in rerun, frame by frame: live from a scanner, or a recorded Sweep replayed.

`SweepLogger.append` takes the same arguments as `SweepWriter.append`, so whatever writes a
Sweep frame can log it too. Per frame it logs, on the timelines "frame" (number) and "time"
(seconds): the frame as a textured quad at its true place and size, the frame with its labels
(and a prediction) in 2D, the tracked probe pose, the robot's body poses from its joints, and
the force, torque and joint time series. `log_sweep` sends a whole Sweep the same way, with
poses and time series sent as columns in bulk.
"""

from __future__ import annotations

import numpy as np
import rerun as rr
from tqdm import tqdm

from resus.sweep.model import Sweep, SweepFrame
from resus.visualize import entities as at
from resus.visualize.quads import textured_quad
from resus.visualize.robot import log_robot_shapes, send_robot_poses
from resus.visualize.transforms import pose_columns
from sim.labels import LABEL_NAMES
from sim.robot.kinematics import JOINT_NAMES

PROBE_AXIS_LENGTH = 0.02
"""Length of the drawn probe axes (m): x red along the array, z blue into the tissue."""
FORCE_NAMES = ("Fx", "Fy", "Fz")
TORQUE_NAMES = ("Tx", "Ty", "Tz")


class SweepLogger:
    """Logs frames of one scan to `stream` as they come; static parts are logged on creation."""

    def __init__(
        self,
        stream: rr.RecordingStream,
        image_to_probe: np.ndarray,
        label_names: tuple[str, ...] = LABEL_NAMES,
        *,
        robot: bool = True,
    ) -> None:
        """`robot`: draw the UR3e from the joint positions given with each frame."""
        self.stream = stream
        self.image_to_probe = np.asarray(image_to_probe, dtype=np.float64)
        self.count = 0
        """Frames logged so far (the next frame's number)."""
        self.robot = robot
        self._robot_shapes_logged = False
        stream.log(at.FRAME_2D, at.annotation_context(label_names), static=True)
        stream.log(at.WORLD, rr.ViewCoordinates.RIGHT_HAND_Z_UP, static=True)
        stream.log(at.PROBE, rr.TransformAxes3D(PROBE_AXIS_LENGTH), static=True)
        for path, names in ((at.FORCE, FORCE_NAMES), (at.TORQUE, TORQUE_NAMES)):
            stream.log(path, rr.SeriesLines(names=names), static=True)
        stream.log(at.JOINTS, rr.SeriesLines(names=JOINT_NAMES), static=True)

    def append(self, frame: SweepFrame, prediction: np.ndarray | None = None) -> None:
        """Log one recorded frame (and optionally a model's labels for it)."""

        def row(value: np.ndarray | None) -> np.ndarray | None:
            return None if value is None else np.asarray(value)[None]

        self.log_frames(
            np.asarray(frame.image)[None], np.asarray(frame.probe_to_base)[None],
            np.array([frame.timestamp], dtype=np.float64),
            labels=row(frame.label), wrench=row(frame.wrench),
            joint_positions=row(frame.joint_positions), predictions=row(prediction),
        )  # fmt: skip

    def log_frames(
        self,
        frames: np.ndarray,
        probe_to_base: np.ndarray,
        timestamps: np.ndarray,
        *,
        labels: np.ndarray | None = None,
        wrench: np.ndarray | None = None,
        joint_positions: np.ndarray | None = None,
        predictions: np.ndarray | None = None,
        progress: bool = False,
    ) -> None:
        """Log K frames (K, H, W) with their (K, 4, 4) poses and (K,) times; optional (K, ...)
        labels, predictions, wrenches (N, N m) and joints (rad). Poses and series go in bulk."""
        count = len(frames)
        numbers = np.arange(self.count, self.count + count)
        indexes = [
            rr.TimeColumn(at.FRAME, sequence=numbers),
            rr.TimeColumn(at.TIME, duration=np.asarray(timestamps, dtype=np.float64)),
        ]
        poses = np.asarray(probe_to_base, dtype=np.float64)
        self.stream.send_columns(at.PROBE, indexes=indexes, columns=pose_columns(poses))
        if wrench is not None:
            wrench = np.asarray(wrench, dtype=np.float64)
            self.stream.send_columns(at.FORCE, indexes, rr.Scalars.columns(scalars=wrench[:, :3]))
            self.stream.send_columns(at.TORQUE, indexes, rr.Scalars.columns(scalars=wrench[:, 3:]))
        if joint_positions is not None:
            joints = np.asarray(joint_positions, dtype=np.float64)
            self.stream.send_columns(at.JOINTS, indexes, rr.Scalars.columns(scalars=joints))
            if self.robot:
                if not self._robot_shapes_logged:
                    log_robot_shapes(self.stream)
                    self._robot_shapes_logged = True
                send_robot_poses(self.stream, indexes, joints)
        for k in tqdm(range(count), desc="rerun", unit="frame", disable=not progress):
            self.stream.set_time(at.FRAME, sequence=int(numbers[k]))
            self.stream.set_time(at.TIME, duration=float(timestamps[k]))
            label = None if labels is None else labels[k]
            self.stream.log(
                at.FRAME_QUAD, textured_quad(poses[k] @ self.image_to_probe, frames[k], label)
            )
            self.stream.log(f"{at.FRAME_2D}/image", rr.Image(frames[k]))
            if label is not None:
                self.stream.log(
                    f"{at.FRAME_2D}/labels", rr.SegmentationImage(label, opacity=at.LABEL_OPACITY)
                )
            if predictions is not None:
                self.stream.log(
                    f"{at.FRAME_2D}/prediction",
                    rr.SegmentationImage(predictions[k], opacity=at.LABEL_OPACITY),
                )
        self.stream.reset_time()
        self.count += count


def log_sweep(
    stream: rr.RecordingStream,
    sweep: Sweep,
    *,
    predictions: np.ndarray | None = None,
    robot: bool = True,
    progress: bool = False,
) -> SweepLogger:
    """Log a whole recorded Sweep (and optional (N, H, W) predicted labels) plus the probe's
    path; returns the logger, so that more frames can follow."""
    logger = SweepLogger(stream, sweep.image_to_probe, sweep.label_names, robot=robot)
    stream.log(at.PROBE_PATH, rr.LineStrips3D([sweep.probe_to_base[:, :3, 3]]), static=True)
    logger.log_frames(
        sweep.frames, sweep.probe_to_base, sweep.timestamps, labels=sweep.labels,
        wrench=sweep.wrench, joint_positions=sweep.joint_positions, predictions=predictions,
        progress=progress,
    )  # fmt: skip
    return logger
