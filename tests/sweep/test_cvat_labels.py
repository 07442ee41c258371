"""CVAT labels (`resus.sweep.cvat`) on folders made here: export-labels then attach-labels gives
the labels back; CVAT's class names and their synonyms map to artery and vein; plain label
PNGs work too; and every bad folder is one line naming the file."""

from __future__ import annotations

import dataclasses
import shutil
from pathlib import Path

import cv2
import numpy as np
import pytest
from sweep_samples import sample_sweep

from resus.errors import ResusError
from resus.sweep.cvat import (
    attach_labels,
    class_value,
    export_labels,
    frame_name,
    read_label_masks,
)
from sim.labels import ARTERY, BACKGROUND, LABEL_COLOURS, LABEL_NAMES, VEIN

ROWS, COLS = 32, 48


@pytest.fixture
def sweep():
    return sample_sweep(n=5, rows=ROWS, cols=COLS, seed=21)


def write_rgb(path: Path, rgb: np.ndarray) -> None:
    path.parent.mkdir(parents=True, exist_ok=True)
    assert cv2.imwrite(str(path), np.ascontiguousarray(rgb[..., ::-1]))


def cvat_folder(folder: Path, labels: np.ndarray, classes: dict[str, tuple[int, int, int]],
                values: dict[int, str], names=None) -> Path:  # fmt: skip
    """A CVAT "Segmentation mask 1.1" export: `classes` name -> colour in labelmap.txt,
    label value v painted in the colour of class `values[v]`."""
    lines = ["# label:color_rgb:parts:actions"]
    lines += [f"{name}:{r},{g},{b}::" for name, (r, g, b) in classes.items()]
    (folder / "labelmap.txt").parent.mkdir(parents=True, exist_ok=True)
    (folder / "labelmap.txt").write_text("\n".join(lines) + "\n")
    names = names or [frame_name(i) for i in range(len(labels))]
    lut = np.array([classes[values[v]] for v in range(3)], np.uint8)
    for name, label in zip(names, labels, strict=True):
        write_rgb(folder / "SegmentationClass" / f"{name}.png", lut[label])
    image_set = folder / "ImageSets" / "Segmentation" / "default.txt"
    image_set.parent.mkdir(parents=True, exist_ok=True)
    image_set.write_text("\n".join(names) + "\n")
    return folder


def test_export_then_attach_gives_the_labels_back(sweep, tmp_path):
    assert export_labels(sweep, tmp_path / "cvat", frames=True) == len(sweep)
    labelmap = (tmp_path / "cvat" / "labelmap.txt").read_text().splitlines()
    assert labelmap == [
        "# label:color_rgb:parts:actions",
        *(f"{n}:{','.join(map(str, LABEL_COLOURS[n]))}::" for n in LABEL_NAMES),
    ]
    names = (tmp_path / "cvat" / "ImageSets/Segmentation/default.txt").read_text().split()
    assert names == [f"frame_{i:06d}" for i in range(len(sweep))]
    mask = cv2.imread(str(tmp_path / "cvat/SegmentationClass/frame_000002.png"))[..., ::-1]
    artery = sweep.labels[2] == ARTERY
    assert (mask[artery] == LABEL_COLOURS["artery"]).all()
    frame = cv2.imread(str(tmp_path / "cvat/JPEGImages/frame_000002.png"), cv2.IMREAD_UNCHANGED)
    np.testing.assert_array_equal(frame, sweep.frames[2])
    unlabelled = dataclasses.replace(sweep, labels=None)
    back = attach_labels(unlabelled, tmp_path / "cvat")
    np.testing.assert_array_equal(back.labels, sweep.labels)
    assert back.label_names == LABEL_NAMES
    np.testing.assert_array_equal(back.frames, sweep.frames)  # the rest unchanged
    np.testing.assert_array_equal(back.probe_to_base, sweep.probe_to_base)


@pytest.mark.parametrize(
    ("name", "value"),
    [
        ("background", BACKGROUND), ("Background", BACKGROUND), ("bg", BACKGROUND),
        ("artery", ARTERY), ("Femoral Artery", ARTERY), ("femoral_artery", ARTERY),
        ("CFA", ARTERY), ("sfa", ARTERY), ("Common-Femoral-Artery", ARTERY),
        ("left femoral artery", ARTERY), ("profunda femoris", ARTERY),
        ("vein", VEIN), ("Femoral Vein", VEIN), ("CFV", VEIN), ("GSV", VEIN),
        ("great saphenous vein", VEIN), ("Right_Common_Femoral_Vein", VEIN),
    ],
)  # fmt: skip
def test_class_names_and_synonyms(name, value):
    assert class_value(name) == value


