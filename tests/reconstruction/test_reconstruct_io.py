"""Volume files: NRRD and MetaImage round trips in millimetres, PNG slices."""

import re
from pathlib import Path

import numpy as np
import pytest

from resus.errors import ResusError
from resus.reconstruction.figures import save_slices_png
from resus.reconstruction.grid import VolumeGrid
from resus.reconstruction.io import (
    intensity_to_uint8,
    read_label_volume,
    read_volume,
    volume_subject,
    write_volume,
)

SKEWED = VolumeGrid(
    origin=(0.012, -0.034, 0.056),
    axes=[[0.4e-3, 0.05e-3, 0.0], [0.0, 0.3e-3, 0.02e-3], [0.03e-3, 0.0, 0.5e-3]],
    shape=(7, 5, 4),
)


@pytest.mark.parametrize("suffix", [".nrrd", ".mha"])
def test_round_trip_keeps_values_and_geometry(tmp_path: Path, suffix: str) -> None:
    volume = np.random.default_rng(0).integers(0, 256, size=SKEWED.shape, dtype=np.uint8)
    names = ["background", "artery", "vein"]
    path = write_volume(tmp_path / f"v{suffix}", volume, SKEWED, names, subject="default/3")
    array, grid, read_names = read_volume(path)
    np.testing.assert_array_equal(array, volume)
    np.testing.assert_allclose(grid.origin, SKEWED.origin, atol=1e-12)
    np.testing.assert_allclose(grid.axes, SKEWED.axes, atol=1e-12)
    assert read_names == names and volume_subject(path) == "default/3"
    bare = write_volume(tmp_path / f"bare{suffix}", volume, SKEWED)
    assert volume_subject(bare) is None


@pytest.mark.parametrize(
    ("change", "message"),
    [
        ({"origin": SKEWED.origin + np.array([0.0, 0.0, 2e-6])}, "not on the volume's grid"),
        ({"axes": SKEWED.axes * 1.01}, "not on the volume's grid"),
        ({"shape": (7, 5, 3)}, "labels shape (7, 5, 3) differs from the volume's (7, 5, 4)"),
    ],
)
def test_a_label_volume_must_lie_on_its_volumes_grid(tmp_path: Path, change, message) -> None:
    classes = np.random.default_rng(1).integers(0, 3, size=SKEWED.shape, dtype=np.uint8)
    names = ["background", "artery", "vein"]
    on_grid = write_volume(tmp_path / "labels.nrrd", classes, SKEWED, names)
    labels, read_names = read_label_volume(on_grid, SKEWED)
    np.testing.assert_array_equal(labels, classes)
    assert read_names == names
    # written in millimetres to six significant digits or so: a hair off is the same grid
    assert SKEWED.places_like(VolumeGrid(SKEWED.origin + 1e-7, SKEWED.axes, SKEWED.shape))
    other = VolumeGrid(**{"origin": SKEWED.origin, "axes": SKEWED.axes, "shape": SKEWED.shape,
                          **change})  # fmt: skip
    elsewhere = write_volume(tmp_path / "other.nrrd", np.zeros(other.shape, np.uint8), other)
    with pytest.raises(ResusError, match=re.escape(message)) as error:
        read_label_volume(elsewhere, SKEWED)
    assert "other.nrrd" in str(error.value)


def test_nrrd_header_is_lps_millimetres(tmp_path: Path) -> None:
    import nrrd

    write_volume(tmp_path / "v.nrrd", np.zeros(SKEWED.shape, np.float32), SKEWED)
    header = nrrd.read_header(str(tmp_path / "v.nrrd"))
    assert header["space"] == "left-posterior-superior"
    np.testing.assert_allclose(header["space origin"], [12.0, -34.0, 56.0])
    np.testing.assert_allclose(header["space directions"], SKEWED.axes * 1e3)
    np.testing.assert_array_equal(header["sizes"], SKEWED.shape)


def test_slices_png_is_written(tmp_path: Path) -> None:
    volume = np.random.default_rng(1).random(SKEWED.shape).astype(np.float32)
    labels = (volume > 0.7).astype(np.uint8)
    path = save_slices_png(tmp_path / "s.png", volume, SKEWED, labels)
    assert path.read_bytes()[:8] == b"\x89PNG\r\n\x1a\n"


