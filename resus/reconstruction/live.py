"""Live reconstruction during a scan: every recorded frame compounded into a coarse volume,
logged to rerun every few frames so the volume grows in the viewer as the probe moves.

`LiveVolume` is a scanner listener (it takes frames the way `SweepWriter.append` does). It
runs inside the scanner's control loop, so it is kept cheap: a coarse axis-aligned grid
around the planned frames, no hole filling, and the volume logged only every `every` frames.
"""

from __future__ import annotations

import numpy as np
import rerun as rr

from resus.acquisition.trajectory import Trajectory
from resus.reconstruction.compounding import ReconstructionSettings, Reconstructor
from resus.reconstruction.grid import VolumeGrid, aabb_grid, frame_corner_pixels, frame_points_world
from resus.sweep.model import SweepFrame
from resus.visualize.volume import log_volume

PLAN_SAMPLES = 200
"""Poses sampled along the plan to bound the volume."""
MARGIN = 0.005
"""Padding around the planned frames (m): force mode presses the probe into the tissue."""


def planned_grid(
    trajectory: Trajectory,
    image_to_probe: np.ndarray,
    frame_shape: tuple[int, int],
    voxel_size: float,
) -> VolumeGrid:
    """Axis-aligned grid of `voxel_size` around every frame the plan would take, plus MARGIN."""
    poses = trajectory.poses_at(np.linspace(0.0, trajectory.duration, PLAN_SAMPLES))
    corners = frame_points_world(poses, image_to_probe, frame_corner_pixels(*frame_shape))
    low = corners.reshape(-1, 3).min(axis=0) - MARGIN
    high = corners.reshape(-1, 3).max(axis=0) + MARGIN
    return aabb_grid(voxel_size, bounds=(low, high))


class LiveVolume:
    """Compounds each recorded frame (and its labels) and logs the volume every `every`."""

    def __init__(
        self,
        stream: rr.RecordingStream,
        grid: VolumeGrid,
        image_to_probe: np.ndarray,
        *,
        n_classes: int = 0,
        every: int = 30,
    ) -> None:
        """`n_classes` counts label classes with background (0: frames carry no labels)."""
        self.stream = stream
        self.every = max(1, every)
        settings = ReconstructionSettings(fill_passes=0)
        self.reconstructor = Reconstructor(grid, image_to_probe, settings, n_classes)
        # The compounding kernel compiles on its first call: seconds on a cold numba cache,
        # which in the control loop would stall the scan while the robot moves on. A black
        # frame into a throwaway reconstructor of one voxel (not a second copy of the volume)
        # compiles it now, before the scan starts.
        blank = np.zeros((2, 2), dtype=np.uint8)
        one_voxel = aabb_grid(float(grid.spacing.min()), bounds=(np.zeros(3), np.zeros(3)))
        warm_up = Reconstructor(one_voxel, image_to_probe, settings, n_classes)
        warm_up.add_frame(blank, np.eye(4), blank if n_classes else None)
        self.logged = 0
        """How many times the volume was logged."""
        self._logged_frames = 0

    def append(self, frame: SweepFrame) -> None:
        """Compound one frame; log the volume when `every` more frames have come in."""
        labels = frame.label if self.reconstructor.n_classes else None
        self.reconstructor.add_frame(frame.image, frame.probe_to_base, labels)
        if self.reconstructor.n_frames % self.every == 0:
            self.log()

    def log(self) -> None:
        """Log the volume so far (static: the viewer shows the latest); nothing when no frame
        came in since the last time."""
        if self.reconstructor.n_frames == self._logged_frames:
            return
        self._logged_frames = self.reconstructor.n_frames
        result = self.reconstructor.result(fill_holes=False)
        log_volume(self.stream, result.volume, result.grid, result.labels)
        self.logged += 1
