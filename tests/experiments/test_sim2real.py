"""The sim-to-real experiment: its splits, its curve statistics, and one small run end to end
(simulated femoral sweeps, a simulation-only model, fine-tunings on a folder of "real" PNGs
with known vessels), its scores checked against independent computations."""

from __future__ import annotations

import dataclasses
import json
import math
import shutil
from pathlib import Path

import numpy as np
import pytest
from cli_runner import run_main
from PIL import Image

from resus.acquisition.patterns import LinearPattern
from resus.acquisition.simulation import DONE_FOLDER
from resus.errors import ResusError
from resus.execution import LocalExecutor
from resus.experiments.sim2real import (
    FROM_SCRATCH,
    FROM_SIMULATION,
    CurvePoint,
    Sim2RealSettings,
    Spread,
    curve_summary,
    fine_tune,
    get_sim2real_preset,
    off_vessel_subjects,
    pretraining_verdict,
    real_splits,
    rehearsal_frames,
    repeated_to,
    run_sim2real,
    simulate_subjects,
    subject_preset,
    subject_sweep,
    sweep_provenance,
)
from resus.experiments.vessel_targets import vessel_depth, vessel_midline
from resus.segmentation.data import LabelledImages
from resus.segmentation.folders import read_folders
from resus.segmentation.trained_model import load_model
from resus.sweep.io import SweepReader, read_sweep
from sim.fingerprint import simulator_fingerprint
from sim.phantom import VesselSpec, load_phantom, phantom_digest
from sim.ultrasound.scanner import RANDOM_RANGES, sweep_preset

TINY = Sim2RealSettings(
    name="tiny",
    subjects=(0, 1),
    training="quick",
    sweep=LinearPattern(start=(0.0, -0.04), length=0.01),
    label_counts=(0, 2, 4),
    splits=2,
    fine_tune_epochs=1,
    fine_tune_epoch_images=8,
    rehearsal_images=4,
    minimum_test_images=6,
    training_cpus=1,
)


def write_real_folder(folder: Path, count: int, seed: int = 0) -> Path:
    """`count` speckle images, two sizes, each with a dark disc (its mask 255) but every
    fifth, which shows none: a stand-in for a folder of real images with vessel masks."""
    rng = np.random.default_rng(seed)
    (folder / "images").mkdir(parents=True)
    (folder / "masks").mkdir()
    for index in range(count):
        shape = (96, 80) if index % 2 else (72, 88)
        image = np.clip(rng.rayleigh(40.0, shape), 0, 255)
        mask = np.zeros(shape, np.uint8)
        if index % 5:
            rows, cols = np.indices(shape)
            centre = rng.uniform(20, 50, 2)
            disc = (rows - centre[0]) ** 2 + (cols - centre[1]) ** 2 <= rng.uniform(6, 12) ** 2
            image[disc] *= 0.3
            mask[disc] = 255
        Image.fromarray(image.astype(np.uint8)).save(folder / "images" / f"{index:04d}.png")
        Image.fromarray(mask).save(folder / "masks" / f"{index:04d}.png")
    return folder


def vessel_counts(model, images) -> tuple[int, int]:
    """Pooled vessel intersection and union of `model` on `images`, counted with numpy."""
    predicted = model.predict(list(images.images))
    pairs = [(p > 0, t > 0) for p, t in zip(predicted, images.labels, strict=True)]
    return sum(int((p & t).sum()) for p, t in pairs), sum(int((p | t).sum()) for p, t in pairs)


def test_splits_are_seeded_permutations_of_pool_and_test():
    splits = real_splits(30, TINY, seed=5)
    assert [s.index for s in splits] == [0, 1]
    for split in splits:
        assert len(split.pool) == 4 and len(split.test) == 26
        assert sorted(split.pool + split.test) == list(range(30))
    assert splits[0].pool != splits[1].pool
    assert real_splits(30, TINY, seed=5) == splits
    assert real_splits(30, TINY, seed=6) != splits


def test_too_few_real_images_is_one_error_naming_the_settings():
    with pytest.raises(ResusError, match=r"9 real images: .* needs 4 .* and 6 to test on"):
        real_splits(9, TINY, seed=0)


