"""`resus train` from sweep and reslice files, and the loaders' errors."""

import json

import numpy as np
import pytest
import torch
import typer
from cli_runner import resus
from typer.testing import CliRunner

from resus.cli.train import register
from resus.errors import ResusError
from resus.reslicing.dataset import ResliceWriter
from resus.reslicing.reslice import Reslice, ResliceSettings
from resus.segmentation.checkpoint import load_checkpoint
from resus.segmentation.loaders import load_reslice_sets, load_sweep_frames
from resus.segmentation.synthetic import synthetic_subject
from resus.sweep.io import write_sweep
from resus.sweep.model import Sweep

torch.set_num_threads(1)  # one per pytest-xdist worker: more oversubscribes the 2 cores


def write_synthetic_sweep(path, subject: str, seed: int, labelled: bool = True) -> None:
    images = synthetic_subject(subject, 12, size=64, seed=seed)
    count = len(images)
    write_sweep(
        path,
        Sweep(
            frames=images.images,
            probe_to_base=np.repeat(np.eye(4)[None], count, axis=0),
            timestamps=np.arange(count) / 30.0,
            image_to_probe=np.diag([1e-4, 1e-4, 1.0, 1.0]),
            labels=images.labels if labelled else None,
            subject=subject,
        ),
    )


def write_synthetic_reslices(path, subject: str, seed: int) -> None:
    images = synthetic_subject(subject, 6, size=64, seed=seed, oblique=True)
    with ResliceWriter(path, ResliceSettings(size=64), "volume.nrrd", subject=subject) as writer:
        for image, label in zip(images.images, images.labels, strict=True):
            writer.append(Reslice(image, label, (10.0, 0.0), 0, np.eye(4)))


@pytest.fixture
def files(tmp_path):
    (tmp_path / "sweeps").mkdir()
    for i, subject in enumerate(("s1", "s2", "s3")):
        write_synthetic_sweep(tmp_path / "sweeps" / f"{subject}.h5", subject, i)
        write_synthetic_reslices(tmp_path / f"{subject}_reslices.h5", subject, 10 + i)
    return tmp_path


def cli() -> typer.Typer:
    app = typer.Typer()
    register(app)
    app.command("noop")(lambda: None)  # a second command keeps `train` a named sub-command
    return app


def test_train_command_holds_out_a_subject(files) -> None:
    out = files / "run"
    arguments = ["train", "--sweeps", str(files / "sweeps"), "--out", str(out), "--regime"]
    arguments += ["resus", "--test-subject", "s2", "--seed", "3"]
    for subject in ("s1", "s2", "s3"):
        arguments += ["--reslices", str(files / f"{subject}_reslices.h5")]
    result = CliRunner().invoke(cli(), arguments, catch_exceptions=False)
    assert result.exit_code == 0, result.output
    assert "test subject s2: IoU artery" in result.output
    metrics = json.loads((out / "metrics.json").read_text())
    assert metrics["status"] == "run" and metrics["train_subjects"] == ["s1", "s3"]
    assert metrics["train_images"] == 2 * (12 - 2) + 2 * 6  # s2's reslices left out
    assert set(metrics["test_iou"]) == {"artery", "vein", "mean"}
    _, config = load_checkpoint(out / "checkpoint.pt")
    assert config["regime"] == "resus" and config["seed"] == 3
    assert (out / "curves.png").is_file()


