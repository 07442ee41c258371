"""Fixtures shared across the suite: a hang guard, the default phantoms and the shared robot.

Helper modules beside this file (`cli_runner`, `sweep_samples`, `shared_data`, ...) are on the
import path through `pythonpath` in pyproject.toml.
"""

from __future__ import annotations

import faulthandler

import pytest

from sim.phantom import Phantom, load_phantom
from sim.robot import SimulatedUR3e
from sim.robot.kinematics import forward_kinematics, inverse_kinematics
from sim.ultrasound.deformation import TissueLoad
from sim.ultrasound.scanner import scanner_preset
from sim.ultrasound.simulator import UltrasoundSimulator
from sim.ultrasound.skin_pose import probe_pose_on_skin

HANG_TIMEOUT = 150.0
"""Seconds after which a test marked `hang_guard` aborts the test process with tracebacks."""


def pytest_configure(config: pytest.Config) -> None:
    """Compile the real-time kernels once, before any test process starts.

    Numba caches compiled kernels beside their sources; on a fresh clone (CI) there is no
    cache yet, and each process compiles what it calls, about 40 s for the ultrasound kernels.
    Left to the tests, both xdist workers and the render and emulator processes that the scan
    tests start would compile at once, and a real-time scan starved of CPU records only part
    of its sweep. Here the controller (or a run without xdist) fills the cache first: render a
    frame rigid and pressed, and solve the arm's kinematics and a simulation step."""
    if hasattr(config, "workerinput"):  # an xdist worker: the controller has done it
        return
    phantom = Phantom(load_phantom("femoral"))
    preset = scanner_preset("vascular")
    simulator = UltrasoundSimulator(phantom, preset.probe(), preset.settings())
    pose = probe_pose_on_skin(phantom, 0.0, 0.0)
    simulator.render(pose)
    pose[:3, 3] += 0.003 * pose[:3, 2]
    simulator.render(pose, TissueLoad(4.0, 0.0))
    robot = SimulatedUR3e()
    inverse_kinematics(forward_kinematics(robot.joint_positions()), robot.joint_positions())
    robot.step()


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
