"""Arbitrary world planes: a longitudinal view along a vessel."""

from __future__ import annotations

import numpy as np
import pytest
from reslice_volumes import cylinder_volume, grid_for

from resus.errors import ResusError
from resus.reslicing.plane import ObliquePlane, reslice_plane
from resus.reslicing.sampling import SampledVolume


def test_longitudinal_plane_along_a_vessel_shows_a_band_of_its_diameter():
    shape, radius, spacing = (48, 48, 64), 6.0, 0.5e-3
    volume, labels, axis = cylinder_volume(shape, [0.4, 0.2, 1.0], radius)
    grid = grid_for(shape, spacing)
    centre = (np.array(shape) - 1) / 2
    start, end = grid.to_world(centre - 20 * axis), grid.to_world(centre + 20 * axis)
    depth = grid.directions.T @ np.array([1.0, 0.0, 0.0])
    plane = ObliquePlane.along_segment(start, end, depth, height=20e-3, spacing=0.25e-3)
    image, label, plane_to_world = reslice_plane(SampledVolume(volume, labels), grid, plane)
    rows, cols = plane.shape
    assert image.shape == label.shape == (rows, cols) == (80, 80)
    # every column crosses the vessel as a band 2 * radius wide, centred on the middle row
    widths = label.sum(axis=0) * plane.spacing
    np.testing.assert_allclose(widths, 2 * radius * spacing, atol=2 * plane.spacing)
    band_rows = np.nonzero(label[:, cols // 2])[0]
    assert abs(band_rows.mean() - (rows - 1) / 2) <= 1
    assert (image[rows // 2] == 200).all()  # on the axis
    edges = image[[0, -1]]  # far from the vessel: tissue, or zero where the plane leaves the volume
    assert np.isin(edges, [0, 80]).all() and (edges == 80).mean() > 0.5
    # the pose puts the image centre on the vessel axis and the columns along it
    middle = plane_to_world @ [(cols - 1) / 2, (rows - 1) / 2, 0, 1]
    np.testing.assert_allclose(middle[:3], grid.to_world(centre), atol=1e-12)
    axis_world = grid.to_world(centre + axis) - grid.to_world(centre)
    column = plane_to_world[:3, 0] / np.linalg.norm(plane_to_world[:3, 0])
    np.testing.assert_allclose(column, axis_world / np.linalg.norm(axis_world), atol=1e-12)
    assert np.isclose(np.linalg.norm(plane_to_world[:3, 1]), plane.spacing)


def test_plane_outside_the_volume_is_zero():
    volume, labels, _ = cylinder_volume((16, 16, 16), [0, 0, 1], 4)
    grid = grid_for((16, 16, 16))
    plane = ObliquePlane(
        centre=np.array([5.0, 5.0, 5.0]),
        col_direction=[1, 0, 0],
        row_direction=[0, 1, 0],
        width=0.01,
        height=0.01,
        spacing=1e-3,
    )
    image, label, _ = reslice_plane(SampledVolume(volume, labels), grid, plane)
    assert not image.any() and not label.any()


@pytest.mark.parametrize(
    ("change", "message"),
    [
        ({"row_direction": [2, 0, 0]}, "parallel"),
        ({"spacing": 0}, "spacing"),
        ({"col_direction": [0, 0, 0]}, "col_direction"),
    ],
)
def test_bad_planes_are_refused(change: dict, message: str) -> None:
    good = {"centre": np.zeros(3), "col_direction": [1, 0, 0], "row_direction": [0, 1, 0]}
    with pytest.raises(ResusError, match=message):
        ObliquePlane(**{**good, "width": 1, "height": 1, "spacing": 0.1, **change})
