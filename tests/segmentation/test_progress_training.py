"""The training bar: batch by batch, the warm-up batch its own step, so that the rate and the
time left of the first epoch are those of the batches after it; the numbers trained are the
same with or without it."""

from __future__ import annotations

import re
import time
from dataclasses import replace

import torch

from resus.segmentation.presets import QUICK
from resus.segmentation.synthetic import synthetic_subject
from resus.segmentation.train import TrainingProgress, train_model

torch.set_num_threads(1)  # one per pytest-xdist worker: more oversubscribes the 2 cores

WARM_UP = 1.0
BATCH = 0.02
BATCHES = 20


def rates(text: str) -> list[float]:
    """The batches per second each print of the bar showed."""
    return [float(rate) for rate in re.findall(r"([\d.]+)batch/s", text)]


def test_the_rate_leaves_out_the_warm_up_batch(capsys) -> None:
    with TrainingProgress(epochs=1, batches_per_epoch=BATCHES + 1) as bar:
        time.sleep(WARM_UP)  # the first batch: allocation, first calls
        bar.batch_done()
        for _ in range(BATCHES):
            time.sleep(BATCH)
            bar.batch_done()
    shown = capsys.readouterr().err
    assert "train warm-up" in shown
    last = rates(shown)[-1]
    with_warm_up = (BATCHES + 1) / (WARM_UP + BATCHES * BATCH)  # 15 batches/s
    assert last > 2 * with_warm_up, shown  # about 1 / BATCH = 50 batches/s


def test_progress_shows_the_bar_and_changes_no_number(capsys) -> None:
    subject = synthetic_subject("s", 12, size=64, seed=0)
    train, validation = [subject.take(slice(0, 10))], [subject.take(slice(10, None))]
    preset = replace(QUICK, max_epochs=2)
    quiet = train_model(train, validation, preset, seed=1, progress=False)
    assert capsys.readouterr().err == ""
    shown = train_model(train, validation, preset, seed=1, progress=True)
    err = capsys.readouterr().err
    assert "train warm-up" in err and "batch/s" in err and "epoch=1/2" in err
    assert [r.train_loss for r in shown.history] == [r.train_loss for r in quiet.history]
    assert [r.validation_loss for r in shown.history] == [r.validation_loss for r in quiet.history]