def test_a_cvat_export_with_its_own_names_and_colours(sweep, tmp_path):
    classes = {"background": (0, 0, 0), "CFA": (250, 50, 83), "Femoral Vein": (51, 221, 255)}
    folder = cvat_folder(
        tmp_path / "task", sweep.labels, classes, {0: "background", 1: "CFA", 2: "Femoral Vein"}
    )
    np.testing.assert_array_equal(read_label_masks(folder, 5, (ROWS, COLS)), sweep.labels)
    # names from images keep their own names: anything ending in the frame number
    shutil.rmtree(folder)
    names = ["scan/img_00000", "scan/img_00001", "2", "frame3", "frame_000004"]
    cvat_folder(
        folder, sweep.labels, classes, {0: "background", 1: "CFA", 2: "Femoral Vein"}, names
    )
    np.testing.assert_array_equal(read_label_masks(folder, 5, (ROWS, COLS)), sweep.labels)


def test_plain_label_pngs(sweep, tmp_path):
    for index, label in enumerate(sweep.labels):
        assert cv2.imwrite(str(tmp_path / f"frame_{index:06d}.png"), label)
    back = attach_labels(dataclasses.replace(sweep, labels=None), tmp_path)
    np.testing.assert_array_equal(back.labels, sweep.labels)


def one_line(error: pytest.ExceptionInfo, *fragments: str) -> str:
    text = str(error.value)
    assert "\n" not in text, text
    for fragment in fragments:
        assert fragment in text, (fragment, text)
    return text


def test_missing_frames_are_one_line(sweep, tmp_path):
    export_labels(sweep, tmp_path / "cvat")
    (tmp_path / "cvat/SegmentationClass/frame_000003.png").unlink()
    with pytest.raises(ResusError) as error:
        attach_labels(sweep, tmp_path / "cvat")
    one_line(
        error, "frame_000003.png", "is listed in ImageSets/Segmentation/default.txt but missing"
    )
    (tmp_path / "cvat/ImageSets/Segmentation/default.txt").unlink()  # then the files decide
    with pytest.raises(ResusError) as error:
        attach_labels(sweep, tmp_path / "cvat")
    text = one_line(
        error, "no mask for 1 of the sweep's 5 frames (3; expected e.g. frame_000003.png)"
    )
    assert text.startswith(str(tmp_path / "cvat"))


def test_a_mask_for_no_frame_or_twice_is_one_line(sweep, tmp_path):
    for index in range(6):
        assert cv2.imwrite(str(tmp_path / f"frame_{index:06d}.png"), sweep.labels[index % 5])
    with pytest.raises(ResusError) as error:
        attach_labels(sweep, tmp_path)
    one_line(error, "frame_000005.png: names frame 5, but the sweep has 5 frames (0-4")
    (tmp_path / "frame_000005.png").rename(tmp_path / "again_1.png")
    with pytest.raises(ResusError) as error:
        attach_labels(sweep, tmp_path)
    one_line(error, "is a second mask for frame 1")


def test_unknown_colours_classes_and_values_are_one_line(sweep, tmp_path):
    export_labels(sweep, tmp_path / "cvat")
    mask = tmp_path / "cvat/SegmentationClass/frame_000001.png"
    image = cv2.imread(str(mask))
    image[4, 7] = (1, 2, 3)  # BGR
    cv2.imwrite(str(mask), image)
    with pytest.raises(ResusError) as error:
        attach_labels(sweep, tmp_path / "cvat")
    one_line(error, f"{mask}: colour (3, 2, 1) at pixel (col 7, row 4) is not in labelmap.txt")

    labelmap = tmp_path / "cvat/labelmap.txt"
    labelmap.write_text(labelmap.read_text() + "femoral nerve:250,250,0::\n")
    with pytest.raises(ResusError) as error:
        attach_labels(sweep, tmp_path / "cvat")
    one_line(error, f"{labelmap}: line 5: class 'femoral nerve' is none of background, artery")

    plain = tmp_path / "plain"
    plain.mkdir()
    for index, label in enumerate(sweep.labels):
        assert cv2.imwrite(str(plain / f"frame_{index:06d}.png"), label * (4 if index == 2 else 1))
    with pytest.raises(ResusError) as error:
        attach_labels(sweep, plain)
    one_line(error, "frame_000002.png: label value 4 at pixel", "is none of 0 background, 1 artery")


def test_a_size_mismatch_is_one_line(sweep, tmp_path):
    for index, label in enumerate(sweep.labels):
        label = label[:, :-1] if index == 4 else label
        assert cv2.imwrite(str(tmp_path / f"frame_{index:06d}.png"), label)
    with pytest.raises(ResusError) as error:
        attach_labels(sweep, tmp_path)
    one_line(error, "frame_000004.png: mask is 47 x 32 px, the sweep's frames are 48 x 32")


