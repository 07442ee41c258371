"""`resus reconstruct` on good and bad input, through the real console entry point."""

from pathlib import Path

import numpy as np
import pytest
from cli_runner import resus
from shared_data import PLUS_CONFIG as CONFIG
from shared_data import PLUS_SEQUENCE as SEQUENCE
from shared_data import requires_plus_data
from sweep_samples import sample_sweep

from resus.reconstruction.io import read_volume, volume_subject
from resus.sweep.io import write_sweep
from resus.sweep.plus import export_plus_sequence


@requires_plus_data
@pytest.mark.parametrize(
    ("grid_args", "out_name"),
    [
        (["--grid", "aabb", "--spacing", "0.002", "--method", "nn"], "v.nrrd"),
        (["--grid", "ransac", "--voxels", "24,20,16"], "v.mha"),
    ],
)
def test_reconstructs_a_plus_sequence(tmp_path: Path, grid_args: list[str], out_name: str) -> None:
    out, png = tmp_path / out_name, tmp_path / "v.png"
    done = resus(
        "reconstruct",
        SEQUENCE,
        "--calibration",
        CONFIG,
        "--out",
        out,
        "--png",
        png,
        "--fill-passes",
        "1",
        *grid_args,
    )
    assert done.returncode == 0, done.stderr
    volume, grid, _ = read_volume(out)
    assert volume.dtype == np.uint8 and volume.max() > 100
    if "aabb" in grid_args:
        np.testing.assert_allclose(grid.spacing, 0.002)
    else:
        assert grid.shape == (24, 20, 16)
    assert png.read_bytes()[:4] == b"\x89PNG"


@pytest.mark.parametrize(
    ("args", "message"),
    [
        (["missing.h5", "--out", "v.nrrd"], "no such sweep file"),
        (["s.igs.mha", "--out", "v.nrrd"], "--calibration"),
        (["s.igs.mha", "--out", "v.nrrd", "--grid", "sphere"], "--grid"),
        (["s.igs.mha", "--out", "v.nrrd", "--method", "cubic"], "--method"),
        (["s.igs.mha", "--out", "v.nrrd", "--radius", "-1"], "--radius"),
        (["s.igs.mha", "--out", "nowhere/v.nrrd"], "output folder"),
        (["s.igs.mha", "--out", "v.nrrd", "--grid", "aabb", "--voxels", "8,8,8"], "--voxels"),
    ],
)
def test_bad_input_is_one_line_and_non_zero(tmp_path: Path, args: list, message: str) -> None:
    export_plus_sequence(sample_sweep(4), tmp_path / "s.igs.mha")  # a small PLUS sequence of ours
    args = [
        tmp_path / a if isinstance(a, str) and a.endswith((".h5", ".nrrd", ".mha")) else a
        for a in args
    ]
    done = resus("reconstruct", *args)
    assert done.returncode != 0
    lines = done.stderr.strip().splitlines()
    assert len(lines) == 1 and lines[0].startswith("error:") and message in lines[0], done.stderr


def test_volumes_record_the_sweeps_subject(tmp_path: Path) -> None:
    write_sweep(tmp_path / "s.h5", sample_sweep(6))
    volume, labels = tmp_path / "v.nrrd", tmp_path / "l.mha"
    done = resus(
        "reconstruct", tmp_path / "s.h5", "--out", volume, "--labels-out", labels,
        "--grid", "aabb", "--spacing", "0.002", "--fill-passes", "0",
    )  # fmt: skip
    assert done.returncode == 0, done.stderr
    assert volume_subject(volume) == volume_subject(labels) == "phantom-7"