@pytest.mark.parametrize(
    ("changes", "message"),
    [
        ({"label_counts": (0, 5, 5)}, "label_counts must be distinct"),
        ({"label_counts": (10, 5)}, "label_counts must be distinct, increasing"),
        ({"regime": "resus"}, "regime must be one of us, aug"),
        ({"splits": 0}, "splits must be at least 1"),
        ({"training": "huge"}, "unknown preset 'huge'"),
        ({"subjects": ()}, "subjects is empty"),
        ({"export_framing_p": 1.5}, r"export_framing_p must be in \[0, 1\], got 1.5"),
        ({"vertical_flip_p": -0.1}, r"vertical_flip_p must be in \[0, 1\], got -0.1"),
        ({"sweep_tilt_deg": 50.0}, r"sweep_offset must be >= 0 and sweep_tilt_deg in \[0, 45\)"),
        ({"training_cpus": 0}, "training_cpus must be at least 1"),
        ({"ensemble": 0}, "ensemble must be at least 1"),
        ({"contact_forces": (5.0, 2.0)}, r"contact_forces must be \(low, high\)"),
        ({"target_depth_fraction": (0.5, 1.2)}, r"target_depth_fraction must be \(low, high\)"),
        ({"rehearsal_images": -1}, "rehearsal_images must be >= 0, got -1"),
        ({"off_vessel_share": 1.5}, r"off_vessel_share must be in \[0, 1\], got 1.5"),
        ({"off_vessel_offset": (0.05, 0.04)}, r"off_vessel_offset must be \(low, high\)"),
        ({"phantom": "thigh"}, "Sim2RealSettings.phantom: unknown phantom 'thigh'; known:"),
        ({"scanner": "vascullar"}, "Sim2RealSettings.scanner: unknown scanner preset 'vascullar'"),
        (
            {"scanner": "no/such.yaml"},
            "Sim2RealSettings.scanner: no/such.yaml: scanner preset file",
        ),
        (
            {"weight_averaging_epochs": 9},
            r"weight_averaging_epochs must be in \[0, 8\] \(the max_epochs of training preset "
            r"'quick'\), got 9",
        ),
    ],
)
def test_settings_refuse_what_cannot_run(changes, message):
    base = {"name": "x", "subjects": (0,), "training": "quick"}
    with pytest.raises(ResusError, match=message):
        Sim2RealSettings(**{**base, **changes})


def test_rehearsal_runs_fewer_epochs_for_the_same_number_of_images():
    quick = get_sim2real_preset("quick")  # 80 epochs of 64 real images; 64 simulated added
    assert quick.fine_tuning_epochs(rehearsal=False) == 80
    assert quick.fine_tuning_epochs(rehearsal=True) == 40
    assert dataclasses.replace(quick, rehearsal_images=0).fine_tuning_epochs(True) == 80
    assert dataclasses.replace(quick, rehearsal_images=16).fine_tuning_epochs(True) == 64
    assert TINY.fine_tuning_epochs(rehearsal=True) == 1  # never none


def test_the_augmentation_probabilities_reach_the_training_preset():
    settings = Sim2RealSettings(
        name="x", subjects=(0,), training="quick", zoom_p=0.2, elastic_p=0.3, vertical_flip_p=0.0
    )
    augmentation = settings.training_preset().augmentation
    assert (augmentation.zoom_p, augmentation.elastic_p) == (0.2, 0.3)
    assert (augmentation.framing_p, augmentation.vertical_flip_p) == (0.5, 0.0)


def test_the_simulation_only_training_averages_its_last_epochs_at_a_constant_rate():
    preset = TINY.simulation_training_preset()  # the quick training preset: 8 epochs
    assert (preset.weight_averaging_epochs, preset.cosine_decay) == (5, False)
    assert TINY.training_preset().weight_averaging_epochs == 0  # the fine-tunings' preset
    plain = dataclasses.replace(TINY, weight_averaging_epochs=0)
    assert plain.simulation_training_preset() == plain.training_preset()


