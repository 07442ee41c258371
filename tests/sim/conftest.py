"""Fixtures of the simulator tests: phantom specs built from scratch around test vessels."""

from __future__ import annotations

from collections.abc import Callable

import pytest

from sim.phantom import BodySpec, Layer, Material, PhantomSpec, VesselSpec
from sim.phantom.mechanics import TissueMechanics

GEL = Layer("gel", 0.5, 0.5, 1.55)
BLOOD = Material("blood", 0.02, 0.18, 1.61)
WALL = Material("wall", 1.0, 0.6, 1.7)


@pytest.fixture(scope="session")
def gel_block_spec() -> Callable[..., PhantomSpec]:
    """Builds `(name, size, vessels, mechanics=None)`: a right-side spec of `vessels` in one
    homogeneous gel block of `size` (x, y, z; m), no bone: the plainest tissue around vessels
    whose geometry a test computes itself."""

    def build(
        name: str,
        size: tuple[float, float, float],
        vessels: tuple[VesselSpec, ...],
        mechanics: TissueMechanics | None = None,
    ) -> PhantomSpec:
        body = BodySpec("block", size)
        return PhantomSpec(
            name, "right", body, (GEL,), BLOOD, WALL, None, vessels, mechanics=mechanics
        )

    return build
