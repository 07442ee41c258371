"""Leave-one-subject-out: no test-subject data in training, regimes run end to end."""

import json
from dataclasses import replace

import numpy as np
import pytest
import torch

from resus.errors import ResusError
from resus.segmentation.loso import Split, hold_out_tail, make_split, run_loso, run_regime
from resus.segmentation.presets import QUICK
from resus.segmentation.synthetic import synthetic_subject

torch.set_num_threads(1)  # one per pytest-xdist worker: more oversubscribes the 2 cores

TINY = replace(QUICK, max_epochs=1, validation_fraction=0.25)
SUBJECTS = ("s1", "s2", "s3")


def frames_and_reslices(count: int = 12):
    frames = [synthetic_subject(s, count, size=64, seed=i) for i, s in enumerate(SUBJECTS)]
    reslices = [
        synthetic_subject(s, count // 2, size=64, seed=10 + i, oblique=True)
        for i, s in enumerate(SUBJECTS)
    ]
    return frames, reslices


def test_split_leaves_out_the_test_subjects_reslices() -> None:
    frames, reslices = frames_and_reslices()
    split = make_split(frames, reslices, "s2", validation_fraction=0.25)
    assert {s.subject for s in split.reslices} == {"s1", "s3"}
    for sets in (split.train, split.validation, split.reslices):
        assert all(s.subject != "s2" for s in sets)
    assert [s.subject for s in split.test] == ["s2"] and len(split.test[0]) == 12
    assert [len(s) for s in split.train] == [9, 9] and [len(s) for s in split.validation] == [3, 3]
    np.testing.assert_array_equal(split.validation[0].images, frames[0].images[9:])


def test_split_refuses_test_subject_data_in_training() -> None:
    frames, reslices = frames_and_reslices()
    with pytest.raises(ResusError, match="test subject 's1' must not be in reslices"):
        Split("s1", (frames[1],), (frames[2],), (frames[0],), (reslices[0],))
    with pytest.raises(ResusError, match="test subject 's1' must not be in training"):
        Split("s1", (frames[0],), (frames[2],), (frames[0],))
    with pytest.raises(ResusError, match="match no frames"):
        make_split(frames[:2], reslices, "s1", 0.25)
    with pytest.raises(ResusError, match="test subject 's9' has no frames"):
        make_split(frames, reslices, "s9", 0.25)


def test_hold_out_tail_keeps_single_images_for_training() -> None:
    one, five = (synthetic_subject("s", n, size=16) for n in (1, 5))
    train, validation = hold_out_tail([one, five], 0.2)
    assert [len(s) for s in train] == [1, 4] and [len(s) for s in validation] == [1]


def test_resus_regime_trains_on_other_subjects_reslices_only(tmp_path) -> None:
    frames, reslices = frames_and_reslices()
    split = make_split(frames, reslices, "s3", TINY.validation_fraction)
    run = run_regime(split, "resus", TINY, out_dir=tmp_path, progress=False)
    config = run.training.config
    assert config["train_subjects"] == ["s1", "s2"] and config["test_subject"] == "s3"
    assert config["train_images"] == 9 + 9 + 6 + 6  # frames minus validation, plus 2 reslice sets
    assert 0.0 <= run.test_iou.mean <= 1.0
    assert (tmp_path / "checkpoint.pt").is_file()
    assert (tmp_path / "curves.png").read_bytes()[:8] == b"\x89PNG\r\n\x1a\n"
    us = run_regime(split, "us", TINY, progress=False)
    assert us.training.config["train_images"] == 18


def test_loso_table_and_paired_tests() -> None:
    frames, reslices = frames_and_reslices()
    result = run_loso(frames, reslices, ["us", "imagenet", "resus"], TINY, progress=False)
    assert set(result.iou) == {"us", "resus"} and set(result.not_run) == {"imagenet"}
    assert all(list(per_subject) == list(SUBJECTS) for per_subject in result.iou.values())
    test = result.comparisons[("us", "resus", "mean")]
    assert test.n == 3 and test.p_value is not None and 0 <= test.p_value <= 1
    report = json.loads(json.dumps(result.to_dict()))
    assert report["regimes"]["imagenet"]["status"] == "not run"
    assert len(report["paired_t_tests"]) == 3
    assert "| s2 |" in result.markdown() and "imagenet: not run" in result.markdown()
    with pytest.raises(ResusError, match="at least 2 subjects"):
        run_loso(frames[:1], [], ["us"], TINY, progress=False)