def test_presets_and_unknown_preset():
    assert get_sim2real_preset("quick").label_counts == (0, 5, 10, 25, 50, 100)
    assert get_sim2real_preset("paper").training == "paper"
    with pytest.raises(ResusError, match="unknown preset 'x'; choose one of quick, paper"):
        get_sim2real_preset("x")


def test_repeats_fill_an_epoch_and_the_spread_is_the_sample_deviation():
    images = np.zeros((3, 4, 4), np.uint8)
    sets = [LabelledImages(images, images, "real")]
    assert sum(map(len, repeated_to(sets, 8))) == 9
    assert sum(map(len, repeated_to(sets, 2))) == 3
    spread = Spread.of([0.2, 0.4, 0.9])
    assert spread.mean == pytest.approx(0.5)
    assert spread.std == pytest.approx(math.sqrt(((0.3**2) + (0.1**2) + (0.4**2)) / 2))
    assert Spread.of([0.3]).std == 0.0


def test_curve_summary_and_the_pretraining_verdict():
    points = [
        CurvePoint(FROM_SIMULATION, 25, split, iou, 0.0) for split, iou in enumerate((0.50, 0.52))
    ] + [CurvePoint(FROM_SCRATCH, 100, split, iou, 0.0) for split, iou in enumerate((0.3, 0.34))]
    summary = curve_summary(points)
    assert summary[FROM_SIMULATION][25].mean == pytest.approx(0.51)
    assert summary[FROM_SCRATCH][100].runs == 2
    as_json = {name: {str(k): vars(s) for k, s in by_k.items()} for name, by_k in summary.items()}
    verdict = pretraining_verdict(as_json)
    assert verdict.startswith("25 real labels with simulation pretraining give IoU 0.510 ± 0.014")
    assert "above 100 labels from scratch (0.320 ± 0.028)" in verdict
    close = [
        CurvePoint(FROM_SIMULATION, 25, 0, 0.33, 0.0),
        CurvePoint(FROM_SCRATCH, 100, 0, 0.32, 0),
    ]
    close += [
        CurvePoint(FROM_SIMULATION, 25, 1, 0.29, 0.0),
        CurvePoint(FROM_SCRATCH, 100, 1, 0.34, 0),
    ]
    close_json = {
        name: {str(k): vars(s) for k, s in by_k.items()}
        for name, by_k in curve_summary(close).items()
    }
    assert "no different from" in pretraining_verdict(close_json)


