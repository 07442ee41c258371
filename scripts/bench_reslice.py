"""Benchmark: reslices per second, fast path (sample each plane) vs the paper's rotate path.

Builds a realistic volume (default 200 x 200 x 250 voxels of 0.2 mm: speckle-like tissue, a
curved femoral artery and vein as tubes with dark lumens and bright walls), reslices it with
both methods on the same angle pairs in the same run (best of `--repeats` timings each, as
the machine is shared), compares their images, and times the fast path on the paper's full
49 angle pairs too. The last line printed is one JSON object with the figures.

    python scripts/bench_reslice.py [--shape 200,200,250] [--angles -30,0,30] [--repeats 2]
"""

from __future__ import annotations

import argparse
import json
import time

import numpy as np
from scipy import ndimage

from resus.reconstruction.grid import VolumeGrid
from resus.reslicing.reslice import Reslice, ResliceSettings, reslice_volume

SPACING = 0.2e-3


def femoral_volume(shape: tuple[int, int, int], seed: int = 0) -> tuple[np.ndarray, np.ndarray]:
    """(grey levels float32, labels uint8): speckle tissue with an artery (1) and a vein (2)
    running along z on gently curved paths; lumens dark, walls bright."""
    rng = np.random.default_rng(seed)
    nx, ny, nz = shape
    speckle = ndimage.gaussian_filter(rng.rayleigh(1.0, shape).astype(np.float32), (1.2, 0.6, 1.2))
    depth_gain = np.linspace(1.1, 0.7, ny, dtype=np.float32)[None, :, None]
    volume = 70 * speckle / speckle.mean() * depth_gain
    x, y = np.meshgrid(
        np.arange(nx, dtype=np.float32), np.arange(ny, dtype=np.float32), indexing="ij"
    )
    labels = np.zeros(shape, dtype=np.uint8)
    vessels = ((1, 0.38, 0.40, 0.075), (2, 0.64, 0.46, 0.095))  # label, x, y (fractions), radius
    for k in range(nz):
        bend = 0.06 * np.sin(np.pi * k / nz)
        for label, cx, cy, radius in vessels:
            distance = np.hypot(x - (cx + bend) * nx, y - cy * ny)
            wall = (distance > radius * nx) & (distance <= (radius + 0.015) * nx)
            volume[:, :, k][wall] *= 2.2
            labels[:, :, k][distance <= radius * nx] = label
    volume[labels > 0] *= 0.15
    return np.clip(volume, 1, 255), labels


def timed_reslices(
    volume: np.ndarray,
    labels: np.ndarray,
    grid: VolumeGrid,
    settings: ResliceSettings,
    repeats: int,
) -> tuple[list[Reslice], float]:
    """The reslices and the best wall time of `repeats` runs (seconds)."""
    best, reslices = float("inf"), []
    for _ in range(repeats):
        start = time.perf_counter()
        reslices = list(reslice_volume(volume, labels, grid, settings))
        best = min(best, time.perf_counter() - start)
    return reslices, best


def compare(fast: list[Reslice], faithful: list[Reslice], spacing: float) -> dict[str, float]:
    """Differences between the two paths on the slices both kept."""
    by_key = {(r.angles_deg, r.slice_index): r for r in faithful}
    keys = [(r.angles_deg, r.slice_index) for r in fast]
    common = [(r, by_key[key]) for r, key in zip(fast, keys, strict=True) if key in by_key]
    size = fast[0].image.shape[0] if fast else 0
    last = size - 1
    corners = np.array(
        [[0, 0, 0, 1], [last, 0, 0, 1], [0, last, 0, 1], [last, last, 0, 1]], float
    ).T
    grey = np.array([np.abs(a.image.astype(int) - b.image.astype(int)).mean() for a, b in common])
    grey_max = max(int(np.abs(a.image.astype(int) - b.image.astype(int)).max()) for a, b in common)
    grey_p99 = np.mean(
        [np.percentile(np.abs(a.image.astype(int) - b.image.astype(int)), 99) for a, b in common]
    )
    labels = np.array([(a.label == b.label).mean() for a, b in common])
    shift = max(
        np.linalg.norm((a.plane_to_world - b.plane_to_world) @ corners, axis=0).max()
        for a, b in common
    )
    return {
        "kept_fast": len(fast),
        "kept_rotate": len(faithful),
        "kept_by_both": len(common),
        "grey_mean_abs_diff": round(float(grey.mean()), 3),
        "grey_mean_abs_diff_worst_slice": round(float(grey.max()), 3),
        "grey_p99_abs_diff": round(float(grey_p99), 2),
        "grey_max_abs_diff": grey_max,
        "label_agreement_mean": round(float(labels.mean()), 5),
        "label_agreement_worst_slice": round(float(labels.min()), 5),
        "pose_corner_shift_max_voxels": round(float(shift / spacing), 3),
    }


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--shape", default="200,200,250", help="voxels nx,ny,nz")
    parser.add_argument(
        "--angles", default="-30,0,30", help="degrees for the fast-vs-rotate comparison"
    )
    parser.add_argument("--repeats", type=int, default=2, help="timed runs per method (best kept)")
    args = parser.parse_args()
    shape = tuple(int(n) for n in args.shape.split(","))
    angles = tuple(float(a) for a in args.angles.split(","))
    volume, labels = femoral_volume(shape)
    grid = VolumeGrid(origin=np.zeros(3), axes=np.eye(3) * SPACING, shape=shape)
    # compile (or load) the numba kernel outside the timings
    list(
        reslice_volume(
            volume[:8, :8, :8], labels[:8, :8, :8], VolumeGrid(np.zeros(3), np.eye(3), (8, 8, 8))
        )
    )

    results, seconds = {}, {}
    for method in ("fast", "rotate"):
        settings = ResliceSettings(angles_deg=angles, method=method)
        results[method], seconds[method] = timed_reslices(
            volume, labels, grid, settings, args.repeats
        )
        rate = len(results[method]) / seconds[method]
        print(
            f"{method:>6}: {len(results[method])} reslices from {len(settings.angle_pairs())} "
            f"angle pairs in {seconds[method]:.2f} s = {rate:.1f} reslices/s"
        )
    full, full_seconds = timed_reslices(volume, labels, grid, ResliceSettings(), args.repeats)
    print(
        f"  fast, paper's 49 angle pairs: {len(full)} reslices in {full_seconds:.2f} s "
        f"= {len(full) / full_seconds:.1f} reslices/s"
    )
    fast_rate = len(results["fast"]) / seconds["fast"]
    rotate_rate = len(results["rotate"]) / seconds["rotate"]
    figures = {
        "shape": list(shape),
        "angles_deg": list(angles),
        "repeats": args.repeats,
        "fast_reslices_per_s": round(fast_rate, 2),
        "rotate_reslices_per_s": round(rotate_rate, 2),
        "speedup": round(fast_rate / rotate_rate, 2),
        "fast_seconds": round(seconds["fast"], 3),
        "rotate_seconds": round(seconds["rotate"], 3),
        "fast_full_49_pairs_reslices": len(full),
        "fast_full_49_pairs_seconds": round(full_seconds, 3),
        **compare(results["fast"], results["rotate"], SPACING),
    }
    print(json.dumps(figures))


if __name__ == "__main__":
    main()
