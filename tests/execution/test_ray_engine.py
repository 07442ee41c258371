"""The Ray engine on one local Ray of 2 CPUs for the whole module: order, errors, retries,
resuming, and the commands' results the same on either engine.

Starting Ray takes about ten seconds, so the module starts it once (`start_local_ray`, as the
executor does: 127.0.0.1 only, no dashboard) and every `RayExecutor` here joins it.
"""

from __future__ import annotations

import json
import os
import sys
from pathlib import Path

import executor_units
import numpy as np
import pytest
from cli_runner import run_main
from executor_units import CountedSquare, count_and_square, granted, refuse
from tiny_experiment import TINY

from resus.errors import ResusError
from resus.execution import (
    RayExecutor,
    Resources,
    make_executor,
    run_pending,
    start_local_ray,
)
from resus.experiments.tables import EXPERIMENT_PRESETS
from resus.sweep.io import read_sweep

ray = pytest.importorskip("ray")


@pytest.fixture(scope="module", autouse=True)
def local_ray():
    """One Ray of 2 CPUs for the module; the units of this module and of `executor_units`
    travel by value (its workers cannot import test modules by name)."""
    unit_modules = (sys.modules[__name__], executor_units)
    for module in unit_modules:
        ray.cloudpickle.register_pickle_by_value(module)
    start_local_ray(2)
    yield
    ray.shutdown()
    for module in unit_modules:
        ray.cloudpickle.unregister_pickle_by_value(module)


def die_once(marker: str) -> int:
    """The first run kills its worker (leaving a marker); the retry returns the worker's pid."""
    if not Path(marker).exists():
        Path(marker).touch()
        os._exit(1)
    return os.getpid()


def test_the_local_ray_listens_on_loopback_only():
    assert ray.get_runtime_context().gcs_address.startswith("127.0.0.1:")
    assert {node["NodeManagerAddress"] for node in ray.nodes()} == {"127.0.0.1"}


def test_ray_executor_keeps_order_grants_cpus_and_leaves_a_running_ray():
    with RayExecutor(2) as executor:
        assert executor.map(abs, [-3, 1, -2, 5], "t", "x", progress=False) == [3, 1, 2, 5]
        assert executor.map(abs, [], "t", "x") == []
        assert executor.map(granted, [0, 1], "t", "x", Resources(cpus=2), progress=False) == [2, 2]
    assert ray.is_initialized()  # the module's Ray: not this executor's to stop


def test_a_unit_error_is_raised_as_itself():
    with pytest.raises(ResusError, match=r"^item -2 is negative$"):
        RayExecutor(2).map(refuse, [1, -2, 3], "t", "x", progress=False)


def test_a_unit_no_node_can_run_is_refused_rather_than_waited_for():
    with pytest.raises(ResusError, match=r"t: a unit needs 3 CPUs, the Ray cluster has 2"):
        RayExecutor(2).map(abs, [1], "t", "x", Resources(cpus=3), progress=False)
    with pytest.raises(ResusError, match=r"t: a unit needs 0\.5 GPUs, the Ray cluster has 0"):
        RayExecutor(2).map(abs, [1], "t", "x", Resources(gpus=0.5), progress=False)


def test_a_killed_worker_has_its_unit_retried(tmp_path):
    markers = [str(tmp_path / f"died_{k}") for k in range(2)]
    pids = RayExecutor(2).map(die_once, markers, "t", "x", progress=False)
    assert all(Path(marker).exists() for marker in markers)  # each first run died
    assert all(pid != os.getpid() for pid in pids)


def test_a_resumed_ray_run_recomputes_nothing_that_finished(tmp_path):
    (tmp_path / "fail").touch()
    units = [CountedSquare(k, tmp_path) for k in range(6)]
    with pytest.raises(ResusError, match=r"unit 2 failed"):
        run_pending(RayExecutor(2), count_and_square, units, "t", "x", progress=False)
    records = [unit.record() for unit in units]
    finished = {k: r.path.stat().st_mtime_ns for k, r in enumerate(records) if r.done()}
    assert 2 not in finished
    (tmp_path / "fail").unlink()
    results = run_pending(RayExecutor(2), count_and_square, units, "t", "x", progress=False)
    assert results == [k * k for k in range(6)]
    runs = [len((tmp_path / f"ran_{k}").read_text().splitlines()) for k in range(6)]
    # a finished unit did not run again; one still running when unit 2 failed was cancelled
    # (possibly after its count, before its record) and ran again: that is the resume
    assert [runs[k] for k in finished] == [1] * len(finished) and max(runs) <= 2
    assert {k: records[k].path.stat().st_mtime_ns for k in finished} == finished


