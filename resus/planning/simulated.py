"""Run a plan in the simulator and measure the reconstruction it really gives.

The recorded frames are matched to the plan by pose (nearest planned sample, rotation counted
at the trajectory's rotation radius) to tell imaging frames from turnaround frames; the
imaging frames are reconstructed with the real SDW kernel and no hole filling on the grid the
estimate uses, and holes are counted inside the swept volume of the recorded poses.
"""

from __future__ import annotations

import dataclasses
from dataclasses import dataclass
from pathlib import Path

import numpy as np

from resus.acquisition.backends.simulated import SimulatedProbeConfig
from resus.acquisition.simulation import simulate_sweep
from resus.acquisition.trajectory import Trajectory
from resus.planning.holes import imaging_grid, swept_volume
from resus.planning.sampling import PathSamples
from resus.reconstruction.compounding import ReconstructionSettings, reconstruct
from resus.sweep.io import read_sweep
from sim.robot.scene_config import SceneConfig
from sim.ultrasound.probe import LinearProbe


@dataclass(frozen=True)
class SimulatedOutcome:
    """What the simulated scan gave."""

    sweep_path: Path
    frames: int
    imaging_frames: int
    hole_fraction: float | None
    """Unobserved fraction of the swept volume, SDW reconstruction without hole filling;
    None when the probe swept no volume (a compression scan images at stations)."""

    def describe(self) -> str:
        scan = (
            f"Simulated scan `{self.sweep_path.name}`: {self.frames} frames "
            f"({self.imaging_frames} imaging); "
        )
        if self.hole_fraction is None:
            return scan + "the probe swept no volume (it images at stations): no holes to count."
        return scan + (
            "SDW reconstruction without hole filling leaves "
            f"{self.hole_fraction:.2%} of the swept volume as holes."
        )


def imaging_segments_of_poses(trajectory: Trajectory, poses: np.ndarray) -> np.ndarray:
    """Imaging segment (-1: transit) of recorded poses, by the nearest planned sample."""
    samples = PathSamples.of(trajectory)
    segment = trajectory.imaging_segment_at(samples.times)
    return segment[samples.nearest(poses, trajectory.rotation_radius)]


def simulate_plan(
    out: Path,
    scene: SceneConfig,
    trajectory: Trajectory,
    voxel_size: float,
    probe: LinearProbe | None = None,
    progress: bool = True,
) -> SimulatedOutcome:
    """Scan `trajectory` in simulation into `out` and measure its reconstruction's holes."""
    probe = probe or LinearProbe()
    config = SimulatedProbeConfig(probe=probe, frame_rate=trajectory.frame_rate)
    result = simulate_sweep(out, scene, trajectory, probe=config, progress=progress)
    sweep = read_sweep(result.path)
    poses = np.asarray(sweep.probe_to_base)
    segment = imaging_segments_of_poses(trajectory, poses)
    imaging = segment >= 0
    grid = imaging_grid(poses[imaging], probe, voxel_size)
    settings = dataclasses.replace(ReconstructionSettings(), fill_passes=0)
    volume = reconstruct(
        sweep.frames[imaging], poses[imaging], sweep.image_to_probe, grid, settings,
        progress=progress, total=int(imaging.sum()),
    )  # fmt: skip
    swept, _ = swept_volume(grid, poses, segment, probe, volume.observed)
    swept_voxels = int(swept.sum())
    holes = float((swept & ~volume.observed).sum() / swept_voxels) if swept_voxels else None
    return SimulatedOutcome(result.path, len(poses), int(imaging.sum()), holes)
