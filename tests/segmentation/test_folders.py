"""Reading a folder of real images and one of masks: modes, classes, sizes and the errors."""

import numpy as np
import pytest
from PIL import Image

from resus.errors import ResusError
from resus.segmentation.folders import VESSEL, read_folders, read_image
from sim.labels import ARTERY, VEIN, label_colour

SHAPE = (12, 16)  # rows, columns


def vessel_mask(shape=SHAPE) -> np.ndarray:
    """A boolean mask with a 4 x 5 vessel in it."""
    mask = np.zeros(shape, bool)
    mask[3:7, 4:9] = True
    return mask


def grey_ramp(shape=SHAPE) -> np.ndarray:
    return (np.arange(shape[0] * shape[1]).reshape(shape) % 256).astype(np.uint8)


def palette_image(indices: np.ndarray, colours: list[tuple[int, int, int]]) -> Image.Image:
    image = Image.fromarray(indices.astype(np.uint8), mode="P")
    image.putpalette([channel for colour in colours for channel in colour])
    return image


@pytest.fixture
def folders(tmp_path):
    (tmp_path / "images").mkdir()
    (tmp_path / "masks").mkdir()
    return tmp_path / "images", tmp_path / "masks"


def test_images_of_every_mode_become_grey(tmp_path) -> None:
    rgb = np.zeros((*SHAPE, 3), np.uint8)
    rgb[..., 0] = 255  # pure red: ITU-R 601 luma 0.299 * 255 = 76
    rgb[:, 8:] = (10, 200, 30)  # 0.299 * 10 + 0.587 * 200 + 0.114 * 30 = 123.8
    Image.fromarray(rgb).save(tmp_path / "rgb.png")
    Image.fromarray(np.dstack([rgb, np.full(SHAPE, 90, np.uint8)])).save(tmp_path / "rgba.png")
    palette_image(
        np.where(np.arange(16) < 8, 0, 1)[None].repeat(12, 0), [(255, 0, 0), (10, 200, 30)]
    ).save(tmp_path / "palette.png")
    expected = np.where(np.arange(16) < 8, 76, 124)[None].repeat(12, 0)
    for name in ("rgb.png", "rgba.png", "palette.png"):
        grey = read_image(tmp_path / name)
        assert grey.dtype == np.uint8 and grey.shape == SHAPE, name
        np.testing.assert_array_equal(grey, expected, err_msg=name)
    Image.fromarray(grey_ramp()).save(tmp_path / "grey.png")
    np.testing.assert_array_equal(read_image(tmp_path / "grey.png"), grey_ramp())
    Image.fromarray(np.full((*SHAPE, 3), 128, np.uint8)).save(tmp_path / "grey.jpg", quality=95)
    assert np.abs(read_image(tmp_path / "grey.jpg").astype(int) - 128).max() <= 2


def test_grey_rgb_and_palette_masks_all_read_as_vessel(folders) -> None:
    images, masks = folders
    vessel = vessel_mask()
    for name in ("grey", "rgb", "palette", "reordered", "bilevel", "deep"):
        Image.fromarray(grey_ramp()).save(images / f"{name}.png")
    Image.fromarray(vessel.astype(np.uint8) * 255).save(masks / "grey.png")
    rgb = np.zeros((*SHAPE, 3), np.uint8)
    rgb[vessel] = (0, 255, 0)  # any colour but black is vessel
    Image.fromarray(rgb).save(masks / "rgb.png")
    palette_image(vessel, [(0, 0, 0), (255, 255, 255)]).save(masks / "palette.png")
    # an optimised grey palette: index 0 is white, so the greys count, not the indices
    palette_image(~vessel, [(255, 255, 255), (0, 0, 0)]).save(masks / "reordered.png")
    Image.fromarray(vessel).save(masks / "bilevel.png")
    Image.fromarray(vessel.astype(np.uint16) * 1000).save(masks / "deep.png")  # 16-bit grey
    data = read_folders(images, masks)
    assert data.names == ("bilevel", "deep", "grey", "palette", "reordered", "rgb")
    assert data.classes == (VESSEL,) and not data.separates_classes
    for name, labels in zip(data.names, data.labels, strict=True):
        assert labels.dtype == np.uint8, name
        np.testing.assert_array_equal(labels, vessel.astype(np.uint8), err_msg=name)


