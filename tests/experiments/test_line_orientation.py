"""Bright-line orientation against patterns whose lines run a known way."""

from __future__ import annotations

import math

import numpy as np
import pytest
from scipy import ndimage

from resus.experiments.realism import ImageSet, measure
from resus.experiments.realism.line_orientation import (
    ANGLE_BIN_DEGREES,
    bright_line_normals,
    line_angle_counts,
    share_between,
)

SIZE = 256


def stripes(angle_degrees: float, period: float = 16.0) -> np.ndarray:
    """Bright lines every `period` px whose normal lies `angle_degrees` from the beam (the
    rows' direction, down the image), on a grey floor."""
    rows, cols = np.mgrid[:SIZE, :SIZE].astype(float)
    angle = math.radians(angle_degrees)
    along_normal = rows * math.cos(angle) + cols * math.sin(angle)
    offset = np.mod(along_normal, period) - period / 2
    return (60 + 120 * np.exp(-(offset**2) / 2)).astype(np.uint8)


@pytest.mark.parametrize("angle", [0.0, 20.0, 45.0, 70.0, 90.0])
def test_the_normals_of_straight_lines_lie_at_their_angle(angle: float) -> None:
    normals = bright_line_normals(stripes(angle), np.ones((SIZE, SIZE), bool))
    assert normals.size > 1000
    assert np.degrees(np.median(normals)) == pytest.approx(angle, abs=1.5)


def test_lines_of_every_direction_spread_evenly() -> None:
    """Smoothed white noise has no preferred direction: each bin holds its width's share."""
    noise = ndimage.gaussian_filter(np.random.default_rng(3).normal(size=(SIZE, SIZE)), 2.0)
    counts = line_angle_counts(bright_line_normals(noise, np.ones((SIZE, SIZE), bool)))
    shares = counts / counts.sum()
    assert len(shares) == round(90 / ANGLE_BIN_DEGREES)
    assert share_between(tuple(shares), 0, 45) == pytest.approx(0.5, abs=0.04)
    assert share_between(tuple(shares), 0, 30) == pytest.approx(1 / 3, abs=0.04)


def test_only_usable_pixels_away_from_the_edge_count() -> None:
    image = stripes(0.0)
    usable = np.zeros((SIZE, SIZE), bool)
    assert bright_line_normals(image, usable).size == 0
    usable[:, : SIZE // 2] = True
    half = bright_line_normals(image, usable).size
    assert 0 < half < bright_line_normals(image, np.ones((SIZE, SIZE), bool)).size
    flat = np.full((SIZE, SIZE), 80, np.uint8)
    assert bright_line_normals(flat, np.ones((SIZE, SIZE), bool)).size == 0


def test_realism_counts_the_tissue_lines_and_leaves_out_a_vessel_rim() -> None:
    """Through `measure`: streaks across the beam all fall within 10 degrees, steep lines all
    beyond 45. A vessel's bright rim, whose sides run along the beam, would add steep lines
    (seen by `bright_line_normals` with only the lumen left out); the clearance keeps it out."""
    vessel = np.zeros((SIZE, SIZE), bool)
    vessel[100:140, 100:140] = True
    rows, cols = np.mgrid[:SIZE, :SIZE]
    rim = (np.abs(rows - 119.5) < 22) & (np.abs(cols - 119.5) < 22) & ~vessel  # 2 px wide
    for angle, low, high in ((0.0, 0, 10), (80.0, 45, 90)):
        image = stripes(angle)
        image[60:180, 60:180] = 60  # plain tissue around the vessel
        image[rim] = 250
        image[vessel] = 10
        stats = measure(ImageSet("stripes", (image,), (vessel,), ("stripes.png",)))
        assert stats.line_angle_shares is not None
        assert share_between(stats.line_angle_shares, low, high) > 0.97
        if angle == 0.0:
            assert share_between(stats.line_angle_shares, 45, 90) == 0.0
            counts = line_angle_counts(bright_line_normals(image, ~vessel))
            assert share_between(tuple(counts / counts.sum()), 45, 90) > 0.01
