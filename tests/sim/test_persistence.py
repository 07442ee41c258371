"""Persistence: the recursive frame average against a hand computation, and a simulated scan
whose frames follow that recursion from the same scan's unaveraged frames, labels untouched."""

from __future__ import annotations

import dataclasses

import numpy as np
import pytest

from resus.acquisition.backends.simulated import SimulatedProbeConfig
from resus.acquisition.patterns import LinearPattern
from resus.acquisition.simulation import resolve_scene, simulate_sweep
from resus.sweep.io import read_sweep
from sim.ultrasound.persistence import Persistence
from sim.ultrasound.probe import LinearProbe
from sim.ultrasound.settings import UltrasoundSettings


def test_each_displayed_image_weighs_the_previous_one_by_the_persistence() -> None:
    frames = [np.full((2, 3), value, np.uint8) for value in (100, 200, 0)]
    average = Persistence(0.25)
    shown = [average(frame)[0, 0] for frame in frames]
    # 100; 0.25 * 100 + 0.75 * 200 = 175; 0.25 * 175 + 0.75 * 0 = 43.75
    assert shown == [100, 175, 44]
    assert average(np.full((4, 4), 9, np.uint8))[0, 0] == 9  # another size starts afresh
    frame = np.arange(6, dtype=np.uint8).reshape(2, 3)
    assert Persistence(0.0)(frame) is frame


@pytest.mark.parametrize("weight", [1.0, -0.2])
def test_a_persistence_outside_zero_to_one_is_refused(weight: float) -> None:
    with pytest.raises(ValueError, match=rf"persistence must be in \[0, 1\), got {weight}"):
        Persistence(weight)
    with pytest.raises(ValueError, match=r"setting persistence must be in \[0, 1\)"):
        UltrasoundSettings(persistence=weight)


def test_a_simulated_scan_shows_its_frames_through_the_persistence(tmp_path) -> None:
    scene = resolve_scene("default", None, None)
    plain = SimulatedProbeConfig(probe=LinearProbe(cols=48, rows=48), frame_rate=30.0)
    averaged = dataclasses.replace(
        plain, settings=dataclasses.replace(plain.settings, persistence=0.6)
    )
    sweeps = []
    for name, config in (("plain", plain), ("averaged", averaged)):
        path = tmp_path / f"{name}.h5"
        simulate_sweep(path, scene, LinearPattern(length=0.006), probe=config, progress=False)
        sweeps.append(read_sweep(path))
    plain_sweep, averaged_sweep = sweeps
    assert np.array_equal(plain_sweep.probe_to_base, averaged_sweep.probe_to_base)
    assert np.array_equal(plain_sweep.labels, averaged_sweep.labels)
    assert len(plain_sweep.frames) > 5 and plain_sweep.frames.any()
    # Frames taken before recording began (the approach) are in the average too, so the
    # check is the recursion itself: each shown frame from the previous shown one and the
    # frame's own image, within the rounding of the shown frames (0.6 * 0.5 + 0.5 levels).
    shown = averaged_sweep.frames.astype(np.float64)
    own = plain_sweep.frames.astype(np.float64)
    recursion = 0.6 * shown[:-1] + 0.4 * own[1:]
    assert np.abs(shown[1:] - recursion).max() <= 0.8 + 1e-9
    assert np.abs(shown - own).mean() > 1.0  # the average changed what is shown
