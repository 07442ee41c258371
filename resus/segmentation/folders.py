"""Labelled images from two folders: real B-mode images and their vessel masks.

Real data rarely comes as sweeps: a data set is a folder of images (`images/0001.png`) and a
folder of masks (`masks/0001.png`), paired by file stem. `read_folders` reads both into
`FolderImages`, which `labelled_sets` turns into the package's `LabelledImages`, so real
images train and score through the same path as simulated frames.

- Images: PNG or JPEG, 8-bit grey, RGB(A), palette or bilevel, any size. Colour becomes grey
  by the ITU-R 601 luma (`resus.sweep.images.to_grey`, as every other path into the pipeline).
- Masks: PNG only (JPEG's artefacts would mark vessels everywhere), grey, RGB(A) or palette,
  the same size as their image. RGB masks whose pixels are all grey count as grey; RGB masks
  in `sim.labels`' artery and vein colours become their label values; in other RGB masks any
  colour but black is vessel. A palette mask counts by its colours when they are all grey
  (an optimised grey PNG), else by its palette indices (VOC-style class indices).
- Classes: when every mask holds only the values 0, 1, 2 and some mask holds a 2, the masks
  tell artery (1) from vein (2) and keep them; otherwise any nonzero pixel is "vessel",
  stored as label 1, the same for the whole folder.
- Sizes: images of different sizes may share a folder; `FolderImages` keeps each at its own
  size and `labelled_sets` makes one `LabelledImages` per size.

Every problem is one line naming the file or folder: no such folder, no images in it, an
image without a mask or a mask without an image, an unreadable file, a size mismatch.
"""

from __future__ import annotations

import dataclasses
from collections.abc import Sequence
from dataclasses import dataclass
from pathlib import Path

import numpy as np
from PIL import Image

from resus.errors import ResusError
from resus.segmentation.data import LabelledImages
from resus.sweep.images import to_grey
from sim.labels import BACKGROUND, VEIN, VESSEL_CLASSES, label_colour

IMAGE_SUFFIXES = (".png", ".jpg", ".jpeg")
MASK_SUFFIXES = (".png",)
VESSEL = "vessel"
"""The one class of masks that do not tell artery from vein (stored as label 1)."""
EIGHT_BIT_MODES = ("1", "L", "LA", "P", "PA", "RGB", "RGBA", "CMYK", "YCbCr")
"""Pillow modes of 8-bit images, which `read_image` turns to grey."""
GREY_MASK_MODES = ("1", "L", "LA", "I", "I;16")
"""Pillow modes of grey masks (8- and 16-bit, bilevel), read as values."""


@dataclass(frozen=True)
class FolderImages:
    """Grey images and their labels from two folders, in file-name order."""

    names: tuple[str, ...]
    """File stems (`0001`), sorted."""
    images: tuple[np.ndarray, ...]
    """(H, W) uint8 grey images, each at its own size."""
    labels: tuple[np.ndarray, ...]
    """(H, W) uint8 labels of the images: 0 background, then 1 vessel, or 1 artery, 2 vein."""
    classes: tuple[str, ...]
    """The vessel classes the labels tell apart: ("vessel",) or ("artery", "vein")."""
    image_folder: Path
    mask_folder: Path

    def __len__(self) -> int:
        return len(self.names)

    @property
    def separates_classes(self) -> bool:
        """Whether the masks tell artery from vein (else every vessel is label 1)."""
        return self.classes != (VESSEL,)

    def subset(self, indices: Sequence[int]) -> FolderImages:
        """The images at `indices` (in that order), e.g. one split of a data set."""
        pick = [int(i) for i in indices]
        return dataclasses.replace(
            self,
            names=tuple(self.names[i] for i in pick),
            images=tuple(self.images[i] for i in pick),
            labels=tuple(self.labels[i] for i in pick),
        )

    def labelled_sets(self, subject: str | None = None) -> list[LabelledImages]:
        """One `LabelledImages` per image size, in order of first appearance.

        `subject` defaults to the name of the folder that holds the image folder
        (`usgra_seg` for `usgra_seg/images`), the data set the images come from.
        """
        subject = subject or self.image_folder.resolve().parent.name or "images"
        by_shape: dict[tuple[int, ...], list[int]] = {}
        for index, image in enumerate(self.images):
            by_shape.setdefault(image.shape, []).append(index)
        return [
            LabelledImages(
                np.stack([self.images[i] for i in indices]),
                np.stack([self.labels[i] for i in indices]),
                subject,
                f"{self.image_folder} ({shape[1]}x{shape[0]})",
            )
            for shape, indices in by_shape.items()
        ]


def image_files(folder: Path, suffixes: Sequence[str] = IMAGE_SUFFIXES) -> dict[str, Path]:
    """File stem -> path of the files in `folder` with one of `suffixes` (any case), sorted;
    a missing or empty folder, or two files of one stem, is a ResusError naming it."""
    folder = Path(folder)
    if not folder.is_dir():
        raise ResusError("no such folder", folder)
    files: dict[str, Path] = {}
    for path in sorted(folder.iterdir()):
        if path.suffix.lower() not in suffixes or not path.is_file():
            continue
        if path.stem in files:
            raise ResusError(f"has the same name as {files[path.stem].name}", path)
        files[path.stem] = path
    if not files:
        kinds = " or ".join(suffix.lstrip(".").upper() for suffix in suffixes[:2])
        raise ResusError(f"holds no {kinds} files", folder)
    return files


