"""Short simulated sweeps of the default scene, for the vessel-map tests (the simulator runs)."""

from __future__ import annotations

from pathlib import Path

from resus.acquisition.backends.simulated import SimulatedProbeConfig
from resus.acquisition.patterns import LinearPattern
from resus.acquisition.simulation import resolve_scene, simulate_sweep
from sim.ultrasound.probe import LinearProbe


def simulate_vessel_sweep(path: Path, *, start_y: float, length: float, pixels: int) -> Path:
    """Simulate into `path` a linear sweep of the default scene at 25 mm/s, from `start_y` (m)
    along the leg for `length` (m), with `pixels` x `pixels` frames 4 cm deep; returns `path`."""
    simulate_sweep(
        path,
        resolve_scene("default", None, None),
        LinearPattern(start=(0.0, start_y), length=length, speed=0.025),
        probe=SimulatedProbeConfig(probe=LinearProbe(cols=pixels, rows=pixels, depth=0.04)),
        progress=False,
    )
    return path
