"""Render the default phantom and a few of its subjects to docs/phantom_subjects.png.

Top row: centrelines seen from above (x across, y along the leg; artery red, vein blue) over
the block's outline. Bottom row: the transverse cross-section at y = -30 mm (tissue grey,
artery red, vein blue, walls white).
"""

from __future__ import annotations

from pathlib import Path

import matplotlib

matplotlib.use("Agg")
import matplotlib.pyplot as plt
import numpy as np
from tqdm import tqdm

from sim.labels import label_colour_unit
from sim.phantom import ARTERY, VEIN, Phantom, load_phantom, make_subject

OUTPUT = Path(__file__).resolve().parents[1] / "docs" / "phantom_subjects.png"
SUBJECTS = (0, 1, 2, 3)
SECTION_Y = -0.030


def cross_section(phantom: Phantom, y: float, pixel: float = 0.2e-3) -> tuple[np.ndarray, tuple]:
    """RGB image of the plane y = const over the block's x-z extent."""
    sx, _, sz = phantom.spec.body.size
    x = np.arange(-sx / 2, sx / 2, pixel)
    z = np.arange(0.0, -sz, -pixel)
    grid_x, grid_z = np.meshgrid(x, z)
    points = np.stack([grid_x.ravel(), np.full(grid_x.size, y), grid_z.ravel()], axis=1)
    sample = phantom.sample(points)
    echo = np.array([m.echogenicity for m in phantom.materials])
    tissue = np.where(sample.material >= 0, echo[sample.material] / max(echo.max(), 1e-9), 0.0)
    image = np.repeat(0.3 + 0.5 * tissue[:, None], 3, axis=1)
    wall = np.zeros(len(points), bool)
    near = sample.vessel_index >= 0
    thickness = np.array([v.wall_thickness for v in phantom.spec.vessels])
    wall[near] = (sample.vessel_distance[near] >= 0) & (
        sample.vessel_distance[near] <= thickness[sample.vessel_index[near]]
    )
    image[wall] = 1.0
    image[sample.label == ARTERY] = (0.85, 0.15, 0.15)
    image[sample.label == VEIN] = (0.15, 0.3, 0.85)
    extent = (x[0] * 1e3, x[-1] * 1e3, z[-1] * 1e3, 0.0)
    return image.reshape(len(z), len(x), 3), extent


def main() -> None:
    spec = load_phantom("default")
    variants = [("default", spec)] + [(f"subject {k}", make_subject(spec, k)) for k in SUBJECTS]
    figure, axes = plt.subplots(2, len(variants), figsize=(3.2 * len(variants), 8))
    for column, (title, variant) in enumerate(tqdm(variants, desc="phantoms")):
        phantom = Phantom(variant)
        sx, sy, _ = variant.body.size
        top = axes[0, column]
        top.add_patch(plt.Rectangle((-sx / 2 * 1e3, -sy / 2 * 1e3), sx * 1e3, sy * 1e3, fill=False))
        for vessel, line in zip(variant.vessels, phantom.centrelines().values(), strict=True):
            top.plot(
                line[:, 0] * 1e3, line[:, 1] * 1e3, color=label_colour_unit(vessel.label), lw=1.5
            )
            top.annotate(vessel.name, line[-1, :2] * 1e3, fontsize=7, ha="center", va="bottom")
        top.axhline(SECTION_Y * 1e3, color="grey", ls=":", lw=0.8)
        top.set(title=title, xlabel="x (mm, lateral +)", ylabel="y (mm, distal +)", aspect="equal")
        top.invert_yaxis()
        image, extent = cross_section(phantom, SECTION_Y)
        bottom = axes[1, column]
        bottom.imshow(image, extent=extent, aspect="equal")
        bottom.set(title=f"y = {SECTION_Y * 1e3:.0f} mm", xlabel="x (mm)", ylabel="z (mm)")
    figure.suptitle("Femoral vessel phantom (right leg): default and seeded subjects")
    figure.tight_layout()
    OUTPUT.parent.mkdir(parents=True, exist_ok=True)
    figure.savefig(OUTPUT, dpi=110)
    print(OUTPUT)


if __name__ == "__main__":
    main()