def test_train_command_keeps_a_weight_average_and_says_so(files) -> None:
    out = files / "averaged"
    arguments = ["train", "--sweeps", str(files / "sweeps" / "s1.h5"), "--out", str(out)]
    result = CliRunner().invoke(
        cli(), [*arguments, "--average-epochs", "2"], catch_exceptions=False
    )
    assert result.exit_code == 0, result.output
    metrics = json.loads((out / "metrics.json").read_text())
    average = metrics["training"]["weight_average"]
    epochs = metrics["training"]["epochs_run"]
    assert metrics["average_epochs"] == 2 and epochs == 8  # the quick preset's every epoch
    assert (average["first_epoch"], average["last_epoch"]) == (epochs - 1, epochs)
    assert f"weight average of epochs {epochs - 1}-{epochs} ({average['steps']} steps)" in (
        result.output
    )
    assert "best epoch" not in result.output
    _, config = load_checkpoint(out / "checkpoint.pt")
    assert config["weight_average"]["steps"] == average["steps"] > 0


def test_train_command_refuses_imagenet_without_weights(files) -> None:
    out = files / "imagenet"
    arguments = ["train", "--sweeps", str(files / "sweeps" / "s1.h5"), "--out", str(out)]
    result = CliRunner().invoke(cli(), [*arguments, "--regime", "imagenet"])
    assert isinstance(result.exception, ResusError), result.output
    assert "--regime imagenet: no encoder weights file given (--weights)" in str(result.exception)
    assert not out.exists()  # refused before anything is written


def test_train_command_refuses_resus_without_training_reslices(files) -> None:
    out = files / "refused"
    arguments = ["train", "--sweeps", str(files / "sweeps"), "--out", str(out), "--regime"]
    arguments += ["resus", "--test-subject", "s2"]
    nothing = CliRunner().invoke(cli(), arguments)
    assert isinstance(nothing.exception, ResusError), nothing.output
    assert str(nothing.exception) == "--regime resus: no reslices given (--reslices)"
    held_out = ["--reslices", str(files / "s2_reslices.h5")]
    only_test = CliRunner().invoke(cli(), [*arguments, *held_out])
    assert isinstance(only_test.exception, ResusError), only_test.output
    assert "every given reslice belongs to the test subject 's2'" in str(only_test.exception)
    assert not out.exists()
    missing = ["train", "--sweeps", str(files / "nowhere"), "--out", str(out)]
    refused = CliRunner().invoke(cli(), missing)
    assert str(refused.exception).startswith("--sweeps: "), refused.exception
    assert "nowhere: no such" in str(refused.exception)


def test_train_resus_without_reslices_is_an_error_for_real(tmp_path) -> None:
    done = resus("train", "--sweeps", tmp_path, "--out", tmp_path / "o", "--regime", "resus")
    assert done.returncode == 2
    assert done.stderr == "error: --regime resus: no reslices given (--reslices)\n"


def test_loaders_read_files_and_name_bad_ones(files) -> None:
    frames = load_sweep_frames([files / "sweeps"])
    assert [s.subject for s in frames] == ["s1", "s2", "s3"] and frames[0].images.shape == (
        12,
        64,
        64,
    )
    reslices = load_reslice_sets([files / "s1_reslices.h5"])
    assert reslices[0].subject == "s1" and len(reslices[0]) == 6
    unlabelled = files / "unlabelled.h5"
    write_synthetic_sweep(unlabelled, "s4", 4, labelled=False)
    with pytest.raises(ResusError, match=r"unlabelled\.h5: sweep has no labels"):
        load_sweep_frames([unlabelled])
    with pytest.raises(ResusError, match=r"nowhere\.h5: no such sweep file"):
        load_sweep_frames([files / "nowhere.h5"])
    (files / "empty").mkdir()
    with pytest.raises(ResusError, match=r"empty: no \.h5 reslice files"):
        load_reslice_sets([files / "empty"])


def test_train_command_names_the_flag_of_an_unknown_test_subject(files) -> None:
    out = files / "nobody"
    arguments = ["train", "--sweeps", str(files / "sweeps"), "--out", str(out)]
    result = CliRunner().invoke(cli(), [*arguments, "--test-subject", "s9"])
    assert isinstance(result.exception, ResusError), result.output
    assert str(result.exception).startswith("--test-subject: test subject 's9' has no frames")
    assert not out.exists()
