"""The linear probe's image-to-probe calibration follows design.md's conventions."""

import numpy as np
import pytest

from sim.transforms import is_rigid
from sim.ultrasound.probe import LinearProbe


def test_pixel_centres_span_the_field_of_view() -> None:
    probe = LinearProbe(width=0.038, depth=0.05, cols=256, rows=200)
    points = probe.pixel_points()
    assert points.shape == (200, 256, 3)
    # The outermost pixel centres are half a pixel inside the array's edges.
    assert points[0, 0, 0] == pytest.approx(-0.019 + probe.pixel_width / 2)
    assert points[0, -1, 0] == pytest.approx(0.019 - probe.pixel_width / 2)
    assert points[0, 0, 2] == pytest.approx(probe.pixel_height / 2)
    assert points[-1, 0, 2] == pytest.approx(0.05 - probe.pixel_height / 2)
    np.testing.assert_allclose(points[..., 1], 0.0)


def test_calibration_is_a_scaled_proper_rotation() -> None:
    probe = LinearProbe()
    matrix = probe.image_to_probe()
    linear = matrix[:3, :3] / np.linalg.norm(matrix[:3, :3], axis=0)
    pose = np.eye(4)
    pose[:3, :3] = linear
    assert is_rigid(pose)


def test_rejects_nonsense_geometry() -> None:
    with pytest.raises(ValueError, match="width"):
        LinearProbe(width=0.0)
    with pytest.raises(ValueError, match="pixels"):
        LinearProbe(cols=1)
