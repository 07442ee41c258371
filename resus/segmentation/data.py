"""Labelled image sets and the torch dataset built from them.

A `LabelledImages` is the one currency of this package: (N, H, W) uint8 images, the matching
(N, H, W) uint8 labels (0 background, 1 artery, 2 vein) and the subject they come from. Frames
from sweeps, reslices from volumes and synthetic images all arrive in this form, and the
subject id is what leave-one-subject-out splits on.
"""

from __future__ import annotations

from collections.abc import Callable, Sequence
from dataclasses import dataclass

import cv2
import numpy as np
import torch
from torch.utils.data import Dataset

from resus.errors import ResusError
from sim.labels import LABEL_NAMES

INTENSITY_MEAN = 0.449
INTENSITY_STD = 0.226
"""Grey-level normalisation: ImageNet's channel means and deviations averaged, because a
1-channel encoder made from ImageNet weights sums the three colour filters."""


@dataclass(frozen=True)
class LabelledImages:
    """Images with per-pixel labels from one subject (one sweep, or one reslice file)."""

    images: np.ndarray
    """(N, H, W) uint8 B-mode images."""
    labels: np.ndarray
    """(N, H, W) uint8 labels: 0 background, 1 artery, 2 vein."""
    subject: str
    """Who was scanned; leave-one-subject-out splits on this."""
    source: str = ""
    """Where the set came from (a file name), for messages."""

    def __post_init__(self) -> None:
        where = self.source or f"subject {self.subject!r}"
        images, labels = np.asarray(self.images), np.asarray(self.labels)
        if images.ndim != 3 or images.dtype != np.uint8:
            raise ResusError(
                f"{where}: images must be (N, H, W) uint8, got {images.shape} {images.dtype}"
            )
        if labels.shape != images.shape or labels.dtype != np.uint8:
            raise ResusError(
                f"{where}: labels must be uint8 of the images' shape {images.shape}, "
                f"got {labels.shape} {labels.dtype}"
            )
        if labels.size and labels.max() >= len(LABEL_NAMES):
            classes = ", ".join(f"{value} {name}" for value, name in enumerate(LABEL_NAMES))
            raise ResusError(f"{where}: label {labels.max()} is not a class ({classes})")
        if not self.subject:
            raise ResusError(f"{where}: subject id is empty")
        object.__setattr__(self, "images", images)
        object.__setattr__(self, "labels", labels)

    def __len__(self) -> int:
        return len(self.images)

    def take(self, indices: slice | np.ndarray) -> LabelledImages:
        """The images at `indices`, same subject and source."""
        return LabelledImages(self.images[indices], self.labels[indices], self.subject, self.source)


def resize_images(images: np.ndarray, size: int) -> np.ndarray:
    """(N, H, W) uint8 images resized to (N, size, size): area averaging down, bilinear up."""
    return _resize_stack(
        images, size, cv2.INTER_AREA if images.shape[1] >= size else cv2.INTER_LINEAR
    )


def resize_labels(labels: np.ndarray, size: int) -> np.ndarray:
    """(N, H, W) label maps resized to (N, size, size) by nearest neighbour (no new classes)."""
    return _resize_stack(labels, size, cv2.INTER_NEAREST)


def _resize_stack(stack: np.ndarray, size: int, interpolation: int) -> np.ndarray:
    if stack.shape[1:] == (size, size):
        return np.ascontiguousarray(stack)
    out = np.empty((len(stack), size, size), dtype=stack.dtype)
    for i, image in enumerate(stack):
        out[i] = cv2.resize(image, (size, size), interpolation=interpolation)
    return out


def images_to_tensor(images: np.ndarray) -> torch.Tensor:
    """(N, H, W) uint8 -> (N, 1, H, W) float32 network input, normalised."""
    scaled = torch.from_numpy(np.ascontiguousarray(images)).float().div_(255.0)
    return scaled.sub_(INTENSITY_MEAN).div_(INTENSITY_STD).unsqueeze(1)


Augmentation = Callable[..., dict]
"""An albumentations-style callable: `augment(image=..., mask=...) -> {"image", "mask"}`."""


class SegmentationDataset(Dataset):
    """Labelled sets resized once to the network size; optional augmentation per item."""

    def __init__(
        self,
        sets: Sequence[LabelledImages],
        image_size: int,
        augmentation: Augmentation | None = None,
    ) -> None:
        if not sets or not sum(len(s) for s in sets):
            raise ResusError("segmentation dataset has no images")
        self.images = np.concatenate([resize_images(s.images, image_size) for s in sets])
        self.labels = np.concatenate([resize_labels(s.labels, image_size) for s in sets])
        self.subjects: tuple[str, ...] = tuple(sorted({s.subject for s in sets}))
        self.augmentation = augmentation

    def __len__(self) -> int:
        return len(self.images)

    def __getitem__(self, index: int) -> tuple[torch.Tensor, torch.Tensor]:
        image, labels = self.images[index], self.labels[index]
        if self.augmentation is not None:
            augmented = self.augmentation(image=image, mask=labels)
            image, labels = augmented["image"], augmented["mask"]
        return images_to_tensor(image[None])[0], torch.from_numpy(labels.astype(np.int64))
