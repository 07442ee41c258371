"""Export framing: the frame shrunk into a black canvas, labels following it, marks only in
the image (never in the labels)."""

from __future__ import annotations

from dataclasses import replace

import numpy as np
import pytest
from augment_configs import QUIET

from resus.segmentation.augment import build_augmentation
from resus.segmentation.framing import ExportFraming
from resus.segmentation.presets import AugmentationConfig

ALWAYS = replace(AugmentationConfig(), framing_p=1.0, framing_marks_p=0.0)


def block_frame(size: int = 64) -> tuple[np.ndarray, np.ndarray]:
    """Grey tissue filling the frame with a bright labelled block."""
    image = np.full((size, size), 60, np.uint8)
    mask = np.zeros((size, size), np.uint8)
    image[20:36, 24:44] = 220
    mask[20:36, 24:44] = 2
    return image, mask


def test_the_frame_shrinks_into_a_black_canvas_and_its_labels_follow():
    image, mask = block_frame()
    framing = ExportFraming(ALWAYS, np.random.default_rng(0))
    shapes = set()
    for _ in range(30):
        out = framing(image=image, mask=mask)
        framed, labels = out["image"], out["mask"]
        assert framed.shape == labels.shape == image.shape
        rows, cols = np.nonzero(framed)
        height, width = np.ptp(rows) + 1, np.ptp(cols) + 1
        assert 0.6 * 64 - 1 <= height <= 64 and 0.8 * 64 - 1 <= width <= 64
        shapes.add((height, width))
        tissue = framed[rows.min() : rows.max() + 1, cols.min() : cols.max() + 1]
        assert (tissue > 0).all()  # one rectangle of image, the rest black
        assert set(np.unique(labels)) == {0, 2}
        assert np.mean(framed[labels == 2] > 150) > 0.8  # edges blend (area vs nearest)
        assert (labels[framed == 0] == 0).all()
        block = labels == 2
        assert block.sum() == pytest.approx(16 * 20 * height * width / 64**2, rel=0.25)
    assert len(shapes) > 10  # the aspect ratio changes


def test_marks_are_drawn_in_the_image_only_and_framing_can_be_off():
    image, mask = block_frame()
    with_marks = replace(ALWAYS, framing_marks_p=1.0)
    drew = 0
    for seed in range(20):  # the same draws up to the marks, which are drawn on top
        a = ExportFraming(with_marks, np.random.default_rng(seed))(image=image, mask=mask)
        b = ExportFraming(ALWAYS, np.random.default_rng(seed))(image=image, mask=mask)
        np.testing.assert_array_equal(a["mask"], b["mask"])
        drew += int((a["image"] != b["image"]).any())
    assert drew == 20
    off = ExportFraming(AugmentationConfig(), np.random.default_rng(2))
    out = off(image=image, mask=mask)
    assert out["image"] is image and out["mask"] is mask


def test_framing_is_off_in_the_default_aug_regime_and_seeded_when_on():
    image, mask = block_frame()
    default = build_augmentation(QUIET, seed=0)
    np.testing.assert_array_equal(default(image=image, mask=mask)["image"], image)
    runs = [build_augmentation(ALWAYS, seed=4)(image=image, mask=mask)["image"] for _ in range(2)]
    np.testing.assert_array_equal(runs[0], runs[1])
