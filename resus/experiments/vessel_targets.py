"""Where a sonographer looks for the femoral vessels in a phantom: their depth and the
lateral position to centre the probe on, read from the phantom's tube centrelines at one
transverse plane."""

from __future__ import annotations

from typing import TYPE_CHECKING

import numpy as np

from resus.errors import ResusError

if TYPE_CHECKING:
    from sim.phantom import PhantomSpec


def _vessel_crossings(spec: PhantomSpec, y: float) -> list[tuple[int, np.ndarray, float]]:
    """(label, centre, radius) of each artery and vein tube where it crosses the transverse
    plane at `y` (its nearest centreline node)."""
    from sim.phantom.centreline import sample_tube

    crossings = []
    for vessel in spec.vessels:
        tube = sample_tube(vessel)
        if vessel.label and tube.nodes[:, 1].min() <= y <= tube.nodes[:, 1].max():
            nearest = int(np.argmin(np.abs(tube.nodes[:, 1] - y)))
            crossings.append((vessel.label, tube.nodes[nearest], float(tube.radii[nearest])))
    if not crossings:
        raise ResusError(f"phantom {spec.name!r} has no vessel crossing y = {y:.3f} m")
    return crossings


def vessel_depth(spec: PhantomSpec, y: float) -> float:
    """Mean depth (m, below the phantom's top line) of the centres of the artery and vein
    tubes that cross the transverse plane at `y`: where a sonographer looks for them."""
    return float(np.mean([-centre[2] for _, centre, _ in _vessel_crossings(spec, y)]))


def vessel_midline(spec: PhantomSpec, y: float) -> float:
    """Lateral position (m, phantom x) a sonographer centres the probe on at `y`: midway
    between the widest artery and the widest vein crossing that plane (one of them alone
    where only one crosses), so both are in view and side branches do not pull it aside."""
    widest: dict[int, tuple[float, float]] = {}
    for label, centre, radius in _vessel_crossings(spec, y):
        if label not in widest or radius > widest[label][0]:
            widest[label] = (radius, float(centre[0]))
    return float(np.mean([x for _, x in widest.values()]))