@pytest.mark.slow
def test_a_small_run_end_to_end(tmp_path):
    import torch

    folder = write_real_folder(tmp_path / "real", 20)
    real = read_folders(folder / "images", folder / "masks")
    out = tmp_path / "out"
    in_process = LocalExecutor(1)  # one CPU slot: every unit runs in this process
    result = run_sim2real(
        TINY, real, out, seed=3, device="cpu", executor=in_process, progress=False
    )
    results = json.loads((out / "results.json").read_text())
    assert results == json.loads(json.dumps(result.to_dict()))
    for name in ("report.md", "few_label_curve.png", "examples.png", "realism/realism.md"):
        assert (out / name).is_file(), name
    report = (out / "report.md").read_text()
    assert "No real image entered training" in report and "| 4 |" in report
    assert "rehearses: 4 simulated frames of its own training sweeps join every epoch" in report

    # the simulation-only model learned from the simulated femoral subjects alone
    model = load_model(out / "sim_only" / "checkpoint.pt", "cpu")
    assert sorted(model.config["train_subjects"]) == ["femoral/0", "femoral/1"]
    assert model.config["augment"] and model.config["preset"]["augmentation"]["framing_p"] == 0.5
    # ... the mean of its weights over the last five of its eight epochs' steps
    assert model.config["weight_average"]["first_epoch"] == 4
    assert model.config["weight_average"]["last_epoch"] == 8
    assert results["sweeps"] == ["data/sweeps/subject_00.h5", "data/sweeps/subject_01.h5"]
    sweeps = [out / p for p in results["sweeps"]]  # under the output folder: relative to it

    # rehearsal: frames of those sweeps, seeded, in the real masks' one vessel class; a
    # fine-tuning from simulation trains on them besides the real images, in fewer epochs
    frames = rehearsal_frames(sweeps, 4, 7, one_vessel_class=True)
    again = rehearsal_frames(sweeps, 4, 7, one_vessel_class=True)
    assert sum(len(part) for part in frames) == 4
    assert all(np.array_equal(a.images, b.images) for a, b in zip(frames, again, strict=True))
    assert all(set(np.unique(part.labels)) <= {0, 1} for part in frames)
    two_classes = rehearsal_frames(sweeps, 4, 7, one_vessel_class=False)
    swept = [read_sweep(path) for path in sweeps]
    for part, kept in zip(frames, two_classes, strict=True):
        assert np.array_equal(part.labels, (kept.labels > 0).astype(np.uint8))
        for image, labels in zip(kept.images, kept.labels, strict=True):
            assert any(
                np.array_equal(image, frame) and np.array_equal(labels, label)
                for sweep in swept
                for frame, label in zip(sweep.frames, sweep.labels, strict=True)
            )
    with pytest.raises(ResusError, match=r"Sim2RealSettings\.rehearsal_images is 999"):
        rehearsal_frames(sweeps, 999, 7, one_vessel_class=True)
    tuned = fine_tune(real.subset(range(2)), model, TINY.training_preset(), TINY, seed=0,
                      device=torch.device("cpu"), rehearsal=frames)  # fmt: skip
    assert tuned.config["train_images"] == 8 + 4  # two real images repeated to 8, and 4
    assert tuned.config["preset"]["max_epochs"] == TINY.fine_tuning_epochs(rehearsal=True)
    assert "weight_average" not in tuned.config

    # its score on every real image, counted independently from its own predictions
    vessel = results["sim_only"]["pooled"]["vessel"]
    assert (vessel["intersection"], vessel["union"]) == vessel_counts(model, real)
    evaluation = json.loads((out / "sim_only" / "evaluation" / "metrics.json").read_text())
    assert evaluation["pooled"]["vessel"] == vessel
    assert len(list((out / "sim_only" / "evaluation" / "overlays").glob("*.png"))) == 20

    # the curve: k = 0 is the simulation-only model on each split's own test images
    points = results["curve"]
    assert {(p["initialisation"], p["labels"]) for p in points} == {
        (FROM_SIMULATION, 0),
        (FROM_SIMULATION, 2),
        (FROM_SIMULATION, 4),
        (FROM_SCRATCH, 2),
        (FROM_SCRATCH, 4),
    }
    assert len(points) == 2 * 5
    for split in results["splits"]:
        intersection, union = vessel_counts(model, real.subset(split["test"]))
        zero = next(p for p in points if p["split"] == split["index"] and p["labels"] == 0)
        assert zero["iou"] == pytest.approx(intersection / union)
        assert not set(split["pool"]) & set(split["test"])

    # a rerun keeps the sweeps it finds, made from the same phantom, subject, seed and scanner
    stamps = [p.stat().st_mtime_ns for p in sweeps]
    made = simulate_subjects(out / "data" / "sweeps", TINY, 3, in_process, progress=False)
    assert made == sweeps
    assert [p.stat().st_mtime_ns for p in sweeps] == stamps
    # ... each recorded with its scanner preset's knobs, drawn for its subject ...
    record_path = out / "data" / "sweeps" / DONE_FOLDER / "subject_01.json"
    record = json.loads(record_path.read_text())
    with SweepReader(sweeps[1]) as sweep:
        provenance = sweep.provenance
    assert record["key"]["scanner"] == provenance["scanner_knobs"]
    assert record["key"]["simulator"] == provenance["simulator"] == simulator_fingerprint()
    # ... and makes again one that another simulator made (its fingerprint differs)
    record["key"]["simulator"] = "0" * 16
    record_path.write_text(json.dumps(record))
    simulate_subjects(out / "data" / "sweeps", TINY, 3, in_process, progress=False)
    assert sweeps[0].stat().st_mtime_ns == stamps[0]
    assert sweeps[1].stat().st_mtime_ns != stamps[1]
    with SweepReader(sweeps[1]) as remade:
        assert remade.provenance == provenance

    # the fine-tunings in two worker processes give the same curve, to the last bit; the
    # simulation-only unit, finished (copied from the first run), is not trained again
    units = sorted((out / "few_label").glob("*/unit.json"))
    assert len(units) == 8
    # only a fine-tuning from simulation rehearses and depends on the simulation-only model,
    # whose unit's key holds its sweeps down to the simulator that made them
    sim_only_key = json.loads((out / "sim_only" / "unit.json").read_text())["key"]
    for unit in units:
        key = json.loads(unit.read_text())["key"]
        from_simulation = unit.parent.name.startswith(FROM_SIMULATION)
        assert ("rehearsal_images" in key["settings"]) == from_simulation
        assert key.get("sim_only") == (sim_only_key if from_simulation else None)
    again = tmp_path / "again"
    shutil.copytree(out / "sim_only", again / "sim_only")
    trained = (again / "sim_only" / "checkpoint.pt").stat().st_mtime_ns
    workers = run_sim2real(
        TINY, real, again, data=out / "data", seed=3, device="cpu",
        executor=LocalExecutor(2), progress=False,
    )  # fmt: skip
    assert (again / "sim_only" / "checkpoint.pt").stat().st_mtime_ns == trained
    assert workers.points == result.points
    assert workers.to_dict()["curve_summary"] == results["curve_summary"]

    # a rerun of the first finds every unit finished and trains nothing
    stamps = [path.stat().st_mtime_ns for path in units]
    rerun = run_sim2real(TINY, real, out, seed=3, device="cpu", executor=in_process, progress=False)
    assert [path.stat().st_mtime_ns for path in units] == stamps
    assert rerun.points == result.points

    # a curve asked for with one more k trains that k alone: the fine-tunings it shares with
    # the run before (same splits, since the largest k is the same) are kept
    more = dataclasses.replace(TINY, label_counts=(0, 1, 2, 4), minimum_test_images=5)
    longer = run_sim2real(more, real, out, seed=3, device="cpu", executor=in_process,
                         progress=False)  # fmt: skip
    assert [path.stat().st_mtime_ns for path in units] == stamps
    assert sorted((out / "few_label").glob("*/unit.json")) == sorted(
        [*units, *(out / "few_label").glob("*_k1_split*/unit.json")]
    )
    assert {p.labels for p in longer.points} == {0, 1, 2, 4}


