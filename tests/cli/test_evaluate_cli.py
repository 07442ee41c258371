"""`resus evaluate` on a folder of generated images (grey, RGB, JPEG, two sizes), `resus train`
from image folders, and their one-line errors."""

import dataclasses
import json

import numpy as np
import pytest
import torch
from cli_runner import one_line_error, run_main
from PIL import Image
from tiny_models import tiny_checkpoint

from resus.segmentation.checkpoint import load_checkpoint
from resus.segmentation.presets import PRESETS, QUICK
from sim.labels import ARTERY

torch.set_num_threads(1)  # one per pytest-xdist worker: more oversubscribes the 2 cores

SAMPLES = {  # name: (file suffix, (rows, columns), rows of vessel in the mask)
    "0000": (".png", (48, 64), 10),
    "0001": (".png", (48, 64), 0),
    "0002": (".jpg", (48, 64), 6),
    "0003": (".png", (40, 40), 4),
}


@pytest.fixture
def data(tmp_path):
    """images/ (grey PNG, RGB PNG, RGB JPEG, a grey PNG of another size) and masks/ (grey,
    RGB and palette PNGs), each mask a band of vessel across the top of the image."""
    images, masks = tmp_path / "images", tmp_path / "masks"
    images.mkdir(), masks.mkdir()
    rng = np.random.default_rng(0)
    for index, (name, (suffix, shape, rows)) in enumerate(SAMPLES.items()):
        grey = rng.integers(40, 200, shape, dtype=np.uint8)
        image = Image.fromarray(np.dstack([grey] * 3) if index in (1, 2) else grey)
        image.save(images / f"{name}{suffix}")
        vessel = np.zeros(shape, np.uint8)
        vessel[:rows] = 1
        if index == 1:
            mask = Image.fromarray(np.dstack([vessel * 255] * 3))  # RGB
        elif index == 2:
            mask = Image.fromarray(vessel, mode="P")  # palette: black, white
            mask.putpalette([0, 0, 0, 255, 255, 255])
        else:
            mask = Image.fromarray(vessel * 255)
        mask.save(masks / f"{name}.png")
    return tmp_path


def test_evaluate_scores_a_folder_and_writes_metrics_and_overlays(data, monkeypatch, capsys):
    tiny_checkpoint(data / "model.pt", ARTERY)  # calls every pixel artery
    out = data / "evaluation"
    arguments = ["--model", data / "model.pt", "--images", data / "images"]
    arguments += ["--masks", data / "masks", "--out", out, "--device", "cpu"]
    status, stdout, stderr = run_main(monkeypatch, capsys, "evaluate", *arguments)
    assert status == 0, stderr
    vessel = sum(shape[1] * rows for _, shape, rows in SAMPLES.values())
    pixels = sum(shape[0] * shape[1] for _, shape, _ in SAMPLES.values())
    assert f"vessel: pooled IoU {vessel / pixels:.3f}" in stdout
    assert f"wrote {out / 'metrics.json'} and 4 overlays" in stdout
    metrics = json.loads((out / "metrics.json").read_text())
    assert metrics["schema"] == "resus.evaluation/3" and metrics["classes"] == ["vessel"]
    assert metrics["pooled"]["vessel"]["iou"] == pytest.approx(vessel / pixels)
    assert metrics["both_empty"] == {"vessel": 0}  # the model finds vessel everywhere
    assert metrics["mirror"] is False  # the tiny model never trained with flips
    assert metrics["input_sizes"] == [48, 64, 80]  # zoomed a quarter either way by default
    assert [row["name"] for row in metrics["per_image"]] == list(SAMPLES)
    for name, (_, (rows, columns), band) in SAMPLES.items():
        row = next(r for r in metrics["per_image"] if r["name"] == name)["vessel"]
        assert row["iou"] == pytest.approx(band / rows), name
        with Image.open(out / "overlays" / f"{name}.png") as written:
            assert written.size == (columns, rows) and written.mode == "RGB"


