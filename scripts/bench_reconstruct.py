"""Benchmark: squared-distance-weighted compounding speed, numba kernel vs plain numpy.

A realistic dense sweep: 256 x 256 frames with 0.2 mm pixels (a 51.2 mm linear probe imaging
51.2 mm deep), tilted 5 degrees, advancing 0.3 mm per frame through a 256^3 grid of 0.3 mm
voxels; SDW with r = 1.5 voxels. The kernel is timed over the whole sweep (after one warm-up
frame compiles it), best of `--repeats`; the numpy reference of the same formula on a few
frames. Prints the figures; the last line is one JSON object.

    python scripts/bench_reconstruct.py [--frames 256] [--repeats 3] [--numpy-frames 3]
"""

from __future__ import annotations

import argparse
import json
import sys
import time
from pathlib import Path

import numba
import numpy as np
from scipy.spatial.transform import Rotation

from resus.reconstruction.compounding import ReconstructionSettings, Reconstructor
from resus.reconstruction.grid import aabb_grid
from sim.transforms import make_pose
from sim.ultrasound.probe import LinearProbe

# The numpy reference is a test oracle; it lives with the tests.
sys.path.insert(0, str(Path(__file__).resolve().parents[1] / "tests"))
from reconstruct_reference import sdw_accumulate_numpy

VOXEL = 0.3e-3
STEP = 0.3e-3
GRID_VOXELS = 256


def sweep(n_frames: int) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """Random-speckle frames, poses along +y with a 5 degree tilt, and the calibration."""
    probe = LinearProbe(width=0.0512, depth=0.0512, cols=256, rows=256)
    tilt = Rotation.from_euler("x", 5, degrees=True).as_matrix()
    poses = np.array([make_pose(tilt, (0.0, 0.002 + i * STEP, -0.012)) for i in range(n_frames)])
    frames = np.random.default_rng(0).integers(0, 256, size=(n_frames, 256, 256), dtype=np.uint8)
    return frames, poses, probe.image_to_probe()


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--frames", type=int, default=256)
    parser.add_argument("--repeats", type=int, default=3)
    parser.add_argument("--numpy-frames", type=int, default=3)
    args = parser.parse_args()

    frames, poses, image_to_probe = sweep(args.frames)
    half = GRID_VOXELS * VOXEL / 2
    grid = aabb_grid(
        VOXEL,
        bounds=((-half, 0.0, -0.02), (half - VOXEL, 2 * half - VOXEL, 2 * half - 0.02 - VOXEL)),
    )
    settings = ReconstructionSettings(method="sdw", radius=1.5, fill_passes=0)

    best = float("inf")
    for _ in range(args.repeats):
        reconstructor = Reconstructor(grid, image_to_probe, settings)
        reconstructor.add_frame(frames[0], poses[0])  # compiles (or loads the cache) once
        start = time.perf_counter()
        for frame, pose in zip(frames, poses, strict=True):
            reconstructor.add_frame(frame, pose)
        best = min(best, time.perf_counter() - start)
    kernel_fps = args.frames / best
    observed = float((reconstructor.weight > 0).mean())

    value = np.zeros(grid.shape)
    weight = np.zeros(grid.shape)
    unit = float(grid.spacing.min())
    start = time.perf_counter()
    for frame, pose in zip(frames[: args.numpy_frames], poses[: args.numpy_frames], strict=True):
        sdw_accumulate_numpy(
            frame, pose, image_to_probe, grid, 1.5 * unit, 0.1 * unit, value, weight
        )
    numpy_fps = args.numpy_frames / (time.perf_counter() - start)

    print(
        f"grid {grid.describe()}; {args.frames} frames 256 x 256, observed {observed:.1%} of voxels"
    )
    print(
        f"numba SDW: {kernel_fps:.0f} frames/s on {numba.get_num_threads()} threads "
        f"(best of {args.repeats})"
    )
    print(f"numpy SDW: {numpy_fps:.2f} frames/s; speed-up {kernel_fps / numpy_fps:.0f}x")
    print(
        json.dumps(
            {
                "benchmark": "sdw_reconstruction",
                "frame_shape": [256, 256],
                "grid_shape": list(grid.shape),
                "voxel_mm": VOXEL * 1e3,
                "radius_voxels": 1.5,
                "frames": args.frames,
                "threads": numba.get_num_threads(),
                "numba_frames_per_s": round(kernel_fps, 1),
                "numpy_frames_per_s": round(numpy_fps, 3),
                "speedup": round(kernel_fps / numpy_fps, 1),
            }
        )
    )


if __name__ == "__main__":
    main()