@pytest.mark.slow
def test_an_ensemble_is_its_members_runs_and_scores_by_their_mean_probabilities(tmp_path):
    import torch

    from resus.segmentation.data import images_to_tensor, resize_images

    folder = write_real_folder(tmp_path / "real", 12)
    real = read_folders(folder / "images", folder / "masks")
    settings = dataclasses.replace(TINY, label_counts=(0,), splits=1, ensemble=2)
    out, in_process = tmp_path / "out", LocalExecutor(1)
    result = run_sim2real(settings, real, out, seed=3, device="cpu", executor=in_process,
                          progress=False)  # fmt: skip
    results = result.to_dict()
    sim_only = results["sim_only"]
    assert sim_only["checkpoints"] == ["sim_only/checkpoint.pt", "sim_only/member_1/checkpoint.pt"]
    members = [load_model(out / path, "cpu") for path in sim_only["checkpoints"]]

    # member 1 is the run at the next seed: its own subjects, scanners and sweeps
    with SweepReader(out / "data" / "member_1" / "sweeps" / "subject_00.h5") as reader:
        wanted = sweep_provenance(settings, 0, 4)
        assert {key: reader.provenance.get(key) for key in wanted} == wanted
    record = json.loads((out / "sim_only" / "member_1" / "unit.json").read_text())
    assert record["key"]["seed"] == 4 and "ensemble" not in record["key"]["settings"]

    # each member scored alone, and the ensemble by the arg-max of their mean softmax over
    # each image and its left-right mirror (the members trained with flips), computed here
    # with torch directly
    for member, scored in zip(members, sim_only["members"], strict=True):
        alone = scored["pooled"]["vessel"]
        assert (alone["intersection"], alone["union"]) == vessel_counts(member, real)
    intersection = union = 0
    with torch.no_grad():
        for image, truth in zip(real.images, real.labels, strict=True):
            inputs = images_to_tensor(resize_images(image[None], members[0].image_size))
            assert all(m.mirror for m in members)
            mean = (
                sum(
                    torch.softmax(m.network(inputs), 1)
                    + torch.softmax(m.network(inputs.flip(3)), 1).flip(3)
                    for m in members
                )
                / 4
            )
            mean = torch.nn.functional.interpolate(mean, size=image.shape, mode="bilinear")
            vessel, true = mean[0].argmax(0).numpy() > 0, truth > 0
            intersection += int((vessel & true).sum())
            union += int((vessel | true).sum())
    vessel = sim_only["pooled"]["vessel"]
    assert (vessel["intersection"], vessel["union"]) == (intersection, union)

    # the curve's k = 0 is member 0, the network fine-tuning starts from
    test = real.subset(results["splits"][0]["test"])
    zero_intersection, zero_union = vessel_counts(members[0], test)
    assert results["curve"][0]["iou"] == pytest.approx(zero_intersection / zero_union)
    assert "ensemble of 2" in (out / "report.md").read_text()

    # a member is the same run whatever the ensemble's size or the curve's settings: one
    # model from it, with another curve asked for, trains no simulation-only model again
    stamp = (out / "sim_only" / "checkpoint.pt").stat().st_mtime_ns
    other_curve = dataclasses.replace(
        settings, ensemble=1, splits=2, fine_tune_epochs=3, minimum_test_images=5
    )
    single = run_sim2real(other_curve, real, out, seed=3, device="cpu", executor=in_process,
                          progress=False)  # fmt: skip
    assert (out / "sim_only" / "checkpoint.pt").stat().st_mtime_ns == stamp
    assert len(single.splits) == 2
    assert single.members == () and single.to_dict()["sim_only"]["members"] == []
    assert single.to_dict()["sim_only"]["pooled"] == sim_only["members"][0]["pooled"]


