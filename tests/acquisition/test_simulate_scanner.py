"""`resus simulate`: a scanner preset reaches the Sweep file; what a `--subjects` rerun keeps,
through the command and through the library's `simulate_subject_sweeps`."""

from __future__ import annotations

import json

import numpy as np
import pytest
from cli_runner import run_main

from resus.acquisition.patterns import LinearPattern
from resus.acquisition.simulation import (
    DONE_FOLDER,
    SimulatedSweepJob,
    phantom_spec,
    resolve_scene,
    simulate_subject_sweeps,
    simulated_truth,
)
from resus.errors import ResusError
from resus.execution import LocalExecutor
from resus.sweep.io import read_sweep
from sim.fingerprint import simulator_fingerprint
from sim.phantom import Phantom, phantom_digest
from sim.ultrasound.scanner import scanner_preset

SHORT = ("--length", "0.006", "--speed", "0.02", "--frame-rate", "10", "--force", "0")


def test_a_preset_sets_the_recorded_pixel_spacing_and_darkens_the_frames(
    monkeypatch, capsys, tmp_path
) -> None:
    plain, nerve = tmp_path / "plain.h5", tmp_path / "nerve.h5"
    assert run_main(monkeypatch, capsys, "simulate", "--out", str(plain), *SHORT)[0] == 0
    status = run_main(
        monkeypatch, capsys, "simulate", "--out", str(nerve), "--scanner", "nerve", *SHORT
    )[0]
    assert status == 0
    plain_sweep, nerve_sweep = read_sweep(plain), read_sweep(nerve)
    preset = scanner_preset("nerve")
    rows = nerve_sweep.frames.shape[1]
    # image_to_probe's second column is the step from one row to the next, in metres
    np.testing.assert_allclose(
        np.linalg.norm(nerve_sweep.image_to_probe[:3, 1]), preset.depth / rows, rtol=1e-9
    )
    np.testing.assert_allclose(
        np.linalg.norm(plain_sweep.image_to_probe[:3, 1]), 0.05 / rows, rtol=1e-9
    )
    assert nerve_sweep.frames.mean() < 0.6 * plain_sweep.frames.mean()  # a darker preset


def test_random_scanner_draws_one_preset_per_subject(monkeypatch, capsys, tmp_path) -> None:
    out = tmp_path / "subjects"
    out.mkdir()
    args = ("simulate", "--out", str(out), "--subjects", "0-1", "--jobs", "1")
    assert run_main(monkeypatch, capsys, *args, "--scanner", "random", *SHORT)[0] == 0
    first, second = (read_sweep(path) for path in sorted(out.glob("*.h5")))
    assert not np.isclose(
        np.linalg.norm(first.image_to_probe[:3, 1]), np.linalg.norm(second.image_to_probe[:3, 1])
    )
    # a rerun keeps both, unless another simulator made one (its record's fingerprint differs)
    record_path = out / ".done" / "subject_01.json"
    record = json.loads(record_path.read_text())
    assert record["key"]["simulator"] == simulator_fingerprint()
    record_path.write_text(json.dumps({**record, "key": {**record["key"], "simulator": "0" * 16}}))
    status, printed, _ = run_main(monkeypatch, capsys, *args, "--scanner", "random", *SHORT)
    assert status == 0 and printed.count("kept ") == 1 and printed.count("wrote ") == 1
    assert f"kept {out / 'subject_00.h5'}" in printed


