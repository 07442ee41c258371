"""The `aug` regime's elastic warp: labels follow the image, no class is invented, the warp
is the same share of the image at any network size, and it is seeded and can be off."""

from dataclasses import replace

import numpy as np
from augment_configs import QUIET

from resus.segmentation.augment import build_augmentation
from sim.labels import VEIN

ELASTIC_ONLY = replace(QUIET, elastic_p=1.0)


def disc(size: int) -> tuple[np.ndarray, np.ndarray]:
    """A bright disc of radius size / 4 (label vein) on a grey ground."""
    rows, cols = np.indices((size, size))
    inside = (rows - size / 2) ** 2 + (cols - size / 2) ** 2 < (size / 4) ** 2
    return np.where(inside, 220, 60).astype(np.uint8), np.where(inside, VEIN, 0).astype(np.uint8)


def overlap_with_disc(size: int, runs: int = 12) -> float:
    """Mean IoU of the warped disc's labels with the unwarped disc."""
    image, mask = disc(size)
    augment = build_augmentation(ELASTIC_ONLY, seed=5, image_size=size)
    scores = []
    for _ in range(runs):
        labels = augment(image=image, mask=mask)["mask"] > 0
        scores.append((labels & (mask > 0)).sum() / (labels | (mask > 0)).sum())
    return float(np.mean(scores))


def test_the_warp_moves_image_and_labels_together_and_invents_no_class():
    image, mask = disc(128)
    augment = build_augmentation(ELASTIC_ONLY, seed=1, image_size=128)
    for _ in range(5):
        out = augment(image=image, mask=mask)
        warped, labels = out["image"], out["mask"]
        assert set(np.unique(labels)) == {0, VEIN}
        assert not np.array_equal(labels, mask)  # the outline moved
        assert (warped[labels == VEIN] > 140).mean() > 0.95  # the bright disc under its label
        assert (warped[labels == 0] < 140).mean() > 0.95
        assert (warped > 0).all()  # edges reflected, no black wedges


def test_the_warp_is_the_same_share_of_the_image_at_any_size():
    small, large = overlap_with_disc(64), overlap_with_disc(128)
    assert 0.75 < large < 0.95  # outlines bend, the disc stays a disc
    assert abs(small - large) < 0.05


def test_the_warp_is_seeded_and_off_by_default():
    image, mask = disc(64)
    runs = [
        build_augmentation(ELASTIC_ONLY, seed=3, image_size=64)(image=image, mask=mask)["mask"]
        for _ in range(2)
    ]
    np.testing.assert_array_equal(*runs)
    off = replace(ELASTIC_ONLY, elastic_p=0.0)
    out = build_augmentation(off, seed=3, image_size=64)(image=image, mask=mask)
    np.testing.assert_array_equal(out["mask"], mask)
    np.testing.assert_array_equal(out["image"], image)