def run_sim2real_cli(monkeypatch, capsys, real: Path, out: Path, *options: str) -> tuple[int, str]:
    """`resus experiment sim2real --real REAL --out OUT OPTIONS...`: its status and stderr."""
    status, _, err = run_main(
        monkeypatch, capsys, "experiment", "sim2real", "--real", real, "--out", out, *options
    )
    return status, err


@pytest.mark.parametrize(
    ("make", "message"),
    [
        (lambda tmp: tmp / "none", "--real: {tmp}/none: no such folder"),
        (lambda tmp: tmp, "--real: {tmp}/images: no such folder"),  # not a data set's layout
        (
            lambda tmp: write_real_folder(tmp / "few", 30),
            "30 real images: the few-label curve needs 100",
        ),
    ],
)
def test_cli_refuses_a_real_folder_it_cannot_use(monkeypatch, capsys, tmp_path, make, message):
    status, err = run_sim2real_cli(monkeypatch, capsys, make(tmp_path), tmp_path / "o")
    assert status == 2 and "Traceback" not in err
    lines = err.strip().splitlines()
    assert len(lines) == 1 and lines[0].startswith("error: "), err
    assert message.format(tmp=tmp_path) in lines[0], lines[0]
    assert not (tmp_path / "o").exists()


@pytest.mark.parametrize(
    ("options", "message"),
    [
        (
            ("--label-counts", "25,5"),
            "--label-counts: Sim2RealSettings.label_counts must be distinct, increasing and "
            ">= 0, got (25, 5)",
        ),
        (
            ("--label-counts", "5,many"),
            "--label-counts: expected a list of comma-separated integers, got '5,many'",
        ),
        (
            ("--rehearsal", "-1"),
            "--rehearsal: Sim2RealSettings.rehearsal_images must be >= 0, got -1",
        ),
        # the curve asked for reaches the check of the real folder: 20 + 20 is more than 30
        (
            ("--label-counts", "0,20", "--splits", "2"),
            "--real: 30 real images: the few-label curve needs 20 for the largest k and 20",
        ),
    ],
)
def test_cli_the_curve_asked_for_is_checked_before_any_work(
    monkeypatch, capsys, tmp_path, options, message
):
    real = write_real_folder(tmp_path / "few", 30)
    status, err = run_sim2real_cli(monkeypatch, capsys, real, tmp_path / "o", *options)
    lines = err.strip().splitlines()
    assert status == 2 and len(lines) == 1 and lines[0].startswith(f"error: {message}"), err
    assert not (tmp_path / "o").exists()


