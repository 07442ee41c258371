"""`resus reconstruct` on good and bad input, through the real console entry point."""

import importlib.util
from pathlib import Path

import numpy as np
import pytest
from cli_runner import resus

from resus.volume_io import read_volume

PLUS = Path(__file__).resolve().parents[1].parent / "shared" / "data" / "plus"
SEQUENCE = PLUS / "SpinePhantomFreehand.igs.mha"
CONFIG = PLUS / "Config_VolumeReconstruction_SpinePhantom_NN_MEAN.xml"


@pytest.mark.skipif(
    not SEQUENCE.is_file() or importlib.util.find_spec("resus.plus_io") is None,
    reason="needs shared/data/plus and resus.plus_io",
)
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
        ([SEQUENCE, "--out", "v.nrrd"], "--calibration"),
        ([SEQUENCE, "--out", "v.nrrd", "--grid", "sphere"], "--grid"),
        ([SEQUENCE, "--out", "v.nrrd", "--method", "cubic"], "--method"),
        ([SEQUENCE, "--out", "v.nrrd", "--radius", "-1"], "--radius"),
        ([SEQUENCE, "--out", "nowhere/v.nrrd"], "output folder"),
    ],
)
def test_bad_input_is_one_line_and_non_zero(tmp_path: Path, args: list, message: str) -> None:
    args = [
        tmp_path / a if isinstance(a, str) and a.endswith((".h5", ".nrrd")) else a for a in args
    ]
    done = resus("reconstruct", *args)
    assert done.returncode != 0
    lines = done.stderr.strip().splitlines()
    assert len(lines) == 1 and lines[0].startswith("error:") and message in lines[0], done.stderr
