"""Small synthetic sweeps for the sweep tests (no simulator needed)."""

from __future__ import annotations

import numpy as np
from scipy.spatial.transform import Rotation

from resus.sweep.model import Sweep
from sim.transforms import make_pose
from sim.ultrasound.probe import LinearProbe

STEP = 1e-3
"""Probe travel between consecutive frames (m), along the world y axis."""


def sample_poses(n: int, *, rotate: bool = True, seed: int = 0) -> np.ndarray:
    """`n` rigid poses 1 mm apart along y; random orientations if `rotate`."""
    rotations = (
        Rotation.random(n, random_state=seed).as_matrix()
        if rotate
        else np.repeat(np.eye(3)[None], n, 0)
    )
    return np.stack([make_pose(r, (0.1, 0.2 + i * STEP, 0.05)) for i, r in enumerate(rotations)])


def sample_sweep(
    n: int = 6,
    rows: int = 24,
    cols: int = 32,
    *,
    seed: int = 0,
    optional: bool = True,
    rotate: bool = True,
) -> Sweep:
    """A random but valid sweep; with labels, wrench and joints when `optional`."""
    rng = np.random.default_rng(seed)
    probe = LinearProbe(cols=cols, rows=rows)
    return Sweep(
        frames=rng.integers(0, 256, (n, rows, cols), dtype=np.uint8),
        probe_to_base=sample_poses(n, rotate=rotate, seed=seed),
        timestamps=10.0 + 0.05 * np.arange(n) + rng.uniform(0, 0.01, n),
        image_to_probe=probe.image_to_probe(),
        labels=rng.integers(0, 3, (n, rows, cols), dtype=np.uint8) if optional else None,
        wrench=rng.normal(size=(n, 6)) if optional else None,
        joint_positions=rng.uniform(-np.pi, np.pi, (n, 6)) if optional else None,
        source="sim",
        subject="phantom-7",
        created="2024-05-01T12:30:00+00:00",
    )
