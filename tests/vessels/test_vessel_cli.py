"""`resus vessels` end to end on a short simulated sweep, and its one-line errors."""

import json
from pathlib import Path

import h5py
import pytest
from cli_runner import resus
from simulated_sweeps import simulate_vessel_sweep


@pytest.fixture(scope="module")
def sweep_path(tmp_path_factory) -> Path:
    path = tmp_path_factory.mktemp("vessels_cli") / "sweep.h5"
    return simulate_vessel_sweep(path, start_y=-0.05, length=0.04, pixels=96)


def test_maps_a_sweep_and_writes_every_output(sweep_path: Path, tmp_path: Path) -> None:
    out = tmp_path / "map"
    done = resus("vessels", sweep_path, "--labels-from-sweep", "--out", out,
                 "--target", "artery", "--spacing", "0.4e-3")  # fmt: skip
    assert done.returncode == 0, done.stderr
    for name in ("artery.ply", "artery.stl", "vein.ply", "vein.stl", "vessel_map.glb",
                 "vessel_labels.nrrd", "vessel_map.png", "needle.png", "vessels.json"):  # fmt: skip
        assert (out / name).stat().st_size > 0, name
    metrics = json.loads((out / "vessels.json").read_text())
    for name in ("artery", "vein"):
        assert metrics["scores"][name]["mean_surface_distance_mm"] < 0.5
    needle = metrics["needle"]
    assert needle["target"] == "artery" and needle["safe"], needle["reason"]
    assert metrics["needle_truth"]["tip_in_target_lumen"]
    assert metrics["needle_truth"]["clearance_from_other_mm"] > 2.5
    assert "the more lateral trunk" in metrics["anatomy"]
    assert "mean surface distance" in done.stdout


def test_a_sweep_of_another_seed_is_scored_against_its_own_phantom(tmp_path: Path) -> None:
    """The sweep's provenance carries the seed: `simulate --subject 1 --seed 5` is scored
    against subject 1 of seed 5, not of the spec's seed (whose vessels lie elsewhere), and
    scoring it as another subject is refused."""
    sweep = tmp_path / "seed5.h5"
    made = resus("simulate", "--out", sweep, "--subject", "1", "--seed", "5", "--length", "0.03",
                 "--speed", "0.02", "--frame-rate", "20")  # fmt: skip
    assert made.returncode == 0, made.stderr
    done = resus("vessels", sweep, "--labels-from-sweep", "--out", tmp_path / "map",
                 "--spacing", "0.4e-3")  # fmt: skip
    assert done.returncode == 0, done.stderr
    scores = json.loads((tmp_path / "map" / "vessels.json").read_text())["scores"]
    for name in ("artery", "vein"):
        assert scores[name]["dice"] >= 0.98, (name, scores[name])
    other = resus("vessels", sweep, "--labels-from-sweep", "--out", tmp_path / "map2",
                  "--subject", "2")  # fmt: skip
    assert other.returncode == 2
    assert "simulated from phantom 'default' subject 1 (its provenance)" in other.stderr


@pytest.mark.parametrize(
    ("args", "message"),
    [
        (["--out", "{tmp}/o"], "exactly one of --model"),
        (["--labels-from-sweep", "--model", "m.pt", "--out", "{tmp}/o"], "exactly one of"),
        (["--labels-from-sweep", "--out", "{tmp}/o", "--target", "nerve"], "--target"),
        (["--labels-from-sweep", "--out", "{tmp}/o", "--needle-angle", "0"], "--needle-angle"),
        (["--labels-from-sweep", "--out", "{tmp}/o", "--spacing", "-1"], "--spacing"),
        (["--model", "{tmp}/missing.pt", "--out", "{tmp}/o"], "checkpoint not found"),
        (["--labels-from-sweep", "--out", "{tmp}/o", "--scene", "nowhere"], "nowhere"),
    ],
)
def test_bad_input_is_one_line_and_non_zero(
    sweep_path: Path, tmp_path: Path, args: list, message: str
) -> None:
    done = resus("vessels", sweep_path, *(a.format(tmp=tmp_path) for a in args))
    assert done.returncode != 0
    lines = done.stderr.strip().splitlines()
    assert len(lines) == 1 and message in lines[0], done.stderr


def test_missing_sweep_and_unlabelled_sweep_are_named(sweep_path: Path, tmp_path: Path) -> None:
    done = resus("vessels", tmp_path / "none.h5", "--labels-from-sweep", "--out", tmp_path)
    assert done.returncode != 0 and "none.h5" in done.stderr and "no such" in done.stderr
    unlabelled = tmp_path / "unlabelled.h5"
    unlabelled.write_bytes(sweep_path.read_bytes())
    with h5py.File(unlabelled, "a") as file:
        del file["labels"]
    done = resus("vessels", unlabelled, "--labels-from-sweep", "--out", tmp_path / "o")
    assert done.returncode != 0 and len(done.stderr.strip().splitlines()) == 1
    assert "has no labels" in done.stderr


def test_a_map_without_vessels_writes_no_meshes_instead_of_failing(tmp_path: Path) -> None:
    """An undertrained model (the demo's smallest size) can find only specks: its map has no
    meshes, and no files are written for them (a glTF scene cannot be empty)."""
    from resus.vessels import write_meshes

    assert write_meshes(tmp_path, {}) == [] and not list(tmp_path.iterdir())


def test_a_model_labels_the_frames_when_the_sweep_has_no_labels_to_use(
    sweep_path: Path, tmp_path: Path
) -> None:
    """`--model` segments every frame and maps what it calls vessel: a model that calls every
    pixel artery maps one artery filling the swept volume and no vein; one that calls none
    leaves nothing to map, which is one line."""
    from tiny_models import tiny_checkpoint

    everywhere = tmp_path / "artery.pt"
    tiny_checkpoint(everywhere, label=1)
    out = tmp_path / "map"
    done = resus("vessels", sweep_path, "--model", everywhere, "--out", out, "--spacing", "1e-3")
    assert done.returncode == 0, done.stderr
    metrics = json.loads((out / "vessels.json").read_text())
    assert metrics["labels"] == f"model {everywhere}"
    assert (out / "artery.ply").is_file() and not (out / "vein.ply").exists()
    # its surface is the swept volume's border, outside the region scored: no distances
    # (this was an IndexError from an empty percentile), but a Dice
    artery = metrics["scores"]["artery"]
    assert artery["mean_surface_distance_mm"] is None and artery["hd95_mm"] is None
    assert 0.0 < artery["dice"] < 0.2

    nowhere = tmp_path / "background.pt"
    tiny_checkpoint(nowhere, label=0)
    done = resus("vessels", sweep_path, "--model", nowhere, "--out", tmp_path / "none")
    assert done.returncode == 2
    errors = [line for line in done.stderr.splitlines() if line.startswith("error")]
    assert errors == ["error: no pixel is labelled artery or vein: there is nothing to map"]
    assert "Traceback" not in done.stderr
