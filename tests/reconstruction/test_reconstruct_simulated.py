"""Reconstructing a simulated sweep gives back the phantom's vessels (issue 4's Dice check)."""

import numpy as np
import pytest

from resus.acquisition.backends.simulated import SimulatedProbeConfig
from resus.acquisition.patterns import LinearPattern
from resus.acquisition.simulation import phantom_spec, resolve_scene, simulate_sweep
from resus.reconstruction.compounding import ReconstructionSettings, reconstruct
from resus.reconstruction.grid import aabb_grid
from resus.sweep.io import read_sweep
from sim.phantom import Phantom
from sim.transforms import invert_pose
from sim.ultrasound.probe import LinearProbe


@pytest.fixture(scope="module")
def simulated(tmp_path_factory):
    scene = resolve_scene("default", None, 2)
    path = tmp_path_factory.mktemp("sim") / "sweep.h5"
    probe = SimulatedProbeConfig(probe=LinearProbe(cols=128, rows=128), frame_rate=30.0)
    simulate_sweep(path, scene, LinearPattern(length=0.02), probe=probe, progress=False)
    return scene, read_sweep(path)


def dice(a: np.ndarray, b: np.ndarray) -> float:
    return 2.0 * np.sum(a & b) / (np.sum(a) + np.sum(b))


def test_label_volume_matches_the_phantom(simulated) -> None:
    scene, sweep = simulated
    grid = aabb_grid(
        0.4e-3,
        poses=sweep.probe_to_base,
        image_to_probe=sweep.image_to_probe,
        frame_shape=sweep.frame_shape,
    )
    result = reconstruct(
        sweep.frames,
        sweep.probe_to_base,
        sweep.image_to_probe,
        grid,
        ReconstructionSettings(),
        labels=sweep.labels,
        n_classes=3,
    )
    # Truth: the phantom's exact labels at the voxel centres, in the phantom frame.
    index = np.indices(grid.shape).reshape(3, -1).T
    world = grid.to_world(index)
    base_to_phantom = invert_pose(scene.phantom_to_base)
    in_phantom = world @ base_to_phantom[:3, :3].T + base_to_phantom[:3, 3]
    truth = Phantom(phantom_spec(scene)).labels(in_phantom).reshape(grid.shape)
    seen = result.filled
    assert seen.mean() > 0.5
    for label in (1, 2):
        score = dice(result.labels[seen] == label, truth[seen] == label)
        assert score >= 0.9, f"class {label}: Dice {score:.3f}"
