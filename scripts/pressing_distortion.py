"""What pressing does to reconstruction: vessel maps of pressed sweeps against the rigid phantom.

One linear sweep over the femoral phantom's vessels (subject 0, 40 mm distal, transverse),
scanned in force mode at a constant 2, 4 and 8 N, with a force that swings between 2 and 10 N
(a `force_profile`, 1 Hz), and in the rigid world at 4 N. Each sweep's true labels are
compounded into a vessel map (`resus vessels --labels-from-sweep`) and scored against the
rigid, undeformed phantom: Dice (volume overlap) and mean surface distance per vessel class.
The veins flatten under the probe, so their maps lose volume as the force grows; what matters
for reconstruction is that at a constant force the loss is steady along the sweep, while a
varying force makes the map's cross-section change from frame to frame.

    python scripts/pressing_distortion.py [--out /tmp/pressing] [--length 0.04]

Last line: JSON {case: {"force_mean", "force_std", "artery_dice", "vein_dice",
"artery_msd_mm", "vein_msd_mm", "vein_area_cv"}}.
"""

from __future__ import annotations

import argparse
import dataclasses
import json
from pathlib import Path

import numpy as np

from resus.acquisition.patterns import LinearPattern
from resus.acquisition.simulation import phantom_spec, resolve_scene, simulate_sweep
from resus.sweep.io import read_sweep
from resus.vessels.pipeline import map_vessels
from sim.labels import VEIN
from sim.phantom import Phantom

SWING = (2.0, 10.0)
"""Force range (N) of the varying-force sweep."""
SWING_PERIOD = 1.0
"""Seconds per force cycle of the varying-force sweep."""


def cases(length: float) -> dict[str, tuple[LinearPattern, list[tuple[float, float]] | None, bool]]:
    """Case name -> (pattern, force profile or None, rigid)."""

    def sweep(force: float) -> LinearPattern:
        return LinearPattern(start=(0.0, -length / 2), length=length, contact_force=force)

    duration = length / sweep(4.0).speed + 1.0
    times = np.arange(0.0, duration, SWING_PERIOD / 8)
    low, high = SWING
    swing = low + (high - low) * 0.5 * (1.0 - np.cos(2 * np.pi * times / SWING_PERIOD))
    return {
        "rigid world, 4 N": (sweep(4.0), None, True),
        "constant 2 N": (sweep(2.0), None, False),
        "constant 4 N": (sweep(4.0), None, False),
        "constant 8 N": (sweep(8.0), None, False),
        f"varying {low:g}-{high:g} N": (sweep(low), list(zip(times, swing, strict=True)), False),
    }


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--out", type=Path, default=Path("/tmp/pressing"))
    parser.add_argument("--length", type=float, default=0.04)
    args = parser.parse_args()
    args.out.mkdir(parents=True, exist_ok=True)
    scene = resolve_scene("default", "femoral", 0)
    phantom = Phantom(phantom_spec(scene))
    results = {}
    for number, (name, (pattern, profile, rigid)) in enumerate(cases(args.length).items()):
        trajectory = pattern.trajectory(phantom, scene.phantom_to_base)
        if profile is not None:
            trajectory = dataclasses.replace(trajectory, force_profile=tuple(profile))
        path = args.out / f"case{number}.h5"
        simulate_sweep(path, scene, trajectory, progress=False, rigid=rigid)
        sweep = read_sweep(path)
        force = sweep.axial_force
        assert sweep.labels is not None and force is not None
        mapped = map_vessels(
            sweep, sweep.labels, scene, args.out / f"case{number}", {"sweep": path.name}
        )
        scores = mapped.scores_to_dict()
        assert isinstance(scores, dict)
        vein_area = (sweep.labels == VEIN).sum(axis=(1, 2)).astype(float)
        results[name] = {
            "force_mean": round(float(force.mean()), 2),
            "force_std": round(float(force.std()), 2),
            **{
                f"{vessel}_{key}": round(float(scores[vessel][field]), 3)
                for vessel in ("artery", "vein")
                for key, field in (("dice", "dice"), ("msd_mm", "mean_surface_distance_mm"))
            },
            "vein_area_cv": round(float(vein_area.std() / vein_area.mean()), 3),
        }
        print(name, results[name], flush=True)
    print(json.dumps(results))


if __name__ == "__main__":
    main()
