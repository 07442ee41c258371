"""Spatial compounding: one displayed frame averaged from frames steered at several angles.

A linear array steers its beams electronically: at steering angle theta every scan line leaves
its element tilted by theta in the image plane. Compound presets fire 3-9 such frames, between
about -20 and +20 degrees, and average them after detection (scan-converted onto one grid),
which is why a modern vascular image looks smoother than a single frame: the speckle of frames
seen from different directions differs and averages down, a curved vessel wall is struck
nearer normal incidence by one of the angles and shows as a more continuous ring, and the
shadow or enhancement below a structure is cast along each direction and smears.

Here a steered frame is imaged on a sheared pixel lattice: line e, row r at the image's pixel
(e + r * tan(theta) * row height / column width, r), the beam along the sheared row step, so
attenuation, wall angles, shadows and reverberation follow the steered beam exactly. Each row
is one row height deeper (the path along the beam is longer by 1 / cos(theta), at most 6 % at
20 degrees; attenuation per row and the pulse's length in rows are taken as unsteered).
The frame is then resampled onto the image grid (linear between the two nearest lines) and
averaged in grey levels where it images the pixel (in contact, not air); pixels near the
image's sides are reached by fewer angles, as on a scanner.

The speckle of each steered frame is drawn independently (its own scatterer seed; the tissue,
its texture and the electronic noise's frame key are shared or keyed the same way): speckle
decorrelates as the steering changes by about the aperture's half-angle at the focus,
atan(1 / (2 F-number)), 10-18 degrees at F-numbers 1.5-3, so independence is exact for angle
steps that large and overstates the smoothing for smaller ones.
"""

from __future__ import annotations

import numba
import numpy as np


def steering_angles(frames: int, largest: float) -> np.ndarray:
    """The steering angles (rad) of `frames` frames evenly spread over [-largest, largest],
    the unsteered one last (the image's labels and air mask are its own)."""
    angles = np.linspace(-largest, largest, frames) if frames > 1 else np.zeros(1)
    return np.concatenate([angles[angles != 0.0], [0.0]])


@numba.njit(cache=True, parallel=True)
def accumulate_steered(
    lines: np.ndarray,
    material: np.ndarray,
    contact: np.ndarray,
    columns_per_row: float,
    total: np.ndarray,
    count: np.ndarray,
) -> None:
    """Add one steered frame's grey `lines` (lines, rows uint8; line e's row r at image column
    e + r * `columns_per_row`) to the image grid's `total` and `count` (cols, rows float32),
    linearly between the two lines either side of each pixel, where both image it (`contact`
    per line, `material` >= 0 per sample, column-major as `lines`)."""
    cols, rows = lines.shape
    for col in numba.prange(cols):
        for row in range(rows):
            position = col - row * columns_per_row
            if not 0.0 <= position <= cols - 1:
                continue  # no steered line reaches this pixel
            first = max(0, min(int(position), cols - 2))
            second = min(first + 1, cols - 1)
            weight = np.float32(position - first)
            if not (contact[first] and contact[second]):
                continue
            if material[first * rows + row] < 0 or material[second * rows + row] < 0:
                continue
            value = (np.float32(1.0) - weight) * np.float32(lines[first, row])
            value += weight * np.float32(lines[second, row])
            total[col, row] += value
            count[col, row] += np.float32(1.0)


@numba.njit(cache=True, parallel=True)
def compound_lines(
    total: np.ndarray,
    count: np.ndarray,
    material: np.ndarray,
    contact: np.ndarray,
    out: np.ndarray,
) -> None:
    """`out` (cols, rows uint8) = the mean grey `total / count`, rounded, where the unsteered
    frame images the pixel (`contact` per column, `material` >= 0), 0 elsewhere."""
    cols, rows = out.shape
    for col in numba.prange(cols):
        for row in range(rows):
            if not contact[col] or material[col * rows + row] < 0 or count[col, row] <= 0:
                out[col, row] = 0
            else:
                value = total[col, row] / count[col, row] + np.float32(0.5)
                out[col, row] = np.uint8(min(value, np.float32(255.0)))
