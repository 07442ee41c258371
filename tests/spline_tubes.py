"""A tube's centreline as `VesselSpec` defines it, sampled densely, and distances to it: the
independent geometry that tests hold the phantom's round-cone chains against."""

from __future__ import annotations

import numpy as np
from scipy.interpolate import CubicSpline

from sim.phantom.spec import VesselSpec


def centreline(tube: VesselSpec, count: int = 4000) -> np.ndarray:
    """The tube's centreline as the spec defines it: scipy's not-a-knot cubic spline over the
    control points' cumulative chord length, sampled densely."""
    points = tube.control_points
    chord = np.concatenate([[0.0], np.cumsum(np.linalg.norm(np.diff(points, axis=0), axis=1))])
    return CubicSpline(chord, points, bc_type="not-a-knot")(np.linspace(0, chord[-1], count))


def distance_to(points: np.ndarray, curve: np.ndarray) -> np.ndarray:
    """Distance of each point to the nearest sample of `curve`."""
    return np.array([np.linalg.norm(curve - p, axis=1).min() for p in points])