def test_nothing_to_read_or_write_is_one_line(sweep, tmp_path):
    with pytest.raises(ResusError, match="holds no label PNGs"):
        attach_labels(sweep, tmp_path)
    with pytest.raises(ResusError, match="no such folder"):
        attach_labels(sweep, tmp_path / "nowhere")
    with pytest.raises(ResusError, match="the sweep has no labels to export"):
        export_labels(dataclasses.replace(sweep, labels=None), tmp_path / "out")


def damage_labelmap(text: str):
    def damage(folder: Path) -> Path:
        (folder / "labelmap.txt").write_text(text)
        return folder / "labelmap.txt"

    return damage


def damage_bytes(relative: str, content: bytes):
    def damage(folder: Path) -> Path:
        (folder / relative).write_bytes(content)
        return folder / relative

    return damage


def no_masks_folder(folder: Path) -> Path:
    shutil.rmtree(folder / "SegmentationClass")
    return folder


@pytest.mark.parametrize(
    ("damage", "message"),
    [
        (damage_labelmap("artery:250,50::\n"), "line 1: expected 'name:r,g,b::', got 'artery"),
        (damage_labelmap("artery:256,0,0::\n"), "line 1: expected 'name:r,g,b::'"),
        (
            damage_labelmap("# a comment\nartery:1,2,3::\nvein:1,2,3::\n"),
            "line 3: colour (1, 2, 3) is given to two classes",
        ),
        (damage_labelmap("# label:color_rgb:parts:actions\n\n"), "lists no classes"),
        (damage_bytes("labelmap.txt", b"artery:\xff\xfe"), "cannot read the labelmap"),
        (no_masks_folder, "has labelmap.txt but no SegmentationClass folder"),
        (
            damage_bytes("SegmentationClass/frame_000002.png", b"not a png"),
            "not a readable PNG image",
        ),
    ],
    ids=["two numbers", "over 255", "one colour twice", "no class", "not text", "no masks", "png"],
)
def test_a_broken_cvat_export_is_one_line_naming_the_file(sweep, tmp_path, damage, message):
    export_labels(sweep, tmp_path / "cvat")
    broken = damage(tmp_path / "cvat")
    with pytest.raises(ResusError) as error:
        attach_labels(sweep, tmp_path / "cvat")
    assert one_line(error, message).startswith(str(broken))


def test_masks_with_alpha_or_in_grey_read_as_their_colours(sweep, tmp_path):
    """CVAT's masks are RGB; an editor may save them with an alpha channel, or as grey when
    every colour of the labelmap is a grey."""
    export_labels(sweep, tmp_path / "cvat")
    mask = tmp_path / "cvat/SegmentationClass/frame_000001.png"
    bgr = cv2.imread(str(mask))
    assert cv2.imwrite(str(mask), np.dstack([bgr, np.full(bgr.shape[:2], 255, np.uint8)]))
    np.testing.assert_array_equal(attach_labels(sweep, tmp_path / "cvat").labels, sweep.labels)

    greys = {"background": (0, 0, 0), "artery": (90, 90, 90), "vein": (180, 180, 180)}
    folder = cvat_folder(tmp_path / "grey", sweep.labels, greys, dict(enumerate(greys)))
    for path in (folder / "SegmentationClass").glob("*.png"):
        assert cv2.imwrite(str(path), cv2.imread(str(path), cv2.IMREAD_GRAYSCALE))
    np.testing.assert_array_equal(read_label_masks(folder, 5, (ROWS, COLS)), sweep.labels)


def test_a_colour_plain_mask_or_one_without_a_frame_number_is_one_line(sweep, tmp_path):
    for index, label in enumerate(sweep.labels):
        assert cv2.imwrite(str(tmp_path / f"frame_{index:06d}.png"), label)
    colour = tmp_path / "frame_000003.png"
    assert cv2.imwrite(str(colour), np.dstack([sweep.labels[3]] * 3))
    with pytest.raises(ResusError) as error:
        attach_labels(sweep, tmp_path)
    one_line(error, f"{colour}: is a colour image: plain label PNGs hold the values 0, 1, 2")
    assert cv2.imwrite(str(colour), sweep.labels[3])
    (tmp_path / "frame_000004.png").rename(tmp_path / "last.png")
    with pytest.raises(ResusError) as error:
        attach_labels(sweep, tmp_path)
    one_line(error, f"{tmp_path / 'last.png'}: mask 'last' does not end in a frame number")