def test_a_phantom_file_edited_in_place_makes_its_sweeps_again(monkeypatch, capsys, tmp_path):
    """A spec file keeps its name when edited: the sweep records its digest, the rerun makes
    the sweep again, and the old sweep is not scored against the new anatomy."""
    spec, out = tmp_path / "phantom.yaml", tmp_path / "subjects"
    spec.write_text("extends: default\nnoise_level: 0.2\n")
    out.mkdir()
    args = ("simulate", "--out", str(out), "--subjects", "0", "--phantom", str(spec), *SHORT)
    assert run_main(monkeypatch, capsys, *args)[0] == 0
    status, printed, _ = run_main(monkeypatch, capsys, *args)
    assert status == 0 and printed.startswith("kept ")
    scene = resolve_scene("default", str(spec), 0)
    made_from = read_sweep(out / "subject_00.h5").provenance
    assert made_from["phantom_digest"] == phantom_digest(spec)
    simulated_truth(scene, made_from)  # the same spec: scored

    spec.write_text("extends: default\nnoise_level: 0.6\n")  # the same name, another phantom
    with pytest.raises(ResusError, match="is not the spec the sweep was simulated from"):
        simulated_truth(scene, made_from)
    status, printed, _ = run_main(monkeypatch, capsys, *args)
    assert status == 0 and printed.startswith("wrote ")
    assert read_sweep(out / "subject_00.h5").provenance["phantom_digest"] == phantom_digest(spec)


def test_a_scanner_file_is_a_preset_and_an_edited_one_another(monkeypatch, capsys, tmp_path):
    machine, out = tmp_path / "machine.yaml", tmp_path / "subjects"
    machine.write_text("depth: 0.03\nfocal_depth: 0.015\n")
    out.mkdir()
    args = ("simulate", "--out", str(out), "--subjects", "0", "--scanner", str(machine), *SHORT)
    assert run_main(monkeypatch, capsys, *args)[0] == 0
    sweep = read_sweep(out / "subject_00.h5")
    assert sweep.provenance["scanner"] == "machine"
    assert sweep.provenance["scanner_knobs"] == scanner_preset(str(machine)).to_dict()
    rows = sweep.frames.shape[1]
    np.testing.assert_allclose(np.linalg.norm(sweep.image_to_probe[:3, 1]), 0.03 / rows)
    machine.write_text("depth: 0.03\nfocal_depth: 0.015\ngain_db: 31\n")
    status, printed, _ = run_main(monkeypatch, capsys, *args)
    assert status == 0 and printed.startswith("wrote ")
    assert read_sweep(out / "subject_00.h5").provenance["scanner_knobs"]["gain_db"] == 31.0


def test_a_sweep_job_per_subject_is_kept_until_its_plan_file_changes(tmp_path) -> None:
    """The library's runner, without the command line: one sweep per subject, a rerun keeps
    them, and a trajectory file edited in place (same path) makes them again."""
    pattern = LinearPattern(length=0.006, speed=0.02, frame_rate=10.0, contact_force=None)
    single = SimulatedSweepJob(tmp_path / "one.h5", pattern, subject=1, seed=3)
    assert single.run(progress=False).frames == len(read_sweep(single.out).timestamps)
    scene, plan = single.scene_config(), tmp_path / "plan.yaml"
    pattern.trajectory(Phantom(phantom_spec(scene, 3)), scene.phantom_to_base).to_yaml(plan)

    job = SimulatedSweepJob(tmp_path / "unused.h5", str(plan), seed=3)  # a path as text too
    assert job.plan == plan
    with pytest.raises(ResusError, match=r"^SimulatedSweepJob\.plan must be a sweep pattern"):
        SimulatedSweepJob(tmp_path / "x.h5", 3)  # type: ignore[arg-type]
    folder, in_process = tmp_path / "subjects", LocalExecutor(1)
    paths, kept = simulate_subject_sweeps(job, [0, 2], folder, in_process)
    assert paths == [folder / "subject_00.h5", folder / "subject_02.h5"] and kept == []
    assert [read_sweep(path).subject for path in paths] == ["default/0", "default/2"]
    record = json.loads((folder / DONE_FOLDER / "subject_02.json").read_text())
    assert record["key"]["trajectory"] == {"path": str(plan), "text": plan.read_text()}
    assert simulate_subject_sweeps(job, [0, 2], folder, in_process)[1] == paths
    plan.write_text(plan.read_text() + "# edited in place\n")
    assert simulate_subject_sweeps(job, [0, 2], folder, in_process)[1] == []