def test_each_subject_is_scanned_its_own_way_within_the_settings_bounds():
    sweeps = [subject_sweep(TINY, k, 3) for k in range(40)]
    offsets = np.array([s.start[0] - TINY.sweep.start[0] for s in sweeps])
    tilts = np.array([s.tilt_deg for s in sweeps])
    forces = np.array([s.contact_force for s in sweeps])
    low, high = TINY.contact_forces
    assert forces.min() >= low and forces.max() <= high and forces.std() > (high - low) / 5
    assert np.abs(offsets).max() <= TINY.sweep_offset and np.abs(tilts).max() <= TINY.sweep_tilt_deg
    assert offsets.std() > TINY.sweep_offset / 3 and tilts.std() > TINY.sweep_tilt_deg / 3
    assert all(s.start[1] == TINY.sweep.start[1] and s.length == TINY.sweep.length for s in sweeps)
    assert subject_sweep(TINY, 5, 3) == sweeps[5] and subject_sweep(TINY, 5, 4) != sweeps[5]


def test_a_share_of_the_subjects_is_scanned_off_the_vessels_and_the_rest_as_before():
    subjects = tuple(range(40))
    base = dataclasses.replace(TINY, subjects=subjects)
    aside = dataclasses.replace(base, off_vessel_share=0.1)
    off = off_vessel_subjects(aside, 3)
    assert len(off) == 4 and off <= set(subjects)
    assert off_vessel_subjects(aside, 3) == off and off_vessel_subjects(aside, 4) != off
    assert off_vessel_subjects(base, 3) == frozenset()
    low, high = aside.off_vessel_offset
    sides = set()
    for subject in subjects:
        sweep, before = subject_sweep(aside, subject, 3), subject_sweep(base, subject, 3)
        if subject in off:
            offset = sweep.start[0] - aside.sweep.start[0]
            assert low <= abs(offset) <= high, (subject, offset)
            assert (sweep.tilt_deg, sweep.contact_force) == (before.tilt_deg, before.contact_force)
            sides.add(np.sign(offset))
        else:
            assert sweep == before  # its sweep, and so its reused file, unchanged
    everyone = dataclasses.replace(base, off_vessel_share=1.0)
    assert sides | {np.sign(subject_sweep(everyone, k, 3).start[0]) for k in subjects} == {-1, 1}


def test_a_sweep_is_reused_only_from_the_same_phantom_subject_seed_scanner_and_simulator():
    made = sweep_provenance(TINY, 1, 3)
    assert made["phantom"] == "femoral" and made["subject"] == 1
    assert made["scanner"].startswith("random-")
    assert sweep_provenance(TINY, 1, 3) == made
    assert sweep_provenance(TINY, 2, 3) != made and sweep_provenance(TINY, 1, 4) != made
    assert made["pattern"]["tilt_deg"] == subject_sweep(TINY, 1, 3).tilt_deg  # where it scanned
    assert made["contact_force"] == subject_sweep(TINY, 1, 3).contact_force  # how hard
    assert made["deformation"] is True
    assert made["simulator"] == simulator_fingerprint()  # made by this simulator
    moved = dataclasses.replace(TINY, sweep_offset=0.0)
    assert sweep_provenance(moved, 1, 3)["pattern"] != made["pattern"]


