"""`resus reslice`: volume files in, dataset and contact sheet out; bad input refused."""

from __future__ import annotations

import numpy as np
import pytest
import typer
from reslice_volumes import grid_for, vessel_volume
from typer.testing import CliRunner

from resus.cli import reslice as reslice_command
from resus.errors import ResusError
from resus.reconstruction.grid import VolumeGrid
from resus.reconstruction.io import intensity_to_uint8, write_volume
from resus.reslicing.dataset import ResliceDataset


@pytest.fixture(scope="module")
def app() -> typer.Typer:
    root = typer.Typer()
    reslice_command.register(root)
    # a second command, so that `reslice` is addressed by name as in `resus`
    root.command("noop")(lambda: None)
    return root


@pytest.fixture(scope="module")
def volume_files(tmp_path_factory):
    folder = tmp_path_factory.mktemp("volumes")
    shape = (32, 32, 40)
    volume, labels = vessel_volume(shape)
    grid = grid_for(shape)
    volume_path = write_volume(
        folder / "volume.nrrd", intensity_to_uint8(volume), grid, subject="default/3"
    )
    labels_path = write_volume(
        folder / "labels.mha", labels, grid, ["background", "artery", "vein"]
    )
    return volume_path, labels_path, folder


def test_reslice_writes_dataset_and_contact_sheet(app, volume_files, tmp_path):
    volume_path, labels_path, _ = volume_files
    out = tmp_path / "out"
    arguments = [
        "reslice",
        str(volume_path),
        str(labels_path),
        "--out",
        str(out),
        "--angles",
        "-20:20:20",
        "--step",
        "8",
        "--size",
        "48",
    ]
    result = CliRunner().invoke(app, arguments)
    assert result.exit_code == 0, result.output
    assert "reslices from 9 angle pairs" in result.output
    with ResliceDataset(out / "reslices.h5") as dataset:
        assert len(dataset) > 10 and dataset.images.shape[1:] == (48, 48)
        # the subject comes from the volume's header (its sweep's), not from the file name
        assert dataset.attrs["subject"] == "default/3" and dataset.attrs["min_nonzero"] == 0.4
        assert set(np.unique(dataset.labels[:])) == {0, 1, 2}
        assert {tuple(a) for a in dataset.angles_deg[:]} <= {
            (x, y) for x in (-20, 0, 20) for y in (-20, 0, 20)
        }
    assert (out / "reslices.png").stat().st_size > 1000


@pytest.mark.parametrize(
    ("change", "message"),
    [
        ({"volume": "missing.nrrd"}, "missing.nrrd: no such volume file"),
        ({"volume": "volume.txt"}, "volume.txt: volume files must end in"),
        (
            {"labels": "other_grid.nrrd"},
            "other_grid.nrrd: label volume is not on the volume's grid",
        ),
        ({"labels": "short.nrrd"}, "short.nrrd: labels shape"),
        ({"options": ["--angles", "10:0:5"]}, "--angles: expected start:stop:step"),
        ({"options": ["--method", "warp"]}, ("--method", "must be one of fast, rotate")),
        ({"volume": "no_subject.nrrd"}, "no_subject.nrrd: the volume records no subject"),
        (
            {"options": ["--angles", "30", "--min-nonzero", "1.0"]},
            "volume.nrrd: no slice has 100% non-zero pixels",
        ),
    ],
)
def test_bad_input_is_one_clear_error(app, volume_files, tmp_path, change, message):
    volume_path, labels_path, folder = volume_files
    shape = (32, 32, 40)
    write_volume(
        folder / "other_grid.nrrd",
        np.zeros(shape, np.uint8),
        VolumeGrid(np.zeros(3), np.eye(3) * 1e-3, shape),
    )
    write_volume(folder / "short.nrrd", np.zeros((32, 32, 39), np.uint8), grid_for((32, 32, 39)))
    (folder / "volume.txt").write_text("")
    write_volume(folder / "no_subject.nrrd", np.zeros(shape, np.uint8), grid_for(shape))
    volume = folder / change["volume"] if "volume" in change else volume_path
    labels = folder / change["labels"] if "labels" in change else labels_path
    arguments = [
        "reslice",
        str(volume),
        str(labels),
        "--out",
        str(tmp_path / "out"),
        "--angles",
        "0",
        *change.get("options", []),
    ]
    result = CliRunner().invoke(app, arguments)
    assert isinstance(result.exception, ResusError), result.output
    fragments = (message,) if isinstance(message, str) else message
    assert all(fragment in str(result.exception) for fragment in fragments), result.exception
    assert "\n" not in str(result.exception)
