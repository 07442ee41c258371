"""Scanner zoom: a window of the frame enlarged to the whole frame, labels following it."""

from __future__ import annotations

from dataclasses import replace

import numpy as np

from resus.segmentation.presets import AugmentationConfig
from resus.segmentation.zoom import ScannerZoom

DOUBLE = replace(AugmentationConfig(), zoom_p=1.0, zoom_range=(2.0, 2.0), zoom_aspect=(1.0, 1.0))


def ramps(size: int = 64) -> tuple[np.ndarray, np.ndarray]:
    """Grey rising by 2 per column; labels 1 in the left half of the columns, 2 in the right."""
    columns = np.arange(size)
    image = np.tile((2 * columns).astype(np.uint8), (size, 1))
    mask = np.tile(np.where(columns < size // 2, 1, 2).astype(np.uint8), (size, 1))
    return image, mask


def test_a_double_zoom_halves_the_grey_slope_and_the_labels_follow_the_image():
    image, mask = ramps()
    zoom = ScannerZoom(DOUBLE, np.random.default_rng(0))
    for _ in range(20):
        out = zoom(image=image, mask=mask)
        zoomed, labels = out["image"].astype(float), out["mask"]
        assert zoomed.shape == labels.shape == image.shape
        slope = np.diff(zoomed[:, 4:-4], axis=1)
        assert abs(slope.mean() - 1.0) < 0.05  # 2 grey levels per column, spread over two
        assert (np.diff(zoomed, axis=0) == 0).all()  # rows stay alike
        # the grey level says which input column a pixel came from; its label must agree
        source_column = zoomed / 2
        far = np.abs(source_column - 31.5) > 1.0
        expected = np.where(source_column < 32, 1, 2)
        np.testing.assert_array_equal(labels[far], expected[far])


def test_zoom_can_be_off_and_stretches_the_window_within_its_aspect_range():
    image, mask = ramps()
    off = ScannerZoom(AugmentationConfig(), np.random.default_rng(1))
    out = off(image=image, mask=mask)
    assert out["image"] is image and out["mask"] is mask
    stretched = replace(DOUBLE, zoom_range=(1.0, 1.0), zoom_aspect=(0.5, 2.0))
    zoom = ScannerZoom(stretched, np.random.default_rng(2))
    slopes = [
        np.diff(zoom(image=image, mask=mask)["image"].astype(float), axis=1).mean()
        for _ in range(40)
    ]
    assert min(slopes) < 1.7 and max(slopes) == 2.0  # narrower windows: gentler slopes
