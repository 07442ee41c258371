"""CVAT labels in and out of Sweeps: the "Segmentation mask 1.1" format, or plain label PNGs.

CVAT exports a segmentation task as a folder (or zip, unpacked) in the Pascal VOC layout:

    labelmap.txt                          # "# label:color_rgb:parts:actions", then per class
                                          #   "artery:230,40,40::"
    ImageSets/Segmentation/default.txt    # the frame names, one per line
    SegmentationClass/NAME.png            # each pixel coloured with its class's colour
    SegmentationObject/NAME.png           # instances (not used here)

`attach_labels` reads such a folder, or a folder of plain per-frame label PNGs whose pixel
values are the label values (0 background, 1 artery, 2 vein), and returns the Sweep with those
labels; `export_labels` writes a Sweep's labels back in CVAT's format, the colours those of
`sim.labels`, so that CVAT imports them for correction (and, with `frames=True`, the B-mode
frames beside them, to create the task from).

Frame names. Frame i is `frame_{i:06d}` (`frame_000123.png`), the name CVAT gives the frames of
a task made from a video, and the name of the files `export_labels` writes. Any other name
is accepted if it ends in the frame's number, counted from 0 (`img_0042`, `42`, a folder
prefix such as `sweep3/frame_000042`), as CVAT keeps the file names of a task made from images.

Class names (CVAT's labels) are matched to the Sweep's classes case-insensitively, with `_`
and `-` read as spaces and a leading "left" or "right" ignored, through `SYNONYMS`:

| class      | names                                                                       |
| ---        | ---                                                                         |
| background | background, bg                                                              |
| artery     | artery, arteries, arterial, femoral artery, common / superficial / deep      |
|            | femoral artery, profunda femoris (artery), CFA, SFA, DFA, PFA               |
| vein       | vein, veins, venous, femoral vein, common / superficial / deep femoral vein, |
|            | great saphenous vein, saphenous vein, CFV, SFV, DFV, GSV                    |

The great saphenous vein is a vein: it joins the common femoral vein in the femoral triangle
and a needle must avoid it just the same. Any other class name (a nerve, a lymph node) is an
error rather than silently background; rename it in CVAT or delete its masks.

Every problem is one line naming the file: a frame without a mask, a mask for no frame, a
colour not in labelmap.txt, a label value outside 0-2, a mask whose size is not the frames'.
"""

from __future__ import annotations

import dataclasses
import re
from pathlib import Path

import numpy as np

from resus.errors import ResusError
from resus.sweep.model import Sweep
from sim.labels import ARTERY, BACKGROUND, LABEL_NAMES, VEIN, label_colour

LABELMAP = "labelmap.txt"
CLASS_FOLDER = "SegmentationClass"
IMAGE_SET = Path("ImageSets", "Segmentation", "default.txt")
FRAMES_FOLDER = "JPEGImages"
"""Where `export_labels(frames=True)` puts the B-mode frames (VOC's name; the files are PNG)."""
LABELMAP_HEADER = "# label:color_rgb:parts:actions"


def frame_name(index: int) -> str:
    """The file name (without `.png`) of frame `index`: CVAT's name for video frames."""
    return f"frame_{index:06d}"


def _synonyms() -> dict[str, int]:
    femoral = ("common femoral", "superficial femoral", "deep femoral", "femoral")
    artery = [
        "artery", "arteries", "arterial", *(f"{f} artery" for f in femoral),
        "profunda femoris", "profunda femoris artery", "cfa", "sfa", "dfa", "pfa",
    ]  # fmt: skip
    vein = [
        "vein", "veins", "venous", *(f"{f} vein" for f in femoral),
        "great saphenous vein", "saphenous vein", "cfv", "sfv", "dfv", "gsv",
    ]  # fmt: skip
    table = {"background": BACKGROUND, "bg": BACKGROUND}
    table.update(dict.fromkeys(artery, ARTERY))
    table.update(dict.fromkeys(vein, VEIN))
    return table


SYNONYMS: dict[str, int] = _synonyms()
"""Normalised class name -> label value of `sim.labels` (see the module's table)."""


def normalise(name: str) -> str:
    """'Left_Femoral-Artery ' -> 'femoral artery': lower case, `_`/`-` as spaces, no side."""
    words = re.sub(r"[_\-\s]+", " ", name.strip().lower()).split()
    if len(words) > 1 and words[0] in ("left", "right"):
        words = words[1:]
    return " ".join(words)


def class_value(name: str) -> int:
    """The label value a CVAT class name stands for (ResusError for an unknown name)."""
    value = SYNONYMS.get(normalise(name))
    if value is None:
        raise ResusError(
            f"class {name!r} is none of {', '.join(LABEL_NAMES)} (nor a known synonym "
            "such as 'femoral artery', 'CFA', 'femoral vein', 'GSV')"
        )
    return value


