"""Synthetic labelled ultrasound-like images: dark vessel ellipses on Rayleigh speckle.

A stand-in for simulated sweeps when a test or a demo needs labelled images without the
simulator: an artery (round, bright wall) lateral to a vein (flattened, sometimes absent,
as when the probe collapses it), drifting smoothly from frame to frame like a sweep. Each
subject draws its own anatomy from its seed. `oblique=True` stretches and tilts the vessels,
the way reslices cut them at an angle.
"""

from __future__ import annotations

import numpy as np

from resus.segmentation.data import LabelledImages
from sim.labels import ARTERY, VEIN


def synthetic_subject(
    subject: str, count: int, size: int = 64, seed: int = 0, *, oblique: bool = False
) -> LabelledImages:
    """`count` images of `size` x `size` for one synthetic subject."""
    rng = np.random.default_rng(seed)
    t = np.linspace(0.0, 1.0, count)[:, None, None]
    rows, cols = (np.mgrid[0:size, 0:size] + 0.5) / size
    artery_radius = rng.uniform(0.08, 0.12)
    vein_axes = np.array([rng.uniform(0.12, 0.16), rng.uniform(0.05, 0.08)])
    drift = rng.uniform(0, 2 * np.pi)
    artery_col = rng.uniform(0.25, 0.35) + 0.06 * np.sin(2 * np.pi * t + drift)
    artery_row = rng.uniform(0.35, 0.55) + 0.04 * np.cos(2 * np.pi * t + drift)
    vein_col = artery_col + artery_radius + vein_axes[0] + rng.uniform(0.02, 0.06)
    vein_row = artery_row + rng.uniform(-0.05, 0.05)
    stretch, tilt = (rng.uniform(1.2, 1.6), rng.uniform(-0.5, 0.5)) if oblique else (1.0, 0.0)

    def ellipse(centre_row, centre_col, half_width, half_height):
        dc, dr = cols - centre_col, rows - centre_row
        u = (np.cos(tilt) * dc + np.sin(tilt) * dr) / (half_width * stretch)
        v = (-np.sin(tilt) * dc + np.cos(tilt) * dr) / half_height
        return u**2 + v**2

    artery = ellipse(artery_row, artery_col, artery_radius, artery_radius)
    vein = ellipse(vein_row, vein_col, *vein_axes)
    vein_present = (np.sin(6 * np.pi * t + drift) > -0.7) & np.ones_like(vein, dtype=bool)

    labels = np.zeros((count, size, size), dtype=np.uint8)
    labels[vein_present & (vein < 1)] = VEIN
    labels[artery < 1] = ARTERY
    depth_gain = 1.0 - 0.5 * rows
    echo = rng.rayleigh(1.0, (count, size, size)) * 70.0 * depth_gain
    echo[labels > 0] *= 0.15
    echo[(artery >= 1) & (artery < 1.4)] *= 2.2
    images = np.clip(echo, 0, 255).astype(np.uint8)
    return LabelledImages(images, labels, subject, source=f"synthetic:{subject}")
