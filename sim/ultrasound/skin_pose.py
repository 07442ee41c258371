"""Probe poses placed on a phantom's skin: the usual way to aim the simulated probe."""

from __future__ import annotations

import numpy as np

from sim.phantom import Phantom
from sim.transforms import make_pose


def probe_pose_on_skin(
    phantom: Phantom,
    x: float,
    y: float,
    rotation: float = 0.0,
    tilt: float = 0.0,
    lift: float = 0.0,
) -> np.ndarray:
    """4x4 probe-to-phantom pose with the transducer face centred on the skin above (x, y).

    The beam (probe z) points along the inward skin normal; the array (probe x) lies along the
    phantom's +x (a transverse view of vessels running along y) turned by `rotation` (rad)
    about the beam. `tilt` (rad) rocks the probe about its array axis (the beam leans towards
    +y for positive tilt). `lift` (m) raises the probe off the skin along the normal (negative
    presses it in).
    """
    height = float(phantom.skin_height(np.asarray(x, np.float64), np.asarray(y, np.float64)))
    if np.isnan(height):
        raise ValueError(f"({x}, {y}) lies outside the skin of phantom {phantom.spec.name!r}")
    normal = phantom.skin_normal(np.asarray(x, np.float64), np.asarray(y, np.float64))
    beam = -normal
    across = np.array([1.0, 0.0, 0.0]) - beam[0] * beam
    across /= np.linalg.norm(across)
    elevation = np.cross(beam, across)
    array_axis = np.cos(rotation) * across + np.sin(rotation) * elevation
    elevation = np.cross(beam, array_axis)
    beam_tilted = np.cos(tilt) * beam - np.sin(tilt) * elevation
    elevation = np.cross(beam_tilted, array_axis)
    rotation_matrix = np.column_stack([array_axis, elevation, beam_tilted])
    position = np.array([x, y, height]) + lift * normal
    return make_pose(rotation_matrix, position)
