"""The `resus.reslices/1` file: round trip, streaming reads, schema checks; the contact sheet."""

from __future__ import annotations

import h5py
import matplotlib.image
import numpy as np
import pytest

from resus.errors import ResusError
from resus.reslicing.dataset import SCHEMA, ResliceDataset, ResliceWriter
from resus.reslicing.reslice import Reslice, ResliceSettings
from resus.reslicing.sheet import overlay_labels, save_contact_sheet


def _reslices(count: int, size: int = 16) -> list[Reslice]:
    rng = np.random.default_rng(5)
    return [
        Reslice(
            image=rng.integers(0, 256, (size, size), dtype=np.uint8),
            label=rng.integers(0, 3, (size, size), dtype=np.uint8),
            angles_deg=(float(i), -float(i)),
            slice_index=5 * i,
            plane_to_world=np.eye(4) + i,
        )
        for i in range(count)
    ]


def test_dataset_round_trip(tmp_path):
    settings = ResliceSettings(angles_deg=(-10.0, 10.0), step=3, size=16)
    written = _reslices(70)
    path = tmp_path / "reslices" / "reslices.h5"
    volume = tmp_path / "volumes" / "volume.nrrd"  # recorded relative to the reslices' folder
    with ResliceWriter(path, settings, source_volume=volume, subject="pig-1") as writer:
        for reslice in written:
            writer.append(reslice)
    with ResliceDataset(path) as dataset:
        assert len(dataset) == 70
        assert dataset.label_names == ["background", "artery", "vein"]
        attrs = dataset.attrs
        assert (
            attrs["schema"] == SCHEMA
            and attrs["subject"] == "pig-1"
            and attrs["source_volume"] == "../volumes/volume.nrrd"
        )
        assert (
            attrs["step"] == 3
            and attrs["method"] == "fast"
            and list(attrs["angles_deg"]) == [-10.0, 10.0]
        )
        for original, read in zip(written, dataset, strict=True):
            np.testing.assert_array_equal(read.image, original.image)
            np.testing.assert_array_equal(read.label, original.label)
            assert (
                read.angles_deg == original.angles_deg and read.slice_index == original.slice_index
            )
            np.testing.assert_array_equal(read.plane_to_world, original.plane_to_world)
        batches = list(dataset.batches(32))
        assert [len(images) for images, _ in batches] == [32, 32, 6]
        np.testing.assert_array_equal(batches[2][1][-1], written[-1].label)
        assert dataset[-1].slice_index == 345
        with pytest.raises(IndexError):
            dataset[70]
    with h5py.File(path) as file:
        assert file["images"].dtype == np.uint8 and file["plane_to_world"].shape == (70, 4, 4)


def test_reader_refuses_other_files(tmp_path):
    with pytest.raises(ResusError, match="no such reslice dataset"):
        ResliceDataset(tmp_path / "missing.h5")
    (tmp_path / "text.h5").write_text("not hdf5")
    with pytest.raises(ResusError, match="not an HDF5 file"):
        ResliceDataset(tmp_path / "text.h5")
    with h5py.File(tmp_path / "sweep.h5", "w") as file:
        file.attrs["schema"] = "resus.sweep/1"
    with pytest.raises(ResusError, match=r"expected 'resus\.reslices/1'"):
        ResliceDataset(tmp_path / "sweep.h5")


def test_contact_sheet_colours_arteries_red_and_veins_blue(tmp_path):
    image = np.full((4, 4), 100, dtype=np.uint8)
    label = np.array([[0, 1, 2, 0]] * 4, dtype=np.uint8)
    rgb = overlay_labels(image, label)
    assert tuple(rgb[0, 0]) == (100, 100, 100)
    red, blue = rgb[0, 1].astype(int), rgb[0, 2].astype(int)
    assert red[0] > red[1] and red[0] > red[2] and blue[2] > blue[0] and blue[2] > blue[1]
    path = save_contact_sheet(tmp_path / "sheet.png", _reslices(7), columns=3)
    picture = matplotlib.image.imread(path)
    assert picture.ndim == 3 and picture.shape[0] > 100
    with pytest.raises(ResusError, match="nothing passed"):
        save_contact_sheet(tmp_path / "empty.png", [])