def test_phantom_and_scanner_files_edited_in_place_are_other_sweeps(tmp_path):
    spec, scanner = tmp_path / "thigh.yaml", tmp_path / "machine.yaml"
    spec.write_text("extends: femoral\n")
    scanner.write_text("gain_db: 30\n")
    from_files = dataclasses.replace(TINY, phantom=str(spec), scanner=str(scanner))
    made = sweep_provenance(from_files, 1, 3)
    assert made["phantom_digest"] == phantom_digest(spec)
    assert made["scanner"].startswith("machine") and made["scanner_knobs"]["gain_db"] == 30.0
    spec.write_text("extends: femoral\nnoise_level: 0.3\n")
    edited = sweep_provenance(from_files, 1, 3)
    assert edited["phantom_digest"] != made["phantom_digest"]
    scanner.write_text("gain_db: 36\n")
    assert sweep_provenance(from_files, 1, 3)["scanner_knobs"]["gain_db"] == 36.0


def test_cli_names_a_bad_training_preset(monkeypatch, capsys, tmp_path):
    real = write_real_folder(tmp_path / "real", 4)
    status, err = run_sim2real_cli(monkeypatch, capsys, real, tmp_path / "o", "--training", "huge")
    assert status == 2 and err.strip().splitlines() == [
        "error: --training: unknown preset 'huge'; choose one of quick, cpu128, paper"
    ]


def straight_vessel(label: int, x: float, depth: float, radius: float) -> VesselSpec:
    """A straight tube along y at (x, -depth)."""
    points = [(x, y, -depth) for y in (-0.08, 0.0, 0.08)]
    return VesselSpec(f"tube{label}", label, points, [radius] * 3)


def test_vessel_depth_is_the_mean_centre_depth_of_the_vessels_crossing_the_plane():
    spec = dataclasses.replace(
        load_phantom("default"),
        vessels=(straight_vessel(1, -0.01, 0.015, 0.004), straight_vessel(2, 0.01, 0.027, 0.005)),
    )
    assert vessel_depth(spec, -0.03) == pytest.approx(0.021, abs=1e-9)
    with pytest.raises(ResusError, match=r"no vessel crossing y = 0\.200 m"):
        vessel_depth(spec, 0.2)


def test_vessel_midline_is_midway_between_the_widest_artery_and_vein():
    """A thin superficial vein (a saphenous one) does not pull the probe's centre aside."""
    spec = dataclasses.replace(
        load_phantom("default"),
        vessels=(
            straight_vessel(1, 0.015, 0.02, 0.004),
            straight_vessel(2, -0.002, 0.025, 0.005),
            straight_vessel(2, -0.015, 0.006, 0.002),
        ),
    )
    assert vessel_midline(spec, 0.01) == pytest.approx(0.0065, abs=1e-9)
    alone = dataclasses.replace(spec, vessels=spec.vessels[1:])
    assert vessel_midline(alone, 0.01) == pytest.approx(-0.002, abs=1e-9)


def test_the_displayed_depth_puts_the_vessels_at_the_drawn_fraction_of_it():
    from resus.acquisition.simulation import phantom_spec, resolve_scene

    low, high = TINY.target_depth_fraction
    fractions = []
    for subject in range(6):
        spec = phantom_spec(resolve_scene("default", TINY.phantom, subject), 3)
        preset = subject_preset(TINY, spec, subject, 3)
        own = sweep_preset(TINY.scanner, 3, subject)
        sweep = subject_sweep(TINY, subject, 3)
        depth = vessel_depth(spec, sweep.start[1] + sweep.length / 2)
        assert (
            preset.name.startswith(own.name + "@")
            and preset.centre_frequency == own.centre_frequency
        )
        assert preset.focal_depth / preset.depth == pytest.approx(own.focal_depth / own.depth)
        assert RANDOM_RANGES["depth"][0] <= preset.depth <= RANDOM_RANGES["depth"][1]
        if RANDOM_RANGES["depth"][0] < preset.depth < RANDOM_RANGES["depth"][1]:
            fractions.append(depth / preset.depth)
        assert subject_preset(TINY, spec, subject, 3) == preset  # seeded
    assert len(fractions) >= 4 and low <= min(fractions) and max(fractions) <= high
    blind = dataclasses.replace(TINY, target_depth_fraction=None)
    assert subject_preset(blind, spec, 5, 3) == sweep_preset(TINY.scanner, 3, 5)