def test_a_repeated_model_flag_scores_the_checkpoints_as_one_ensemble(data, monkeypatch, capsys):
    tiny_checkpoint(data / "a.pt", logits=(0.0, 2.0, 0.0))  # artery, softmax 0.787
    tiny_checkpoint(data / "b.pt", logits=(3.0, 0.0, 0.0))  # background, softmax 0.909
    arguments = ["--model", data / "a.pt", "--model", data / "b.pt", "--images", data / "images"]
    arguments += ["--masks", data / "masks", "--out", data / "e", "--device", "cpu", "--mirror"]
    arguments += ["--zooms", "1"]
    status, _, stderr = run_main(monkeypatch, capsys, "evaluate", *arguments)
    assert status == 0, stderr
    metrics = json.loads((data / "e" / "metrics.json").read_text())
    assert metrics["checkpoints"] == [str(data / "a.pt"), str(data / "b.pt")]
    assert metrics["mirror"] is True  # as --mirror asks
    assert metrics["input_sizes"] == [64]  # as --zooms 1 asks
    # mean softmax: background 0.507, artery 0.416: no vessel anywhere
    assert metrics["pooled"]["vessel"]["intersection"] == 0
    assert metrics["both_empty"] == {"vessel": 1}  # 0001 shows none and gets none


def test_train_from_image_folders_then_evaluate(data, monkeypatch, capsys):
    monkeypatch.setitem(PRESETS, "quick", dataclasses.replace(QUICK, max_epochs=2))  # fast
    run = data / "run"
    arguments = ["--images", data / "images", "--masks", data / "masks", "--out", run]
    status, stdout, stderr = run_main(monkeypatch, capsys, "train", *arguments, "--device", "cpu")
    assert status == 0, stderr
    assert "masks do not tell artery from vein" in stdout
    metrics = json.loads((run / "metrics.json").read_text())
    assert metrics["train_subjects"] == [data.name]
    assert metrics["train_images"] + metrics["validation_images"] == len(SAMPLES)
    _, config = load_checkpoint(run / "checkpoint.pt")
    assert config["model"]["image_size"] == QUICK.model.image_size  # real sizes resized to it
    arguments = ["--model", run / "checkpoint.pt", "--images", data / "images"]
    arguments += ["--masks", data / "masks", "--out", data / "scores", "--device", "cpu"]
    status, _, stderr = run_main(monkeypatch, capsys, "evaluate", *arguments)
    assert status == 0, stderr
    assert len(list((data / "scores" / "overlays").glob("*.png"))) == len(SAMPLES)


def test_bad_flags_and_folders_are_one_error_line(data, monkeypatch, capsys):
    tiny_checkpoint(data / "model.pt", ARTERY)  # calls every pixel artery
    good = {"--model": data / "model.pt", "--images": data / "images", "--masks": data / "masks"}

    def evaluate(**changed):
        flags = {**good, **{f"--{k}": v for k, v in changed.items()}, "--out": data / "o"}
        return run_main(monkeypatch, capsys, "evaluate", *(x for f in flags.items() for x in f))

    one_line_error(evaluate(images=data / "nowhere"), "--images: ", "nowhere: no such folder")
    (data / "empty").mkdir()
    one_line_error(evaluate(masks=data / "empty"), "--masks: ", "empty: holds no PNG files")
    one_line_error(evaluate(model=data / "none.pt"), "--model: ", "checkpoint not found")
    one_line_error(evaluate(device="gpu0"), "--device: ", "not a torch device")
    one_line_error(evaluate(zooms="0.75,big"), "--zooms: expected a list of comma-separated")
    one_line_error(evaluate(zooms="0,1"), "--zooms: magnifications must be positive")
    Image.fromarray(np.zeros((40, 41), np.uint8)).save(data / "masks" / "0003.png")
    one_line_error(evaluate(), "0003.png: 41x40, but its image ", "0003.png is 40x40")
    assert not (data / "o" / "metrics.json").exists()
    train = ["train", "--out", data / "run"]
    one_line_error(run_main(monkeypatch, capsys, *train), "no training data: give --sweeps")
    one_line_error(
        run_main(monkeypatch, capsys, *train, "--images", data / "images"),
        "--images: needs --masks too",
    )
