"""`resus sweep ...` run for real in a subprocess: good inputs work, bad inputs end with a
non-zero status and one line on stderr naming the file and the problem, never a traceback."""

from __future__ import annotations

import re
import subprocess
from pathlib import Path

import h5py
import numpy as np
import pytest
from cli_runner import resus
from matplotlib.image import imread
from shared_data import PLUS_CONFIG as CONFIG
from shared_data import PLUS_SEQUENCE as SEQUENCE
from shared_data import requires_plus_data
from sweep_samples import sample_sweep

from resus.sweep.io import SweepWriter, read_sweep, write_sweep


def assert_one_line_error(run: subprocess.CompletedProcess, *fragments: str) -> None:
    assert run.returncode == 2, run.stderr
    assert "Traceback" not in run.stderr
    lines = run.stderr.strip().splitlines()
    assert len(lines) == 1 and lines[0].startswith("error: "), run.stderr
    for fragment in fragments:
        assert fragment in lines[0], (fragment, lines[0])


@pytest.fixture(scope="module")
def straight_sweep(tmp_path_factory) -> Path:
    """Eight frames 1 mm apart, 0.05 s apart (plus jitter), with labels, wrench, joints."""
    path = tmp_path_factory.mktemp("cli") / "straight.h5"
    write_sweep(path, sample_sweep(n=8, rotate=False))
    return path


def test_info_reports_geometry_and_contents(straight_sweep):
    run = resus("sweep", "info", straight_sweep)
    assert run.returncode == 0, run.stderr
    fields = dict(re.split(r"\s{2,}", line, maxsplit=1) for line in run.stdout.splitlines())
    assert fields["frames"] == "8"
    assert fields["image size"] == "32 x 24 px (width x height)"
    assert fields["pixel spacing"] == "1.1875 x 2.0833 mm (column x row)"
    assert fields["path length"] == "7.00 mm (probe)"
    assert fields["frame spacing"] == "mean 1.000, min 1.000, max 1.000 mm (between frame centres)"
    assert fields["source"] == "sim" and fields["subject"] == "phantom-7"
    assert fields["optional data"] == "labels (background, artery, vein); wrench; joint positions"


def test_preview_writes_a_contact_sheet(straight_sweep, tmp_path):
    run = resus("sweep", "preview", straight_sweep, "--out", tmp_path / "sheet.png", "--count", 5)
    assert run.returncode == 0, run.stderr
    assert "5 frames of 8" in run.stdout
    image = imread(tmp_path / "sheet.png")
    assert image.shape[0] > 100 and image.shape[1] > 300
    red = (image[..., 0] > 0.8) & (image[..., 1] < 0.5) & (image[..., 2] < 0.5)
    assert red.any()  # the artery overlay is there


def test_a_sweep_that_recorded_nothing_has_nothing_to_preview(tmp_path):
    """A scan that aborted before its first frame leaves a sweep file without frames."""
    empty = tmp_path / "empty.h5"
    with SweepWriter(empty, (8, 10), np.eye(4)):
        pass
    assert_one_line_error(
        resus("sweep", "preview", empty, "--out", tmp_path / "sheet.png"),
        f"{empty}: the sweep holds no frames, nothing to preview",
    )
    assert not (tmp_path / "sheet.png").exists()
    info = resus("sweep", "info", empty)
    assert info.returncode == 0 and re.search(r"^frames +0$", info.stdout, re.MULTILINE)


@requires_plus_data
def test_import_export_and_import_again(tmp_path):
    run = resus(
        "sweep", "import-plus", SEQUENCE, "--calibration", CONFIG, "--out", tmp_path / "a.h5"
    )
    assert run.returncode == 0, run.stderr
    assert "imported 21 frames" in run.stdout
    run = resus("sweep", "export-plus", tmp_path / "a.h5", "--out", tmp_path / "b.igs.mha")
    assert run.returncode == 0, run.stderr
    assert (tmp_path / "b_config.xml").is_file()
    config = tmp_path / "b_config.xml"
    run = resus(
        "sweep",
        "import-plus",
        tmp_path / "b.igs.mha",
        "--calibration",
        config,
        "--out",
        tmp_path / "c.h5",
    )
    assert run.returncode == 0, run.stderr
    first, again = read_sweep(tmp_path / "a.h5"), read_sweep(tmp_path / "c.h5")
    np.testing.assert_array_equal(first.frames, again.frames)
    np.testing.assert_allclose(first.probe_to_base, again.probe_to_base, rtol=0, atol=1e-15)
    assert again.source == "plus" and again.subject == "b"


