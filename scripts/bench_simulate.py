"""Benchmark: simulated scanning throughput, robot + ultrasound + writing, in frames per wall
second for a full scan (approach, force-mode contact, sweep, retreat) at 256 x 256.

    python scripts/bench_simulate.py [--length 0.08] [--frame-rate 30] [--repeats 2]

Prints a line per run, and as its last line one JSON object with the best run's figures.
"""

from __future__ import annotations

import argparse
import json
import tempfile
import time
from pathlib import Path

from resus.acquisition.patterns import LinearPattern
from resus.acquisition.simulation import resolve_scene, simulate_sweep


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--length", type=float, default=0.08, help="sweep length (m)")
    parser.add_argument("--frame-rate", type=float, default=30.0, help="frames per second")
    parser.add_argument("--repeats", type=int, default=2, help="runs; the best is reported")
    args = parser.parse_args()
    scene = resolve_scene("default", None, 0)
    plan = LinearPattern(length=args.length, frame_rate=args.frame_rate)
    with tempfile.TemporaryDirectory() as folder:
        # Warm-up: numba compilation and MuJoCo model building are not part of a scan.
        simulate_sweep(Path(folder) / "warm.h5", scene, LinearPattern(length=0.005), progress=False)
        best = None
        for run in range(args.repeats):
            start = time.perf_counter()
            result = simulate_sweep(Path(folder) / f"run{run}.h5", scene, plan, progress=False)
            wall = time.perf_counter() - start
            figures = {
                "frames": result.frames,
                "wall_s": round(wall, 3),
                "frames_per_s": round(result.frames / wall, 1),
                "realtime_factor": round(result.duration / wall, 2),
            }
            print(f"run {run}: {figures}")
            if best is None or figures["frames_per_s"] > best["frames_per_s"]:
                best = figures
    print(json.dumps({**best, "rows": 256, "cols": 256, "frame_rate_hz": args.frame_rate}))


if __name__ == "__main__":
    main()
