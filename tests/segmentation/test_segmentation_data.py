"""Labelled image sets, resizing and the `aug` regime's transforms keeping labels aligned."""

from dataclasses import replace

import numpy as np
import pytest

from resus.errors import ResusError
from resus.segmentation.augment import build_augmentation
from resus.segmentation.data import LabelledImages, SegmentationDataset, resize_labels
from resus.segmentation.presets import AugmentationConfig
from resus.segmentation.synthetic import synthetic_subject


def test_labelled_images_rejects_bad_input() -> None:
    images = np.zeros((2, 8, 8), dtype=np.uint8)
    with pytest.raises(ResusError, match=r"images must be \(N, H, W\) uint8"):
        LabelledImages(images.astype(np.float32), images, "s1")
    with pytest.raises(ResusError, match="labels must be uint8"):
        LabelledImages(images, images[:1], "s1")
    with pytest.raises(ResusError, match="label 3"):
        LabelledImages(images, images + 3, "s1")
    with pytest.raises(ResusError, match="subject id is empty"):
        LabelledImages(images, images, "")


def test_resize_labels_makes_no_new_classes() -> None:
    subject = synthetic_subject("s", 4, size=96, seed=0)
    resized = resize_labels(subject.labels, 64)
    assert resized.shape == (4, 64, 64)
    assert set(np.unique(resized)) == set(np.unique(subject.labels)) == {0, 1, 2}


def test_flip_moves_image_and_mask_together() -> None:
    flip_only = AugmentationConfig(
        horizontal_flip_p=1.0, vertical_flip_p=0.0, noise_p=0, sharpen_p=0, brightness_contrast_p=0
    )
    image = np.arange(64, dtype=np.uint8).reshape(8, 8)
    mask = (image % 3).astype(np.uint8)
    out = build_augmentation(flip_only, seed=0)(image=image, mask=mask)
    np.testing.assert_array_equal(out["image"], image[:, ::-1])
    np.testing.assert_array_equal(out["mask"], mask[:, ::-1])


def test_full_augmentation_keeps_labels_aligned() -> None:
    image = np.full((64, 64), 20, dtype=np.uint8)
    mask = np.zeros((64, 64), dtype=np.uint8)
    image[4:20, 8:20] = 230  # a bright vessel-sized block in the upper left
    mask[4:20, 8:20] = 1
    augment = build_augmentation(AugmentationConfig(), seed=7)
    corners = set()
    for _ in range(24):
        out = augment(image=image, mask=mask)
        inside = out["mask"] == 1
        assert set(np.unique(out["mask"])) == {0, 1} and inside.sum() == 16 * 12
        # The mask still covers the bright block: were it flipped alone, it would sit on
        # the dark background.
        assert out["image"][inside].mean() - out["image"][~inside].mean() > 100
        rows, cols = np.nonzero(inside)
        corners.add((rows.mean() > 32, cols.mean() > 32))
    assert len(corners) == 4  # both flips happened, in every combination


def test_augmentation_is_reproducible_with_a_seed() -> None:
    subject = synthetic_subject("s", 6, size=32, seed=1)
    runs = []
    for _ in range(2):
        dataset = SegmentationDataset([subject], 32, build_augmentation(AugmentationConfig(), 3))
        runs.append(np.stack([dataset[i][0].numpy() for i in range(len(dataset))]))
    np.testing.assert_array_equal(runs[0], runs[1])
    stronger = replace(AugmentationConfig(), noise_p=1.0)
    other = SegmentationDataset([subject], 32, build_augmentation(stronger, 3))
    assert not np.array_equal(runs[0][0], other[0][0].numpy())


def test_dataset_resizes_and_records_subjects() -> None:
    sets = [synthetic_subject("b", 3, size=48, seed=2), synthetic_subject("a", 2, size=80, seed=3)]
    dataset = SegmentationDataset(sets, 32)
    image, labels = dataset[4]
    assert len(dataset) == 5 and dataset.subjects == ("a", "b")
    assert image.shape == (1, 32, 32) and labels.shape == (32, 32)
    with pytest.raises(ResusError, match="no images"):
        SegmentationDataset([], 32)