def _damage(path: Path, name: str) -> None:
    """Write a damaged copy of a good sweep into `path`."""
    write_sweep(path, sample_sweep(n=6))
    with h5py.File(path, "r+") as file:
        poses = file["probe_to_base"][...]
        if name == "nan":
            poses[2, 0, 3] = np.nan
        elif name == "shear":
            poses[4, 0, 1] += 0.1
        elif name == "short":
            poses = poses[:3]
        del file["probe_to_base"]
        file["probe_to_base"] = poses


@pytest.fixture(scope="module")
def bad_inputs(tmp_path_factory, straight_sweep) -> dict[str, tuple[Path, str]]:
    folder = tmp_path_factory.mktemp("bad")
    (folder / "notes.txt").write_text("hello\n")
    (folder / "picture.png").write_bytes(b"\x89PNG\r\n\x1a\n" + bytes(64))
    data = straight_sweep.read_bytes()
    (folder / "half.h5").write_bytes(data[: len(data) // 2])
    for name in ("nan", "shear", "short"):
        _damage(folder / f"{name}.h5", name)
    return {
        "missing": (folder / "missing.h5", "no such file"),
        "text": (folder / "notes.txt", "not an HDF5 file"),
        "png": (folder / "picture.png", "not an HDF5 file"),
        "truncated": (folder / "half.h5", "truncated"),
        "NaN poses": (folder / "nan.h5", "probe_to_base[2][0][3] is nan"),
        "non-rigid": (folder / "shear.h5", "probe_to_base[4] is not a rigid transform"),
        "mismatched": (folder / "short.h5", "mismatched shapes: probe_to_base has 3 rows"),
    }


CASES = ["missing", "text", "png", "truncated", "NaN poses", "non-rigid", "mismatched"]


@pytest.mark.parametrize("case", CASES)
def test_bad_sweep_files_fail_cleanly(bad_inputs, case):
    path, problem = bad_inputs[case]
    assert_one_line_error(resus("sweep", "info", path), str(path), problem)


@pytest.mark.parametrize("case", ["truncated", "non-rigid"])
def test_bad_sweep_files_fail_cleanly_for_the_other_commands(bad_inputs, tmp_path, case):
    path, problem = bad_inputs[case]
    for command in (
        ["preview", path, "--out", tmp_path / "p.png"],
        ["export-plus", path, "--out", tmp_path / "p.igs.mha"],
    ):
        assert_one_line_error(resus("sweep", *command), str(path), problem)
    assert not (tmp_path / "p.png").exists() and not (tmp_path / "p.igs.mha").exists()


def test_bad_plus_inputs_fail_cleanly(bad_inputs, straight_sweep, tmp_path):
    text, _ = bad_inputs["text"]
    out = tmp_path / "out.h5"
    assert_one_line_error(
        resus("sweep", "import-plus", tmp_path / "none.igs.mha", "--out", out), "no such file"
    )
    assert_one_line_error(
        resus("sweep", "import-plus", text, "--out", out), "notes.txt", "not a MetaImage"
    )
    assert_one_line_error(
        resus("sweep", "import-plus", "x.igs.mha", "--calibration", text, "--out", out),
        "notes.txt",
        "not a PLUS config XML",
    )
    assert_one_line_error(
        resus("sweep", "export-plus", straight_sweep, "--out", tmp_path / "s.png"),
        "must end in .igs.mha",
    )
    assert_one_line_error(
        resus("sweep", "preview", straight_sweep, "--out", tmp_path / "no" / "p.png"),
        "output folder does not exist",
    )
    assert not out.exists()


@requires_plus_data
def test_truncated_plus_sequence_fails_cleanly(tmp_path):
    cut = tmp_path / "cut.igs.mha"
    cut.write_bytes(SEQUENCE.read_bytes()[:1_000_000])
    run = resus("sweep", "import-plus", cut, "--calibration", CONFIG, "--out", tmp_path / "o.h5")
    assert_one_line_error(run, "cut.igs.mha", "MetaImage is truncated")
