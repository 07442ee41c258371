"""Save a grid of simulated B-mode frames with their labels outlined: docs/simulated_frames.png.

Rows: the default gel phantom at a few places along the vessels (transverse, oblique,
longitudinal, half off the block, tipped off the skin), two generated subjects, and the leg
phantom (skin, fat, muscle, femur), pressed in or resting on the curved skin. Artery outlines
are red, vein outlines blue.

    python scripts/show_ultrasound.py [--out docs/simulated_frames.png]
"""

from __future__ import annotations

import argparse
from pathlib import Path

import matplotlib

matplotlib.use("Agg")
import matplotlib.pyplot as plt
import numpy as np
from figure_output import save_figure
from tqdm import tqdm

from sim.phantom import ARTERY, VEIN, Phantom, load_phantom, make_subject
from sim.ultrasound.simulator import UltrasoundSimulator
from sim.ultrasound.skin_pose import probe_pose_on_skin

LEG_PRESS = -0.0027
"""A flat 38 mm probe on the 70 mm radius thigh is 2.6 mm off the skin at its ends: press it
in (the phantom is rigid, so the top of the tissue is simply cut away) for full contact."""
VIEWS = (
    ("default", None, "transverse y=-60 mm", dict(x=0.0, y=-0.06)),
    ("default", None, "transverse y=+30 mm", dict(x=0.0, y=0.03)),
    ("default", None, "oblique 40 deg, tilt 10 deg", dict(x=0.0, y=0.0, rotation=0.7, tilt=0.17)),
    ("default", None, "longitudinal over the artery", dict(x=0.007, y=0.0, rotation=np.pi / 2)),
    ("default", 3, "subject 3, y=-40 mm", dict(x=0.0, y=-0.04)),
    ("default", 7, "subject 7, y=+20 mm", dict(x=0.0, y=0.02)),
    ("default", None, "edge of the block (half off)", dict(x=0.045, y=0.0)),
    ("default", None, "lifted 5 mm at one end", dict(x=0.0, y=-0.02)),
    ("leg", None, "leg, y=-40 mm", dict(x=0.005, y=-0.04, lift=LEG_PRESS)),
    ("leg", None, "leg, y=+20 mm (femur)", dict(x=0.012, y=0.02, lift=LEG_PRESS)),
    ("leg", 2, "leg subject 2", dict(x=0.005, y=0.0, lift=LEG_PRESS)),
    ("leg", None, "leg, not pressed in", dict(x=0.005, y=-0.01)),
)


def tipped_pose(phantom: Phantom, x: float, y: float) -> np.ndarray:
    """A probe resting on the skin with one end of its array, the other end 5 mm above it."""
    pose = probe_pose_on_skin(phantom, x, y)
    half_width = UltrasoundSimulator(phantom).probe.width / 2
    angle = np.arcsin(0.005 / (2 * half_width))
    c, s = np.cos(angle), np.sin(angle)
    pivot = np.eye(4)
    pivot[0, 3] = -half_width
    turn = np.eye(4)
    turn[:3, :3] = [[c, 0.0, s], [0.0, 1.0, 0.0], [-s, 0.0, c]]
    return pose @ pivot @ turn @ np.linalg.inv(pivot)


def outline(labels: np.ndarray, value: int) -> np.ndarray:
    """Pixels of class `value` that touch another class (4-neighbourhood)."""
    mask = labels == value
    inner = mask.copy()
    inner[1:, :] &= mask[:-1, :]
    inner[:-1, :] &= mask[1:, :]
    inner[:, 1:] &= mask[:, :-1]
    inner[:, :-1] &= mask[:, 1:]
    return mask & ~inner


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--out", type=Path, default=Path("docs/simulated_frames.png"))
    args = parser.parse_args()
    simulators: dict[tuple[str, int | None], UltrasoundSimulator] = {}
    columns = 4
    rows = -(-len(VIEWS) // columns)
    figure, axes = plt.subplots(rows, columns, figsize=(4 * columns, 4.3 * rows))
    for axis, (name, subject, title, where) in tqdm(
        zip(axes.ravel(), VIEWS, strict=True), total=len(VIEWS), desc="frames"
    ):
        key = (name, subject)
        if key not in simulators:
            spec = load_phantom(name)
            simulators[key] = UltrasoundSimulator(
                Phantom(spec if subject is None else make_subject(spec, subject))
            )
        simulator = simulators[key]
        if title.startswith("lifted"):
            pose = tipped_pose(simulator.phantom, **where)
        else:
            pose = probe_pose_on_skin(simulator.phantom, **where)
        image, labels = simulator.render(pose)
        rgb = np.repeat(image[..., None], 3, axis=2)
        rgb[outline(labels, ARTERY)] = (255, 40, 40)
        rgb[outline(labels, VEIN)] = (60, 120, 255)
        probe = simulator.probe
        extent = (-probe.width / 2 * 1e3, probe.width / 2 * 1e3, probe.depth * 1e3, 0.0)
        axis.imshow(rgb, extent=extent, interpolation="nearest")
        axis.set_title(f"{name}: {title}", fontsize=9)
        axis.set_xlabel("x (mm)", fontsize=8)
        axis.set_ylabel("depth (mm)", fontsize=8)
        axis.tick_params(labelsize=7)
    figure.suptitle("Synthetic B-mode (red: artery, blue: vein outlines from the phantom)")
    save_figure(figure, args.out, dpi=110)


if __name__ == "__main__":
    main()
