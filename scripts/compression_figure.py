"""The README's compression figure: a simulated press on the femoral phantom, vein against artery.

Scans two stations of `resus plan --pattern compression` (light contact, a press to
`--press-force` newtons, release) on the deformable `femoral` phantom with the simulated UR3e,
then plots the vein's and the artery's cross-section area (from the Sweep's exact labels)
against time with the recorded contact force, beside the frames at light contact and at the
highest force.

    python scripts/compression_figure.py [--out docs/compression.png] [--subject 0]

Last line: JSON {"vein_area_ratio", "artery_area_range", "force_max", "frames"}: the vein's
area at the highest force over its area at light contact, and the artery's (max - min) / mean
during that press (its pulse: area, so about twice the diameter's pulsation).
"""

from __future__ import annotations

import argparse
import json
import tempfile
from pathlib import Path

import matplotlib

matplotlib.use("Agg")
import matplotlib.pyplot as plt
import numpy as np
from figure_output import save_figure

from resus.acquisition.patterns import CompressionPattern
from resus.acquisition.simulation import resolve_scene, simulate_sweep
from resus.sweep.io import read_sweep
from sim.labels import ARTERY, VEIN


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--out", type=Path, default=Path("docs/compression.png"))
    parser.add_argument("--subject", type=int, default=0)
    parser.add_argument("--press-force", type=float, default=12.0)
    args = parser.parse_args()
    scene = resolve_scene("default", "femoral", args.subject)
    pattern = CompressionPattern(stations=2, press_force=args.press_force)
    with tempfile.TemporaryDirectory() as folder:
        path = Path(folder) / "press.h5"
        simulate_sweep(path, scene, pattern, progress=False)
        sweep = read_sweep(path)
    force = sweep.axial_force
    assert sweep.labels is not None and force is not None
    pixel_mm2 = float(np.prod(sweep.pixel_spacing)) * 1e6
    vein = (sweep.labels == VEIN).sum(axis=(1, 2)) * pixel_mm2
    artery = (sweep.labels == ARTERY).sum(axis=(1, 2)) * pixel_mm2
    time = sweep.timestamps - sweep.timestamps[0]
    first = time <= time[-1] / 2  # the first station's press
    light, full = int(np.argmin(np.where(first, force, np.inf))), int(np.argmax(force * first))
    press = first & (force > force[light] + 0.5)  # the first station's press, probe still

    figure = plt.figure(figsize=(12, 4))
    grid = figure.add_gridspec(1, 3, width_ratios=[2.2, 1, 1])
    curves = figure.add_subplot(grid[0])
    curves.plot(time, vein, label="vein area", color="tab:blue")
    curves.plot(time, artery, label="artery area", color="tab:red")
    curves.set_xlabel("time (s)")
    curves.set_ylabel("cross-section area in the image (mm²)")
    forces = curves.twinx()
    forces.plot(time, force, color="0.4", linestyle="--", label="contact force")
    forces.set_ylabel("contact force (N)")
    lines = curves.get_lines() + forces.get_lines()
    curves.legend(lines, [line.get_label() for line in lines], loc="upper right", fontsize=8)
    curves.set_title("a press on the femoral phantom (simulated UR3e, force mode)")
    for slot, (index, title) in enumerate(((light, "light contact"), (full, "full press"))):
        axis = figure.add_subplot(grid[slot + 1])
        axis.imshow(sweep.frames[index], cmap="gray", vmin=0, vmax=255)
        axis.contour(sweep.labels[index] == VEIN, levels=[0.5], colors="tab:blue")
        axis.contour(sweep.labels[index] == ARTERY, levels=[0.5], colors="tab:red")
        axis.set_title(f"{title}: {force[index]:.1f} N", fontsize=9)
        axis.axis("off")
    save_figure(figure, args.out, dpi=110)
    print(
        json.dumps(
            {
                "vein_area_ratio": round(float(vein[full] / vein[light]), 3),
                "artery_area_range": round(float(np.ptp(artery[press]) / artery[press].mean()), 3),
                "force_max": round(float(force.max()), 2),
                "frames": len(force),
            }
        )
    )


if __name__ == "__main__":
    main()
