"""Which way the bright lines of tissue run: across the beam, along it, or every way.

Connective-tissue sheets (fasciae, the septa of fat, the perimysium of muscle) echo back to the
probe where the beam meets them square, so real B-mode shows them as streaks across the beam
and hardly where they turn along it. A simulator that draws them alike at every angle closes
them into a honeycomb of bright-edged cells, a texture no real groin shows. The figure here is
the distribution of the angle between the beam and each bright-line pixel's normal (0: a line
across the beam), in `ANGLE_BIN_DEGREES` bins; lines that run every way spread evenly over 0 to
90 degrees, streaks gather near 0, and a honeycomb shows as a tail of steep lines.

A pixel lies on a bright line where the image's Hessian, at a Gaussian scale tied to the
imaged height (`LINE_SCALE`, so that 256-row frames and 512-row exports compare alike), has a
strongly negative eigenvalue across the line and a small one along it (a ridge, not a blob or
a step), and that curvature is among the strongest `LINE_SHARE` of the usable pixels of its
image (so the figure does not depend on the gain). The line's normal is that eigenvalue's
eigenvector; the beam runs down the image's rows.
"""

from __future__ import annotations

import math

import numpy as np

LINE_SCALE = 0.006
"""Gaussian sigma of the Hessian as a share of the imaged height: 1.5 px of a 256-row frame,
about 0.25 mm of a 4 cm image, the half-width of a septum's echo."""
LINE_SHARE = 0.10
"""Share of each image's usable pixels, the strongest ridges, that count as bright lines."""
RIDGE_ELONGATION = 2.0
"""A ridge's curvature across it must exceed this many times its curvature along it."""
ANGLE_BIN_DEGREES = 5.0
"""Width of the bins of the lines' angles (their normal's to the beam)."""
EDGE_SIGMAS = 3.0
"""Pixels within this many sigmas of the image's edge see the edge in their Hessian."""


def line_scale_pixels(height: int) -> float:
    """The Hessian's Gaussian sigma (px) for an imaged area `height` rows tall."""
    return LINE_SCALE * height


def bright_line_normals(image: np.ndarray, usable: np.ndarray) -> np.ndarray:
    """Angles (rad, 0 to pi/2) between the beam and the normal of each bright-line pixel of
    the 2-D grey `image` that lies in the bool mask `usable` and clear of the image's edge."""
    from scipy import ndimage

    sigma = line_scale_pixels(image.shape[0])
    grey = image.astype(np.float64)
    along_along = ndimage.gaussian_filter(grey, sigma, order=(2, 0))  # down the beam, twice
    across_across = ndimage.gaussian_filter(grey, sigma, order=(0, 2))
    mixed = ndimage.gaussian_filter(grey, sigma, order=(1, 1))
    half_trace = 0.5 * (along_along + across_across)
    root = np.hypot(0.5 * (along_along - across_across), mixed)
    across_curvature = half_trace - root  # the more negative eigenvalue
    along_curvature = half_trace + root
    margin = math.ceil(EDGE_SIGMAS * sigma)
    inside = np.zeros_like(usable)
    inside[margin:-margin, margin:-margin] = usable[margin:-margin, margin:-margin]
    if not inside.any():
        return np.empty(0)
    strength = -across_curvature
    threshold = np.quantile(strength[inside], 1.0 - LINE_SHARE)
    lines = (
        inside
        & (strength > 0)
        & (strength >= threshold)
        & (strength > RIDGE_ELONGATION * np.abs(along_curvature))
    )
    # The eigenvector of the larger eigenvalue lies at this angle from the beam's axis; the
    # line's normal, the smaller eigenvalue's, is perpendicular to it.
    larger = 0.5 * np.arctan2(2.0 * mixed[lines], along_along[lines] - across_across[lines])
    normal = np.mod(larger + 0.5 * math.pi, math.pi)
    return np.minimum(normal, math.pi - normal)


def line_angle_counts(angles: np.ndarray) -> np.ndarray:
    """Bright-line pixels per `ANGLE_BIN_DEGREES` bin of their normal's angle to the beam
    (0: a line across the beam), from 0 to 90 degrees."""
    edges = np.arange(0.0, 90.0 + ANGLE_BIN_DEGREES, ANGLE_BIN_DEGREES)
    return np.histogram(np.degrees(angles), bins=edges)[0]


def share_between(shares: tuple[float, ...], low: float, high: float) -> float:
    """Share of bright-line pixels whose normal lies `low` to `high` degrees from the beam,
    from the per-bin `shares` (bin edges on multiples of `ANGLE_BIN_DEGREES`)."""
    first, last = round(low / ANGLE_BIN_DEGREES), round(high / ANGLE_BIN_DEGREES)
    return float(sum(shares[first:last]))