def test_masks_of_label_values_or_colours_keep_artery_and_vein(folders) -> None:
    images, masks = folders
    truth = np.zeros(SHAPE, np.uint8)
    truth[2:5, 2:6], truth[6:10, 8:14] = ARTERY, VEIN
    for name in ("values", "colours", "indices"):
        Image.fromarray(grey_ramp()).save(images / f"{name}.png")
    Image.fromarray(truth).save(masks / "values.png")
    Image.fromarray(np.array([label_colour(v) for v in range(3)], np.uint8)[truth]).save(
        masks / "colours.png"
    )
    palette_image(truth, [(0, 0, 0), (128, 0, 0), (0, 128, 0)]).save(masks / "indices.png")
    data = read_folders(images, masks)
    assert data.classes == ("artery", "vein") and data.separates_classes
    for name, labels in zip(data.names, data.labels, strict=True):
        np.testing.assert_array_equal(labels, truth, err_msg=name)


def test_masks_without_a_vein_are_one_vessel_class(folders) -> None:
    images, masks = folders
    Image.fromarray(grey_ramp()).save(images / "a.png")
    Image.fromarray(vessel_mask().astype(np.uint8)).save(masks / "a.png")  # 0/1: no vein
    assert read_folders(images, masks).classes == (VESSEL,)


def test_images_of_different_sizes_are_grouped_by_size(folders) -> None:
    images, masks = folders
    for name, shape in (("a", SHAPE), ("b", (20, 8)), ("c", SHAPE)):
        Image.fromarray(grey_ramp(shape)).save(images / f"{name}.png")
        Image.fromarray(vessel_mask(shape).astype(np.uint8) * 255).save(masks / f"{name}.png")
    data = read_folders(images, masks)
    assert [image.shape for image in data.images] == [SHAPE, (20, 8), SHAPE]
    sets = data.labelled_sets()
    assert [s.images.shape for s in sets] == [(2, *SHAPE), (1, 20, 8)]
    assert {s.subject for s in sets} == {images.parent.name}
    assert data.labelled_sets("volunteers")[0].subject == "volunteers"


def test_a_size_mismatch_is_one_line_naming_both_files(folders) -> None:
    images, masks = folders
    Image.fromarray(grey_ramp((12, 20))).save(images / "0003.png")
    Image.fromarray(np.zeros(SHAPE, np.uint8)).save(masks / "0003.png")
    with pytest.raises(ResusError) as refused:
        read_folders(images, masks)
    message = str(refused.value)
    assert message == f"{masks / '0003.png'}: 16x12, but its image {images / '0003.png'} is 20x12"
    assert "\n" not in message


def test_unpaired_unreadable_and_missing_files_are_named(folders) -> None:
    images, masks = folders
    with pytest.raises(ResusError, match=r"images: holds no PNG or JPG files$"):
        read_folders(images, masks)
    with pytest.raises(ResusError, match=r"nowhere: no such folder$"):
        read_folders(images.parent / "nowhere", masks)
    for name in ("0001", "0002"):
        Image.fromarray(grey_ramp()).save(images / f"{name}.png")
    Image.fromarray(np.zeros(SHAPE, np.uint8)).save(masks / "0001.png")
    with pytest.raises(ResusError, match=r"images/0002\.png: has no mask .*masks/0002\.png$"):
        read_folders(images, masks)
    Image.fromarray(np.zeros(SHAPE, np.uint8)).save(masks / "0002.png")
    Image.fromarray(np.zeros(SHAPE, np.uint8)).save(masks / "0009.png")
    with pytest.raises(ResusError, match=r"masks/0009\.png: has no image of its name in "):
        read_folders(images, masks)
    (masks / "0009.png").unlink()
    (masks / "0002.png").write_bytes(b"not a png")
    with pytest.raises(ResusError, match=r"masks/0002\.png: not a readable image"):
        read_folders(images, masks)
    Image.fromarray(np.zeros((*SHAPE, 3), np.uint8)).save(images / "0002.jpg")
    with pytest.raises(ResusError, match=r"0002\.png: has the same name as 0002\.jpg"):
        read_folders(images, masks)
    Image.fromarray(np.zeros(SHAPE, np.uint16)).save(images / "deep.png")
    with pytest.raises(ResusError, match=r"deep\.png: is a I;16 image; expected 8-bit"):
        read_image(images / "deep.png")
