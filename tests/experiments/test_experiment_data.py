"""Experiment data preparation: one scan's sweep, volumes and reslices, and its stage cache."""

import dataclasses
import json

import h5py
import pytest
from sim.assets import assets_dir

from resus.acquisition.patterns import LinearPattern
from resus.experiments.data import ScanSettings, prepare_subjects
from resus.reslicing.reslice import ResliceSettings
from resus.sweep.io import SweepReader
from sim.fingerprint import simulator_fingerprint

pytestmark = pytest.mark.slow  # the demo and experiments run whole pipelines

SETTINGS = ScanSettings(
    cols=48,
    rows=48,
    sweep=LinearPattern(length=0.015, speed=0.01, frame_rate=8.0),
    spacing=1.0e-3,
    reslice=ResliceSettings(angles_deg=(0.0, 20.0), step=6, size=32),
)


def modified(data) -> dict[str, int]:
    return {name: getattr(data, name).stat().st_mtime_ns for name in ("sweep", "volume", "labels",
                                                                      "reslices")}  # fmt: skip


def test_prepare_subjects_writes_every_file_and_caches_each_stage(tmp_path):
    (first,) = prepare_subjects(tmp_path, [2], SETTINGS, jobs=1, progress=False)
    assert first.subject == "default/2" and first.sweep.parent == tmp_path / "subject_02"
    with SweepReader(first.sweep) as sweep:
        assert sweep.frame_shape == (48, 48) and len(sweep) >= 10
    with h5py.File(first.reslices) as reslices:
        assert reslices.attrs["subject"] == "default/2"
        assert reslices["images"].shape[1:] == (32, 32) and len(reslices["images"]) > 0
    before = modified(first)

    (again,) = prepare_subjects(tmp_path, [2], SETTINGS, jobs=1, progress=False)
    assert again == first and modified(again) == before  # nothing simulated or rewritten

    other_reslicing = dataclasses.replace(SETTINGS, reslice=ResliceSettings(step=8, size=32))
    (resliced,) = prepare_subjects(tmp_path, [2], other_reslicing, jobs=1, progress=False)
    after = modified(resliced)
    assert {k: after[k] == before[k] for k in after} == {
        "sweep": True, "volume": True, "labels": True, "reslices": False
    }  # fmt: skip
    with h5py.File(resliced.reslices) as reslices:
        assert reslices.attrs["step"] == 8


def test_interrupted_stage_runs_again(tmp_path):
    (first,) = prepare_subjects(tmp_path, [0], SETTINGS, jobs=1, progress=False)
    before = modified(first)
    first.volume.unlink()  # as if reconstruction had crashed before writing
    (again,) = prepare_subjects(tmp_path, [0], SETTINGS, jobs=1, progress=False)
    after = modified(again)
    assert after["sweep"] == before["sweep"]
    assert after["volume"] != before["volume"] and after["reslices"] != before["reslices"]


def test_a_scan_another_simulator_made_is_made_again(tmp_path):
    (first,) = prepare_subjects(tmp_path, [1], SETTINGS, jobs=1, progress=False)
    before = modified(first)
    record_path = first.sweep.parent / "scan.json"
    record = json.loads(record_path.read_text())
    assert record["simulate"]["simulator"] == simulator_fingerprint()
    record["simulate"]["simulator"] = "0" * 16  # as if an older simulator had made the sweep
    record_path.write_text(json.dumps(record))
    (again,) = prepare_subjects(tmp_path, [1], SETTINGS, jobs=1, progress=False)
    after = modified(again)
    assert all(after[name] != before[name] for name in after)  # every stage after it too
    assert json.loads(record_path.read_text())["simulate"]["simulator"] == simulator_fingerprint()


def test_scene_phantom_and_scanner_files_edited_in_place_are_simulated_again(tmp_path):
    """Files keep their names when edited: the cache keys on what they say."""
    spec, scene, scanner = (tmp_path / name for name in ("phantom.yaml", "scene.yaml", "m.yaml"))
    spec.write_text("extends: default\nnoise_level: 0.2\n")
    scene_text = (assets_dir() / "scenes" / "default.yaml").read_text()
    scene.write_text(scene_text.replace("phantom: default", f"phantom: {spec}"))
    scanner.write_text("gain_db: 25.0\n")
    settings = dataclasses.replace(SETTINGS, scene=str(scene), scanner=str(scanner))
    (first,) = prepare_subjects(tmp_path / "data", [0], settings, jobs=1, progress=False)
    before = modified(first)
    (again,) = prepare_subjects(tmp_path / "data", [0], settings, jobs=1, progress=False)
    assert modified(again) == before  # unchanged files: kept

    for path, old, new in [
        (spec, "noise_level: 0.2", "noise_level: 0.6"),  # the phantom the scene names
        (scene, "xyz: [-0.30, -0.13, 0.06]", "xyz: [-0.30, -0.125, 0.06]"),  # its pose
        (scanner, "gain_db: 25.0", "gain_db: 30.0"),
    ]:
        path.write_text(path.read_text().replace(old, new))
        (edited,) = prepare_subjects(tmp_path / "data", [0], settings, jobs=1, progress=False)
        after = modified(edited)
        assert all(after[name] != before[name] for name in after), path.name
        before = after
