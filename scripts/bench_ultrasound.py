"""Benchmark the synthetic B-mode simulator: frames/s along a realistic sweep, every feature on.

The probe sweeps the default phantom's femoral vessels distally in transverse view, swaying
sideways and rocking a little, as a robot sweep does; every frame queries the phantom and runs
speckle, elevational slice, pulse, beam, attenuation, specular walls, noise and log compression.
The figure is the best of `--repeats` passes after a warm-up (other processes share the CPU).

    python scripts/bench_ultrasound.py [--frames 400] [--repeats 5] [--phantom default]
        [--scanner vascular]

The scanner preset (clutter and grey map on) is timed against the plain settings at the same
probe geometry in the same run. Last line: JSON {"frames_per_s", "baseline_frames_per_s",
"preset_cost_ratio", "megapixels_per_s", "rows", "cols", "phantom", "scanner"}.
"""

from __future__ import annotations

import argparse
import json
import time

import numpy as np
from tqdm import tqdm

from sim.phantom import Phantom, load_phantom
from sim.ultrasound.scanner import scanner_preset
from sim.ultrasound.simulator import UltrasoundSimulator
from sim.ultrasound.skin_pose import probe_pose_on_skin


def sweep_poses(phantom: Phantom, count: int) -> list[np.ndarray]:
    """A distal transverse sweep over 120 mm with sideways sway and a little rocking."""
    t = np.linspace(0.0, 1.0, count)
    y = -0.06 + 0.12 * t
    x = 0.004 * np.sin(2 * np.pi * 1.5 * t)
    tilt = 0.08 * np.sin(2 * np.pi * 2.0 * t)
    rotation = 0.05 * np.sin(2 * np.pi * 0.7 * t)
    return [
        probe_pose_on_skin(phantom, xi, yi, rotation=ri, tilt=ti)
        for xi, yi, ri, ti in zip(x, y, rotation, tilt, strict=True)
    ]


def frames_per_second(
    simulator: UltrasoundSimulator, poses: list[np.ndarray], repeats: int
) -> float:
    """Best of `repeats` passes over `poses`, after a warm-up (JIT, phantom index, caches)."""
    for pose in poses[:20]:
        simulator.render(pose)
    best = np.inf
    for _ in tqdm(range(repeats), desc="passes"):
        start = time.perf_counter()
        for pose in poses:
            simulator.render(pose)
        best = min(best, time.perf_counter() - start)
    return len(poses) / best


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--frames", type=int, default=400)
    parser.add_argument("--repeats", type=int, default=5)
    parser.add_argument("--phantom", default="default", help="Phantom name or YAML file.")
    parser.add_argument(
        "--scanner",
        default="vascular",
        help="Scanner preset (sim.ultrasound.scanner); timed against the plain settings.",
    )
    args = parser.parse_args()
    phantom = Phantom(load_phantom(args.phantom))
    preset = scanner_preset(args.scanner)
    probe = preset.probe()
    poses = sweep_poses(phantom, args.frames)
    baseline = frames_per_second(UltrasoundSimulator(phantom, probe), poses, args.repeats)
    simulator = UltrasoundSimulator(phantom, probe, preset.settings())
    frames_per_s = frames_per_second(simulator, poses, args.repeats)
    megapixels_per_s = frames_per_s * probe.rows * probe.cols / 1e6
    print(
        f"{frames_per_s:.1f} frames/s with the {preset.name} preset, {baseline:.1f} without "
        f"({probe.rows} x {probe.cols}, {args.phantom} phantom, best of {args.repeats} passes "
        f"of {len(poses)} frames)"
    )
    print(
        json.dumps(
            {
                "frames_per_s": round(frames_per_s, 1),
                "baseline_frames_per_s": round(baseline, 1),
                "preset_cost_ratio": round(baseline / frames_per_s, 3),
                "megapixels_per_s": round(megapixels_per_s, 2),
                "rows": probe.rows,
                "cols": probe.cols,
                "phantom": args.phantom,
                "scanner": preset.name,
            }
        )
    )


if __name__ == "__main__":
    main()
