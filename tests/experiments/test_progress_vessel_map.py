"""The vessel-map stage's progress: a bar over the steps of each map with rate and time left,
one bar for several maps (the demo's), and nothing at all with progress off.

The sweep is simulated but marked as a real scan, so that no map is scored against the
phantom (seconds each, and not what these tests are about).
"""

from __future__ import annotations

import dataclasses
import re

import pytest
from simulated_sweeps import simulate_vessel_sweep

from resus.acquisition.simulation import resolve_scene
from resus.sweep.io import read_sweep
from resus.vessels.map import VesselMapSettings
from resus.vessels.pipeline import MAP_STEPS, VesselJob, map_progress, map_vessels

COARSE = VesselJob(map=VesselMapSettings(spacing=0.8e-3, smoothing_iterations=0))


@pytest.fixture(scope="module")
def sweep(tmp_path_factory):
    path = tmp_path_factory.mktemp("progress") / "sweep.h5"
    simulate_vessel_sweep(path, start_y=-0.01, length=0.02, pixels=48)
    return dataclasses.replace(read_sweep(path), source="real")


def test_one_map_shows_each_step_with_rate_and_time_left(sweep, tmp_path, capsys) -> None:
    scene = resolve_scene("default", None, None)
    map_vessels(sweep, sweep.labels, scene, tmp_path / "one", {}, COARSE, progress=True)
    shown = capsys.readouterr().err
    steps = len(MAP_STEPS)
    final = re.findall(
        rf"vessel map: 100%.*{steps}/{steps} \[[\d:]+<[\d:]+, *[\d.]+(s/step|step/s)", shown
    )
    assert final, shown
    assert MAP_STEPS[-1] in shown


def test_several_maps_share_one_bar(sweep, tmp_path, capsys) -> None:
    scene = resolve_scene("default", None, None)
    with map_progress(2) as bar:
        for name in ("a", "b"):
            map_vessels(sweep, sweep.labels, scene, tmp_path / name, {}, COARSE, progress=bar)
        assert bar.n == 2 * len(MAP_STEPS)
    shown = capsys.readouterr().err
    assert "vessel maps: 100%" in shown and "vessel map:" not in shown


def test_no_bar_without_progress(sweep, tmp_path, capsys) -> None:
    scene = resolve_scene("default", None, None)
    result = map_vessels(sweep, sweep.labels, scene, tmp_path / "quiet", {}, COARSE)
    assert capsys.readouterr().err == ""
    assert result.scores is None and set(result.meshes) == {"artery", "vein"}