def sweeps_of(folder: Path) -> dict[str, object]:
    return {path.name: read_sweep(path) for path in sorted(folder.glob("*.h5"))}


@pytest.mark.slow
def test_simulate_subjects_writes_the_same_sweeps_on_ray(monkeypatch, capsys, tmp_path):
    short = ["--length", "0.01", "--frame-rate", "10"]  # 13 frames a sweep: enough to compare
    for engine in ("local", "ray"):
        status, out, err = run_main(
            monkeypatch, capsys, "simulate", "--subjects", "0-2", "--out", tmp_path / engine,
            *short, "--executor", engine,
        )  # fmt: skip
        assert status == 0, err
        assert out.count("wrote ") == 3
    local, on_ray = sweeps_of(tmp_path / "local"), sweeps_of(tmp_path / "ray")
    assert list(local) == list(on_ray) == ["subject_00.h5", "subject_01.h5", "subject_02.h5"]
    for name, sweep in local.items():
        other = on_ray[name]
        for field in ("frames", "labels", "probe_to_base", "timestamps", "wrench"):
            assert np.array_equal(getattr(sweep, field), getattr(other, field)), (name, field)
        assert sweep.subject == other.subject
    # a rerun keeps every sweep (and makes the missing one): nothing rewritten
    before = {p.name: p.stat().st_mtime_ns for p in (tmp_path / "ray").glob("*.h5")}
    status, out, _ = run_main(
        monkeypatch, capsys, "simulate", "--subjects", "0-3", "--out", tmp_path / "ray",
        *short, "--executor", "ray",
    )  # fmt: skip
    assert status == 0 and out.count("kept ") == 3 and out.count("wrote ") == 1
    after = {p.name: p.stat().st_mtime_ns for p in (tmp_path / "ray").glob("*.h5")}
    assert {name: after[name] for name in before} == before and "subject_03.h5" in after


# `experiment subjects --preset quick` takes minutes a run on 2 cores: this test runs the same
# command on a test-only preset, "tiny" (48 x 48 frames, 2 cm sweeps at 8 frames/s, the
# smallest U-Net for one epoch; tests/tiny_experiment.py), 3 subjects, regimes us and resus.
ENVIRONMENT = ("executor", "command", "data_folder", "seconds")
"""results.json entries that say how and where a run went, not what it found."""


def modified(folder: Path) -> dict[str, int]:
    return {str(p.relative_to(folder)): p.stat().st_mtime_ns for p in folder.rglob("*")
            if p.is_file()}  # fmt: skip


@pytest.mark.slow
def test_subjects_experiment_gives_the_same_results_on_either_engine_and_resumes(
    monkeypatch, capsys, tmp_path
):
    monkeypatch.setitem(EXPERIMENT_PRESETS, "tiny", TINY)
    command = ["experiment", "subjects", "--preset", "tiny", "--subjects", "3"]
    command += ["--regimes", "us,resus", "--device", "cpu", "--seed", "3"]
    results = {}
    for engine in ("local", "ray"):
        out = tmp_path / engine
        status, _, err = run_main(monkeypatch, capsys, *command, "--out", out, "--executor", engine)
        assert status == 0, err
        results[engine] = json.loads((out / "results.json").read_text())
    assert results["ray"]["executor"].startswith("ray")
    for saved in results.values():
        for name in ENVIRONMENT:
            saved.pop(name)
    assert results["local"] == results["ray"]
    assert set(results["ray"]["loso"]["regimes"]) == {"us", "resus"}

    data = tmp_path / "ray" / "data"
    units = sorted((data / "training" / "subjects").iterdir())
    assert len(units) == 3 * 2 * 2  # held-out subjects x regimes x seeds
    assert all((unit / "unit.json").is_file() for unit in units)
    before = modified(data)
    status, _, err = run_main(
        monkeypatch, capsys, *command, "--out", tmp_path / "ray", "--executor", "ray"
    )
    assert status == 0, err
    assert modified(data) == before  # no scan prepared, no model trained again
    again = json.loads((tmp_path / "ray" / "results.json").read_text())
    assert {k: v for k, v in again.items() if k not in ENVIRONMENT} == results["ray"]


def test_make_executor_joins_the_running_ray():
    with make_executor("ray", 5) as executor:
        assert executor.map(abs, [-1], "t", "x", progress=False) == [1]
    assert ray.cluster_resources()["CPU"] == 2  # the module's Ray, not one of 5 CPUs