def test_bad_paths_are_refused(tmp_path: Path) -> None:
    with pytest.raises(ResusError, match="must end in"):
        write_volume(tmp_path / "v.vtk", np.zeros(SKEWED.shape), SKEWED)
    with pytest.raises(ResusError, match="does not match grid"):
        write_volume(tmp_path / "v.nrrd", np.zeros((1, 2, 3)), SKEWED)
    with pytest.raises(ResusError, match="no such volume"):
        read_volume(tmp_path / "missing.mha")
    (tmp_path / "junk.nrrd").write_text("not a volume")
    with pytest.raises(ResusError, match=r"junk\.nrrd"):
        read_volume(tmp_path / "junk.nrrd")


def test_intensities_round_and_clip_to_uint8() -> None:
    np.testing.assert_array_equal(
        intensity_to_uint8(np.array([-3.0, 0.4, 0.6, 254.7, 300.0])), [0, 0, 1, 255, 255]
    )


def test_a_slicer_volume_in_ras_lands_where_the_same_volume_in_lps_does(tmp_path: Path) -> None:
    """3D Slicer may save a volume with RAS coordinates: x and y point the other way than in
    the LPS files this project, ITK and PLUS write, so they change sign on reading."""
    import nrrd

    ras_directions = np.array([[0.5, 0.1, 0.0], [0.0, -0.4, 0.0], [0.0, 0.0, 0.3]])  # mm
    ras_origin = np.array([-12.0, 34.0, 56.0])
    header = {"space": "right-anterior-superior", "space directions": ras_directions,
              "space origin": ras_origin}  # fmt: skip
    volume = np.arange(24, dtype=np.uint8).reshape(4, 3, 2)
    nrrd.write(str(tmp_path / "ras.nrrd"), volume, header, index_order="F")
    array, grid, _ = read_volume(tmp_path / "ras.nrrd")
    np.testing.assert_array_equal(array, volume)
    index = np.array([3, 1, 1])
    ras_mm = ras_origin + index @ ras_directions
    lps_m = ras_mm * [-1.0, -1.0, 1.0] * 1e-3
    np.testing.assert_allclose(grid.origin + index @ grid.axes, lps_m, atol=1e-12)
    lps = VolumeGrid(
        origin=ras_origin * [-1.0, -1.0, 1.0] * 1e-3,
        axes=ras_directions * [-1.0, -1.0, 1.0] * 1e-3,
        shape=volume.shape,
    )
    written = write_volume(tmp_path / "lps.nrrd", volume, lps)
    assert read_volume(written)[1].places_like(grid)


def test_an_nrrd_with_spacings_alone_is_an_axis_aligned_grid_at_zero(tmp_path: Path) -> None:
    import nrrd

    volume = np.zeros((3, 4, 5), np.uint8)
    nrrd.write(str(tmp_path / "old.nrrd"), volume, {"spacings": [0.5, 0.25, 2.0]})
    _, grid, names = read_volume(tmp_path / "old.nrrd")
    np.testing.assert_allclose(grid.axes, np.diag([0.5e-3, 0.25e-3, 2e-3]), atol=1e-15)
    np.testing.assert_allclose(grid.origin, 0.0)
    assert names is None


def test_volumes_that_are_not_3d_or_not_readable_are_one_line(tmp_path: Path) -> None:
    import nrrd
    import SimpleITK as sitk

    nrrd.write(str(tmp_path / "flat.nrrd"), np.zeros((3, 4), np.uint8))
    sitk.WriteImage(sitk.GetImageFromArray(np.zeros((3, 4), np.uint8)), str(tmp_path / "flat.mha"))
    (tmp_path / "junk.mha").write_text("not a volume")
    (tmp_path / "junk.nrrd").write_text("not a volume")
    cases = [
        (read_volume, "flat.nrrd", "expected a 3D volume, got 2 dimensions"),
        (read_volume, "flat.mha", "expected a 3D volume, got 2 dimensions"),
        (read_volume, "junk.mha", "not a readable MetaImage volume"),
        (volume_subject, "junk.mha", "not a readable MetaImage volume"),
        (volume_subject, "junk.nrrd", "not a readable NRRD volume"),
    ]
    for read, name, message in cases:
        with pytest.raises(ResusError) as error:
            read(tmp_path / name)
        text = str(error.value)
        assert text.startswith(f"{tmp_path / name}: {message}") and "\n" not in text, text
