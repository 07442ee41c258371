"""Benchmark: preparing subjects' scans (simulate, reconstruct, reslice) on each engine.

Wall time of `prepare_subjects` for N subjects at the quick experiment preset's scan settings,
each run into an empty folder (nothing cached): with 1 local worker (this process), 2 local
worker processes, and Ray on the same 2 cores (a local Ray of 2 CPUs, started once; its start
is reported apart). Then Ray's own cost per unit: trivial units (`abs` of an int) mapped
through the Ray executor, per unit, and the latency of a map of one. Best of `--repeats`.
Prints the figures; the last line is one JSON object.

    python scripts/bench_executor.py [--subjects 4] [--repeats 2] [--trivial 200]
"""

from __future__ import annotations

import argparse
import json
import tempfile
import time
from collections.abc import Callable
from pathlib import Path

from resus.execution import Executor, LocalExecutor, RayExecutor, start_local_ray
from resus.execution.executor import available_cores
from resus.experiments.data import prepare_subjects
from resus.experiments.tables import QUICK_EXPERIMENT


def best_seconds(run: Callable[[], object], repeats: int) -> float:
    """The fastest of `repeats` runs of `run`, in seconds."""
    best = float("inf")
    for _ in range(repeats):
        start = time.perf_counter()
        run()
        best = min(best, time.perf_counter() - start)
    return best


def preparing(executor: Executor, subjects: int) -> Callable[[], object]:
    """One preparation of `subjects` scans on `executor`, into a folder of its own."""

    def run() -> object:
        with tempfile.TemporaryDirectory(prefix="bench_executor_") as folder:
            return prepare_subjects(
                Path(folder), range(subjects), QUICK_EXPERIMENT.scans, progress=False,
                executor=executor,
            )  # fmt: skip

    return run


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--subjects", type=int, default=4)
    parser.add_argument("--repeats", type=int, default=2)
    parser.add_argument("--trivial", type=int, default=200, help="trivial units for Ray's cost")
    args = parser.parse_args()

    seconds = {}
    for name, executor in (("local_1", LocalExecutor(1)), ("local_2", LocalExecutor(2))):
        seconds[name] = best_seconds(preparing(executor, args.subjects), args.repeats)
        print(f"{name}: {seconds[name]:.1f} s for {args.subjects} subjects")
    start = time.perf_counter()
    start_local_ray(2)
    ray_start = time.perf_counter() - start
    ray = RayExecutor(2)  # joins the Ray started above
    seconds["ray_2"] = best_seconds(preparing(ray, args.subjects), args.repeats)
    print(f"ray_2: {seconds['ray_2']:.1f} s (Ray itself took {ray_start:.1f} s to start)")
    items = list(range(args.trivial))
    trivial = best_seconds(lambda: ray.map(abs, items, "trivial", "unit", progress=False), 3)
    one = best_seconds(lambda: ray.map(abs, [1], "one", "unit", progress=False), 3)
    print(f"ray: {1e3 * trivial / args.trivial:.2f} ms per trivial unit, {1e3 * one:.1f} ms a map")

    import ray as ray_module

    ray_module.shutdown()
    figures = {
        "subjects": args.subjects,
        "repeats": args.repeats,
        "cores": available_cores(),
        "scan_settings": "quick experiment preset (128 x 128, 120 frames, 0.5 mm, 5 angles)",
        "seconds": {name: round(value, 2) for name, value in seconds.items()},
        "speedup_local_2_over_1": round(seconds["local_1"] / seconds["local_2"], 2),
        "ray_2_over_local_2": round(seconds["ray_2"] / seconds["local_2"], 3),
        "ray_start_seconds": round(ray_start, 2),
        "ray_ms_per_trivial_unit": round(1e3 * trivial / args.trivial, 3),
        "ray_ms_per_map_of_one": round(1e3 * one, 2),
    }
    print(json.dumps(figures))


if __name__ == "__main__":
    main()
