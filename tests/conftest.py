"""Fixtures shared across the suite: a hang guard, the default phantoms and the shared robot.

Helper modules beside this file (`cli_runner`, `sweep_samples`, `shared_data`, ...) are on the
import path through `pythonpath` in pyproject.toml.
"""

from __future__ import annotations

import faulthandler

import pytest

from sim.phantom import Phantom, load_phantom
from sim.robot import SimulatedUR3e

HANG_TIMEOUT = 150.0
"""Seconds after which a test marked `hang_guard` aborts the test process with tracebacks."""


@pytest.fixture(autouse=True)
def _hang_guard(request: pytest.FixtureRequest):
    """ur_rtde blocks holding the GIL: a hung call ends the run with tracebacks, not silence."""
    if request.node.get_closest_marker("hang_guard") is None:
        yield
        return
    faulthandler.dump_traceback_later(HANG_TIMEOUT, exit=True)
    yield
    faulthandler.cancel_dump_traceback_later()


@pytest.fixture(scope="session")
def default_phantom() -> Phantom:
    """The gel-block phantom of the default scene."""
    return Phantom(load_phantom("default"))


@pytest.fixture(scope="session")
def leg_phantom() -> Phantom:
    """The leg phantom."""
    return Phantom(load_phantom("leg"))


@pytest.fixture(scope="module")
def shared_robot() -> SimulatedUR3e:
    """One simulated UR3e per test module (building the MuJoCo model takes a while)."""
    return SimulatedUR3e()


@pytest.fixture
def robot(shared_robot: SimulatedUR3e) -> SimulatedUR3e:
    """The module's robot, reset to its home pose for each test."""
    shared_robot.reset()
    return shared_robot
