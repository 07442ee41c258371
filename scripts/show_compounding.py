"""Save the same femoral views without and with spatial compounding: docs/compounding.png.

Columns: the `vascular` preset, `vascular-compound` (3 frames, +-10 degrees) and 5 frames at
+-20 degrees; rows: the probe resting on the skin and pressed 3 mm in at 6 N. Each panel's
title gives its render time and the speckle's spread in a patch of fat (grey standard
deviation over mean), the label outlines are yellow.

    python scripts/show_compounding.py [--out docs/compounding.png]
"""

from __future__ import annotations

import argparse
import dataclasses
import time
from pathlib import Path

import matplotlib

matplotlib.use("Agg")
import matplotlib.pyplot as plt
import numpy as np
from figure_output import outlined_bmode, save_figure

from sim.phantom import Phantom, load_phantom
from sim.ultrasound.deformation import TissueLoad
from sim.ultrasound.scanner import scanner_preset
from sim.ultrasound.simulator import UltrasoundSimulator
from sim.ultrasound.skin_pose import probe_pose_on_skin

FAT_PATCH = (slice(65, 95), slice(100, 170))
"""Rows and columns of a patch of subcutaneous fat in these views."""


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--out", type=Path, default=Path("docs/compounding.png"))
    args = parser.parse_args()
    phantom = Phantom(load_phantom("femoral"))
    vascular = scanner_preset("vascular")
    columns = {
        "vascular": vascular.settings(),
        "vascular-compound": scanner_preset("vascular-compound").settings(),
        "5 frames, +-20 deg": dataclasses.replace(
            vascular.settings(), compound_frames=5, compound_angle=0.35
        ),
    }
    resting = probe_pose_on_skin(phantom, 0.0, 0.0)
    pressed = resting.copy()
    pressed[:3, 3] += 0.003 * pressed[:3, 2]
    rows = (("resting", resting, None), ("pressed 6 N", pressed, TissueLoad(6.0, 0.2)))
    figure, axes = plt.subplots(2, 3, figsize=(13, 9))
    for j, (name, settings) in enumerate(columns.items()):
        simulator = UltrasoundSimulator(phantom, vascular.probe(), settings)
        for i, (view, pose, load) in enumerate(rows):
            simulator.render(pose, load)  # compile and warm up
            start = time.perf_counter()
            image, labels = simulator.render(pose, load)
            elapsed = time.perf_counter() - start
            patch = image[FAT_PATCH].astype(np.float64)
            spread = patch.std() / patch.mean()
            outlined_bmode(
                axes[i, j],
                image,
                labels,
                f"{name}, {view}\n{elapsed * 1e3:.0f} ms, fat sd/mean {spread:.2f}",
            )
    save_figure(figure, args.out, dpi=80)


if __name__ == "__main__":
    main()
