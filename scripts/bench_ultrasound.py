"""Benchmark the synthetic B-mode simulator: frames/s along a realistic sweep, every feature on.

The probe sweeps the default phantom's femoral vessels distally in transverse view, swaying
sideways and rocking a little, as a robot sweep does; every frame queries the phantom and runs
speckle, elevational slice, pulse, beam, attenuation, specular walls, noise and log compression.
The figure is the best of `--repeats` passes after a warm-up (other processes share the CPU).

    python scripts/bench_ultrasound.py [--frames 400] [--repeats 5] [--phantom default]
        [--scanner vascular] [--force 4]

The scanner preset (clutter and grey map on) is timed against the plain settings at the same
probe geometry in the same run. A phantom with mechanics (`femoral`) is also imaged deformed:
the probe pressed in by `--force` newtons (the face as far into the skin as the MuJoCo
contact lets it at that force, 0.83 mm/N, measured), at the frame rate's times, timed against
the same preset rigid. Last line: JSON {"frames_per_s", "baseline_frames_per_s",
"preset_cost_ratio", "deformed_frames_per_s", "deformation_cost_ratio", "megapixels_per_s",
"rows", "cols", "phantom", "scanner", "force"} (the deformed figures null for a rigid phantom).
"""

from __future__ import annotations

import argparse
import json
import time

import numpy as np
from tqdm import tqdm

from sim.phantom import Phantom, load_phantom
from sim.ultrasound.deformation import TissueLoad
from sim.ultrasound.scanner import scanner_preset
from sim.ultrasound.simulator import UltrasoundSimulator
from sim.ultrasound.skin_pose import probe_pose_on_skin

CONTACT_COMPLIANCE = 0.83e-3
"""How far the simulated UR3e's probe sinks into the phantom per newton of contact force
(m/N): the MuJoCo contact's, measured at 2-12 N."""
FRAME_RATE = 30.0


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


def pressed(poses: list[np.ndarray], force: float) -> list[np.ndarray]:
    """The poses with the face sunk into the skin as far as `force` sinks it in the scene."""
    sunk = [pose.copy() for pose in poses]
    for pose in sunk:
        pose[:3, 3] += pose[:3, 2] * force * CONTACT_COMPLIANCE
    return sunk


def frames_per_second(
    simulator: UltrasoundSimulator,
    poses: list[np.ndarray],
    repeats: int,
    loads: list[TissueLoad | None] | None = None,
) -> float:
    """Best of `repeats` passes over `poses` (under `loads`, if given), after a warm-up (JIT,
    phantom index, caches)."""
    loads = loads or [None] * len(poses)
    for pose, load in zip(poses[:20], loads, strict=False):
        simulator.render(pose, load)
    best = np.inf
    for _ in tqdm(range(repeats), desc="passes"):
        start = time.perf_counter()
        for pose, load in zip(poses, loads, strict=True):
            simulator.render(pose, load)
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
    parser.add_argument(
        "--force", type=float, default=4.0, help="Contact force of the deformed frames (N)."
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
    deformed = None
    if simulator.deformation is not None:
        loads: list[TissueLoad | None] = [
            TissueLoad(args.force, k / FRAME_RATE) for k in range(len(poses))
        ]
        deformed = frames_per_second(simulator, pressed(poses, args.force), args.repeats, loads)
        print(f"{deformed:.1f} frames/s deformed at {args.force:g} N, same preset")
    print(
        json.dumps(
            {
                "frames_per_s": round(frames_per_s, 1),
                "baseline_frames_per_s": round(baseline, 1),
                "preset_cost_ratio": round(baseline / frames_per_s, 3),
                "deformed_frames_per_s": None if deformed is None else round(deformed, 1),
                "deformation_cost_ratio": (
                    None if deformed is None else round(frames_per_s / deformed, 3)
                ),
                "megapixels_per_s": round(megapixels_per_s, 2),
                "rows": probe.rows,
                "cols": probe.cols,
                "phantom": args.phantom,
                "scanner": preset.name,
                "force": args.force,
            }
        )
    )


if __name__ == "__main__":
    main()