def _open(path: Path) -> Image.Image:
    """The decoded image at `path` (a file Pillow cannot decode is a ResusError naming it)."""
    try:
        with Image.open(path) as image:
            image.load()
            return image
    except (OSError, SyntaxError, ValueError) as error:
        raise ResusError(f"not a readable image ({error})", path) from None


def read_image(path: Path) -> np.ndarray:
    """(H, W) uint8 grey image from an 8-bit PNG or JPEG of any mode Pillow reads."""
    image = _open(path)
    if image.mode not in EIGHT_BIT_MODES:
        raise ResusError(f"is a {image.mode} image; expected 8-bit grey, RGB or palette", path)
    if image.mode == "L":
        return np.asarray(image)
    if image.mode not in ("RGB", "RGBA"):
        image = image.convert("RGB")
    return to_grey(np.asarray(image), "rgb")


def read_mask(path: Path) -> np.ndarray:
    """(H, W) uint8 mask values as the module's docstring describes; values above 2 (vein)
    become 255, so that 16-bit masks fit and only 0, 1, 2 keep their meaning."""
    image = _open(path)
    if image.mode in GREY_MASK_MODES:
        values = np.asarray(image.getchannel(0) if image.mode == "LA" else image)
    elif image.mode == "P":
        values = _palette_mask(image)
    elif image.mode in ("RGB", "RGBA", "PA"):
        values = _colour_mask(np.asarray(image.convert("RGB")))
    else:
        raise ResusError(f"is a {image.mode} image; expected a grey, RGB or palette PNG", path)
    return np.where(values > VEIN, 255, values).astype(np.uint8)


def _palette_mask(image: Image.Image) -> np.ndarray:
    """Values of a palette mask: its greys when every used colour is grey, else its indices."""
    indices = np.asarray(image)
    palette = np.asarray(image.getpalette("RGB") or [0, 0, 0], np.uint8).reshape(-1, 3)
    used = np.unique(indices)
    if used[-1] < len(palette) and (palette[used] == palette[used, :1]).all():
        return palette[indices, 0]
    return indices


def _colour_mask(rgb: np.ndarray) -> np.ndarray:
    """Values of an RGB mask: grey when r = g = b, label values when every colour is black or
    a vessel class's colour, else 255 wherever the colour is not black."""
    if (rgb == rgb[..., :1]).all():
        return np.ascontiguousarray(rgb[..., 0])
    values = np.zeros(rgb.shape[:2], np.uint8)
    known = np.zeros(rgb.shape[:2], bool)
    for value in (BACKGROUND, *VESSEL_CLASSES.values()):
        matches = (rgb == label_colour(value)).all(axis=-1)
        values[matches] = value
        known |= matches
    return values if known.all() else np.where(rgb.any(axis=-1), 255, 0).astype(np.uint8)


def _more(count: int) -> str:
    return f" (and {count - 1} more)" if count > 1 else ""


def _pair(images: dict[str, Path], masks: dict[str, Path], folders: tuple[Path, Path]) -> None:
    """Refuse an image without a mask or a mask without an image, naming the first one."""
    no_mask = sorted(set(images) - set(masks))
    if no_mask:
        expected = folders[1] / f"{no_mask[0]}.png"
        raise ResusError(f"has no mask {expected}{_more(len(no_mask))}", images[no_mask[0]])
    no_image = sorted(set(masks) - set(images))
    if no_image:
        message = f"has no image of its name in {folders[0]}{_more(len(no_image))}"
        raise ResusError(message, masks[no_image[0]])


def read_data_set(folder: Path) -> FolderImages:
    """A data set laid out as `folder/images/` and `folder/masks/` (usgra-seg's layout),
    read by `read_folders`."""
    folder = Path(folder)
    if not folder.is_dir():
        raise ResusError("no such folder", folder)
    return read_folders(folder / "images", folder / "masks")


def read_folders(image_folder: Path, mask_folder: Path) -> FolderImages:
    """Every image in `image_folder` with its mask from `mask_folder`, paired by file stem."""
    image_folder, mask_folder = Path(image_folder), Path(mask_folder)
    image_paths = image_files(image_folder)
    mask_paths = image_files(mask_folder, MASK_SUFFIXES)
    _pair(image_paths, mask_paths, (image_folder, mask_folder))
    names = tuple(image_paths)
    images, masks = [], []
    for name in names:
        image, mask = read_image(image_paths[name]), read_mask(mask_paths[name])
        if mask.shape != image.shape:
            raise ResusError(
                f"{mask.shape[1]}x{mask.shape[0]}, but its image {image_paths[name]} is "
                f"{image.shape[1]}x{image.shape[0]}",
                mask_paths[name],
            )
        images.append(image)
        masks.append(mask)
    classed = all(mask.max(initial=0) <= VEIN for mask in masks) and any(
        (mask == VEIN).any() for mask in masks
    )
    if classed:
        return FolderImages(
            names, tuple(images), tuple(masks), tuple(VESSEL_CLASSES), image_folder, mask_folder
        )
    labels = tuple((mask > 0).astype(np.uint8) for mask in masks)
    return FolderImages(names, tuple(images), labels, (VESSEL,), image_folder, mask_folder)