def frame_index(name: str) -> int:
    """The frame number a file name ends in (`frame_000123` -> 123)."""
    match = re.search(r"(\d+)$", Path(name).name.removesuffix(".png"))
    if match is None:
        raise ResusError(f"mask {name!r} does not end in a frame number (e.g. frame_000123)")
    return int(match.group(1))


def read_labelmap(path: Path) -> dict[tuple[int, int, int], int]:
    """RGB colour -> label value from a CVAT/VOC labelmap.txt."""
    colours: dict[tuple[int, int, int], int] = {}
    try:
        lines = path.read_text().splitlines()
    except (OSError, UnicodeDecodeError) as error:
        raise ResusError(f"cannot read the labelmap ({error})", path) from None
    for number, line in enumerate(lines, start=1):
        if not line.strip() or line.lstrip().startswith("#"):
            continue
        name, _, rest = line.partition(":")
        try:
            colour = tuple(int(part) for part in rest.split(":")[0].split(","))
        except ValueError:
            colour = ()
        if len(colour) != 3 or not all(0 <= c <= 255 for c in colour):
            raise ResusError(f"line {number}: expected 'name:r,g,b::', got {line!r}", path)
        try:
            value = class_value(name)
        except ResusError as error:
            raise ResusError(f"line {number}: {error}", path) from None
        rgb = (colour[0], colour[1], colour[2])
        if colours.get(rgb, value) != value:
            raise ResusError(f"line {number}: colour {rgb} is given to two classes", path)
        colours[rgb] = value
    if not colours:
        raise ResusError("lists no classes", path)
    return colours


def _read_png(path: Path) -> np.ndarray:
    import cv2

    image = cv2.imread(str(path), cv2.IMREAD_UNCHANGED)
    if image is None:
        raise ResusError("not a readable PNG image", path)
    if image.ndim == 3 and image.shape[2] == 4:
        image = image[:, :, :3]
    if image.ndim == 3:
        image = np.ascontiguousarray(image[:, :, ::-1])  # OpenCV reads BGR
    return image


def _check_size(image: np.ndarray, shape: tuple[int, int], path: Path) -> None:
    if image.shape[:2] != shape:
        raise ResusError(
            f"mask is {image.shape[1]} x {image.shape[0]} px, the sweep's frames are "
            f"{shape[1]} x {shape[0]}",
            path,
        )


def _colour_mask(path: Path, colours: dict, shape: tuple[int, int]) -> np.ndarray:
    """Label values of a mask coloured by the labelmap."""
    image = _read_png(path)
    if image.ndim == 2:
        image = np.repeat(image[:, :, None], 3, axis=2)  # a grey PNG of grey colours
    _check_size(image, shape, path)
    rgb = image.astype(np.int64)
    packed = (rgb[..., 0] << 16) | (rgb[..., 1] << 8) | rgb[..., 2]
    keys = np.array([(r << 16) | (g << 8) | b for r, g, b in colours], np.int64)
    values = np.array(list(colours.values()), np.uint8)
    order = np.argsort(keys)
    where = np.clip(np.searchsorted(keys[order], packed), 0, len(keys) - 1)
    known = keys[order][where] == packed
    if not known.all():
        row, col = np.argwhere(~known)[0]
        colour = tuple(int(c) for c in image[row, col])
        raise ResusError(
            f"colour {colour} at pixel (col {col}, row {row}) is not in {LABELMAP}", path
        )
    return values[order][where]


def _value_mask(path: Path, shape: tuple[int, int]) -> np.ndarray:
    """Label values of a plain label PNG (one grey value per pixel: 0, 1, 2)."""
    image = _read_png(path)
    if image.ndim != 2:
        raise ResusError(
            "is a colour image: plain label PNGs hold the values 0, 1, 2 (a CVAT export "
            f"has a {LABELMAP})",
            path,
        )
    _check_size(image, shape, path)
    if image.max(initial=0) >= len(LABEL_NAMES):
        row, col = np.argwhere(image >= len(LABEL_NAMES))[0]
        allowed = ", ".join(f"{v} {n}" for v, n in enumerate(LABEL_NAMES))
        raise ResusError(
            f"label value {int(image[row, col])} at pixel (col {col}, row {row}) is none of "
            f"{allowed}",
            path,
        )
    return image.astype(np.uint8)


