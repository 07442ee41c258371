"""`resus sweep export-labels` and `attach-labels` through the command line's `main`: labels
go to a CVAT folder and come back into the same or another sweep file; a bad folder is one
line and leaves the sweep as it was."""

from __future__ import annotations

import dataclasses

import numpy as np
from cli_runner import run_main
from sweep_samples import sample_sweep

from resus.sweep.io import read_sweep, write_sweep


def test_export_then_attach_through_the_command_line(monkeypatch, capsys, tmp_path):
    run = (monkeypatch, capsys)
    sweep = sample_sweep(n=4, rows=32, cols=48, seed=41)
    write_sweep(tmp_path / "labelled.h5", sweep)
    write_sweep(tmp_path / "bare.h5", dataclasses.replace(sweep, labels=None))
    status, out, err = run_main(
        *run, "sweep", "export-labels", tmp_path / "labelled.h5", "--out", tmp_path / "cvat"
    )
    assert status == 0, err
    assert out.startswith("wrote 4 masks (frame_000000.png ...) with labelmap.txt")
    masks = ["--masks", tmp_path / "cvat"]
    status, out, err = run_main(
        *run, "sweep", "attach-labels", tmp_path / "bare.h5", *masks, "--out", tmp_path / "new.h5"
    )
    assert status == 0, err
    assert out.startswith(f"labelled 4 frames of {tmp_path / 'new.h5'}")
    np.testing.assert_array_equal(read_sweep(tmp_path / "new.h5").labels, sweep.labels)
    assert read_sweep(tmp_path / "bare.h5").labels is None  # untouched
    status, out, err = run_main(*run, "sweep", "attach-labels", tmp_path / "bare.h5", *masks)
    assert status == 0, err  # in place
    np.testing.assert_array_equal(read_sweep(tmp_path / "bare.h5").labels, sweep.labels)
    assert sorted(p.name for p in tmp_path.iterdir() if p.is_file()) == [
        "bare.h5", "labelled.h5", "new.h5",
    ]  # fmt: skip


def test_a_bad_folder_is_one_line_and_leaves_the_sweep_alone(monkeypatch, capsys, tmp_path):
    run = (monkeypatch, capsys)
    sweep = sample_sweep(n=3, rows=32, cols=48, seed=42)
    write_sweep(tmp_path / "scan.h5", sweep)
    run_main(*run, "sweep", "export-labels", tmp_path / "scan.h5", "--out", tmp_path / "cvat")
    (tmp_path / "cvat/SegmentationClass/frame_000001.png").unlink()
    (tmp_path / "cvat/ImageSets/Segmentation/default.txt").unlink()
    status, _, err = run_main(
        *run, "sweep", "attach-labels", tmp_path / "scan.h5", "--masks", tmp_path / "cvat"
    )
    assert status == 2
    assert err.strip().splitlines() == [
        f"error: {tmp_path / 'cvat'}: no mask for 1 of the sweep's 3 frames (1; expected e.g. "
        "frame_000001.png)"
    ]
    np.testing.assert_array_equal(read_sweep(tmp_path / "scan.h5").labels, sweep.labels)
