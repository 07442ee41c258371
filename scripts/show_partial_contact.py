"""Save femoral views with full and partial probe contact: docs/partial_contact.png.

Panels (the `vascular` preset): the probe resting flat on the curved groin, which couples only
the middle of the array; pressed 3 mm in at 6 N, every element on the skin; and the same pressed
view with the first quarter of the array's coupling lost (`UltrasoundSettings.lost_coupling`).
Lines whose aperture is partly uncoupled fade towards the black columns. Under each image, the
mean grey of every column. Label outlines in yellow.

    python scripts/show_partial_contact.py [--out docs/partial_contact.png]
"""

from __future__ import annotations

import argparse
import dataclasses
from pathlib import Path

import matplotlib.pyplot as plt
from figure_output import outlined_bmode, save_figure

from sim.phantom import Phantom, load_phantom
from sim.ultrasound.deformation import TissueLoad
from sim.ultrasound.scanner import scanner_preset
from sim.ultrasound.simulator import UltrasoundSimulator
from sim.ultrasound.skin_pose import probe_pose_on_skin


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--out", type=Path, default=Path("docs/partial_contact.png"))
    args = parser.parse_args()
    phantom = Phantom(load_phantom("femoral"))
    vascular = scanner_preset("vascular")
    lifted = dataclasses.replace(vascular.settings(), lost_coupling=(0.25, 0.0))
    resting = probe_pose_on_skin(phantom, 0.0, 0.0)
    pressed = resting.copy()
    pressed[:3, 3] += 0.003 * pressed[:3, 2]
    views = (
        ("resting on the skin", vascular.settings(), resting, None),
        ("pressed 6 N", vascular.settings(), pressed, TissueLoad(6.0, 0.2)),
        ("pressed 6 N, first quarter uncoupled", lifted, pressed, TissueLoad(6.0, 0.2)),
    )
    figure, axes = plt.subplots(
        2, 3, figsize=(13, 6.5), gridspec_kw={"height_ratios": [4, 1]}, sharex="col"
    )
    for j, (title, settings, pose, load) in enumerate(views):
        simulator = UltrasoundSimulator(phantom, vascular.probe(), settings)
        image, labels = simulator.render(pose, load)
        coupled = int(simulator.contact(pose).sum())
        title = f"{title}\n{coupled} of {image.shape[1]} elements coupled"
        outlined_bmode(axes[0, j], image, labels, title, aspect="auto")
        axes[1, j].plot(image.mean(axis=0), color="black", linewidth=0.8)
        axes[1, j].set_ylim(0, 120)
        axes[1, j].set_xlabel("column", fontsize=8)
        axes[1, j].set_ylabel("mean grey", fontsize=8)
    save_figure(figure, args.out, dpi=80)


if __name__ == "__main__":
    main()
