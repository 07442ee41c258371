"""Hole filling: passes of growing radius, fed by observed voxels only."""

import numpy as np

from resus.reconstruction.compounding import ReconstructionSettings, fill_holes_in_passes
from resus.reconstruction.grid import VolumeGrid

GRID = VolumeGrid(origin=np.zeros(3), axes=np.eye(3) * 1e-3, shape=(9, 9, 9))


def fill(channels: np.ndarray, observed: np.ndarray, passes: int, alpha: float = 0.1) -> np.ndarray:
    settings = ReconstructionSettings(fill_passes=passes, fill_radius_step=1.0, fill_alpha=alpha)
    return fill_holes_in_passes(channels, observed, GRID, settings)


def test_filled_voxels_never_change_and_far_holes_stay_holes() -> None:
    rng = np.random.default_rng(0)
    observed = rng.random(GRID.shape) < 0.3
    observed[:, :, 6:] = False
    channels = rng.uniform(0, 255, size=(2, *GRID.shape)).astype(np.float32)
    channels[:, ~observed] = 0
    before = channels.copy()
    filled = fill(channels, observed, passes=2)
    np.testing.assert_array_equal(channels[:, observed], before[:, observed])
    assert filled[observed].all()
    assert not filled[:, :, 8].any()  # farther than 2 voxels from every observed voxel
    # every filled hole is a weighted mean of observed values: inside their range
    holes = filled & ~observed
    assert holes.sum() > 50
    assert channels[0][holes].min() >= before[0][observed].min()
    assert channels[0][holes].max() <= before[0][observed].max()


def test_holes_never_feed_holes() -> None:
    observed = np.zeros(GRID.shape, dtype=bool)
    observed[4, 4, 0] = True  # one observed voxel at the bottom of a column of holes
    channels = np.zeros((1, *GRID.shape), dtype=np.float32)
    channels[0, 4, 4, 0] = 90.0
    filled = fill(channels, observed, passes=1)
    assert filled[4, 4, 1] and not filled[4, 4, 2]  # the pass-1 hole does not pass it on
    filled = fill(channels, observed, passes=3)
    assert filled[4, 4, 1] and filled[4, 4, 2] and filled[4, 4, 3] and not filled[4, 4, 4]
    np.testing.assert_allclose(channels[0, 4, 4, 1:4], 90.0)


def test_each_pass_takes_the_weighted_mean_of_its_radius() -> None:
    observed = np.zeros(GRID.shape, dtype=bool)
    channels = np.zeros((1, *GRID.shape), dtype=np.float32)
    for position, value in (((2, 4, 4), 10.0), ((4, 5, 4), 40.0), ((7, 4, 4), 200.0)):
        observed[position] = True
        channels[(0, *position)] = value
    fill(channels, observed, passes=3, alpha=0.1)
    # hole (4, 4, 4): pass 1 (radius 1 mm) sees only (4, 5, 4)
    assert channels[0, 4, 4, 4] == 40.0
    # hole (3, 4, 3): pass 1 nothing; pass 2 (radius 2 mm) sees (2,4,4) at sqrt2,
    # (4,5,4) at sqrt3
    w = 1 / (np.sqrt([2.0, 3.0]) + 0.1) ** 2
    np.testing.assert_allclose(channels[0, 3, 4, 3], (w @ [10.0, 40.0]) / w.sum(), rtol=1e-6)
    # hole (3, 3, 4) at sqrt2 from (2,4,4) and sqrt5 from (4,5,4): pass 2 sees only the first
    assert channels[0, 3, 3, 4] == 10.0