def _mask_files(folder: Path) -> tuple[list[tuple[str, Path]], bool]:
    """(name, file) of every mask, and whether they are CVAT colour masks."""
    if (folder / LABELMAP).is_file():
        masks = folder / CLASS_FOLDER
        if not masks.is_dir():
            raise ResusError(f"has {LABELMAP} but no {CLASS_FOLDER} folder", folder)
        image_set = folder / IMAGE_SET
        if image_set.is_file():
            names = [line.strip() for line in image_set.read_text().splitlines() if line.strip()]
        else:
            names = sorted(str(p.relative_to(masks).with_suffix("")) for p in masks.rglob("*.png"))
        return [(name, masks / f"{name}.png") for name in names], True
    files = sorted(folder.glob("*.png"))
    return [(path.stem, path) for path in files], False


def read_label_masks(folder: str | Path, count: int, shape: tuple[int, int]) -> np.ndarray:
    """(count, rows, cols) uint8 label values from a CVAT export or plain label PNGs in
    `folder`, one mask per frame 0..count-1."""
    folder = Path(folder)
    if not folder.is_dir():
        raise ResusError("no such folder", folder)
    files, coloured = _mask_files(folder)
    if not files:
        raise ResusError(f"holds no label PNGs (nor a {LABELMAP} with {CLASS_FOLDER}/)", folder)
    colours = read_labelmap(folder / LABELMAP) if coloured else {}
    by_index: dict[int, tuple[str, Path]] = {}
    for name, path in files:
        try:
            index = frame_index(name)
        except ResusError as error:
            raise ResusError(str(error), path) from None
        if index >= count:
            raise ResusError(
                f"names frame {index}, but the sweep has {count} frames (0-{count - 1}; "
                f"frames count from 0, {frame_name(0)}.png)",
                path,
            )
        if index in by_index:
            raise ResusError(f"is a second mask for frame {index}: {by_index[index][1]}", path)
        if not path.is_file():
            raise ResusError(f"mask {name!r} is listed in {IMAGE_SET} but missing", path)
        by_index[index] = (name, path)
    missing = [i for i in range(count) if i not in by_index]
    if missing:
        shown = ", ".join(map(str, missing[:5])) + (", ..." if len(missing) > 5 else "")
        raise ResusError(
            f"no mask for {len(missing)} of the sweep's {count} frames ({shown}; expected "
            f"e.g. {frame_name(missing[0])}.png)",
            folder,
        )
    labels = np.zeros((count, *shape), np.uint8)
    for index, (_, path) in by_index.items():
        labels[index] = _colour_mask(path, colours, shape) if coloured else _value_mask(path, shape)
    return labels


def attach_labels(sweep: Sweep, folder: str | Path) -> Sweep:
    """`sweep` with its labels from the masks in `folder` (replacing any it had)."""
    labels = read_label_masks(folder, len(sweep), sweep.frame_shape)
    return dataclasses.replace(sweep, labels=labels, label_names=LABEL_NAMES)


def export_labels(sweep: Sweep, folder: str | Path, *, frames: bool = False) -> int:
    """Write the sweep's labels as a CVAT "Segmentation mask 1.1" folder (and the frames
    under JPEGImages/ with `frames`); return the number of masks written."""
    import cv2

    folder = Path(folder)
    if sweep.labels is None:
        raise ResusError("the sweep has no labels to export")
    if not folder.parent.is_dir():
        raise ResusError("output folder does not exist", folder.parent)
    colours = [label_colour(value, name) for value, name in enumerate(sweep.label_names)]
    lines = [LABELMAP_HEADER]
    lines += [
        f"{name}:{r},{g},{b}::" for name, (r, g, b) in zip(sweep.label_names, colours, strict=True)
    ]
    palette = np.array(colours, np.uint8)[:, ::-1]  # OpenCV writes BGR
    names = [frame_name(index) for index in range(len(sweep))]
    try:
        (folder / CLASS_FOLDER).mkdir(parents=True, exist_ok=True)
        (folder / IMAGE_SET).parent.mkdir(parents=True, exist_ok=True)
        (folder / LABELMAP).write_text("\n".join(lines) + "\n")
        (folder / IMAGE_SET).write_text("\n".join(names) + "\n")
        if frames:
            (folder / FRAMES_FOLDER).mkdir(exist_ok=True)
        for index, name in enumerate(names):
            if not cv2.imwrite(
                str(folder / CLASS_FOLDER / f"{name}.png"), palette[sweep.labels[index]]
            ):
                raise OSError(f"cannot write {CLASS_FOLDER}/{name}.png")
            if frames and not cv2.imwrite(
                str(folder / FRAMES_FOLDER / f"{name}.png"), sweep.frames[index]
            ):
                raise OSError(f"cannot write {FRAMES_FOLDER}/{name}.png")
    except OSError as error:
        raise ResusError(f"writing the labels failed ({error.strerror or error})", folder) from None
    return len(names)
