"""Benchmark `Phantom.sample` and `Phantom.labels` on 256 x 256 probe image planes (65,536 points).

Planes of a 38 x 50 mm linear probe on the default phantom's skin: transverse across the
vessels, longitudinal along them, and oblique (tilted 30 degrees, turned 45 degrees). Prints
the best of many runs after JIT warm-up (timings on a shared 2-core machine are noisy), and as
its last line one JSON object with the figures in milliseconds.
"""

from __future__ import annotations

import json
import time

import numpy as np
from scipy.spatial.transform import Rotation

from sim.phantom import Phantom, TissueSample, load_phantom
from sim.transforms import make_pose
from sim.ultrasound.probe import LinearProbe

REPEATS = 200


def plane_points(probe: LinearProbe, turn_deg: float, tilt_deg: float, y: float) -> np.ndarray:
    """Pixel centres of a probe touching the skin at (0, y, 0), pointing down (-z)."""
    pointing_down = np.array([[1.0, 0.0, 0.0], [0.0, -1.0, 0.0], [0.0, 0.0, -1.0]])
    turn_and_tilt = Rotation.from_euler("zy", [turn_deg, tilt_deg], degrees=True).as_matrix()
    pose = make_pose(pointing_down @ turn_and_tilt, [0.0, y, 0.0])
    points = probe.pixel_points().reshape(-1, 3)
    return points @ pose[:3, :3].T + pose[:3, 3]


def best_time(function, repeats: int = REPEATS) -> float:
    """Best wall time of `function()` over `repeats` runs (seconds)."""
    best = np.inf
    for _ in range(repeats):
        start = time.perf_counter()
        function()
        best = min(best, time.perf_counter() - start)
    return best


def main() -> None:
    phantom = Phantom(load_phantom("default"))
    probe = LinearProbe(width=0.038, depth=0.050, cols=256, rows=256)
    planes = {
        "transverse": plane_points(probe, 0.0, 0.0, -0.03),
        "longitudinal": plane_points(probe, 90.0, 0.0, -0.03),
        "oblique": plane_points(probe, 45.0, 30.0, -0.03),
    }
    out = TissueSample.empty(probe.rows * probe.cols)
    results = {}
    for name, points in planes.items():
        phantom.sample(points, out=out)  # JIT warm-up and index build
        phantom.labels(points)
        near = np.isfinite(out.vessel_distance).mean()
        results[name] = {
            "sample_ms": 1e3 * best_time(lambda p=points: phantom.sample(p, out=out)),
            "sample_new_buffers_ms": 1e3 * best_time(lambda p=points: phantom.sample(p)),
            "labels_ms": 1e3 * best_time(lambda p=points: phantom.labels(p)),
            "fraction_within_5mm": round(float(near), 3),
        }
        print(name, {k: round(v, 3) for k, v in results[name].items()})
    print(json.dumps({"points": probe.rows * probe.cols, "repeats": REPEATS, **results}))


if __name__ == "__main__":
    main()
