"""The vessel cross-sections of an image: shape, placement, walls, lumens, what lies round them.

Vessel shapes. Each connected vessel region (8-connected) of at least
`RealismSettings.min_vessel_area` of its image's imaged area is one vessel cross-section. Its
aspect is sqrt(l1 / l2) of its second moments' eigenvalues, each pixel a unit square (so a
uniform ellipse of semi-axes a >= b gives a / b, and a one-pixel line stays finite); its area
and its centre's depth are shares of the imaged area and height, so that 256 px frames and
512 px exports compare alike. A vein pressed flat shows as a region over `ELONGATED_ASPECT`
times longer than wide: common in simulation at a heavy probe force, rare in real scans made
with the light touch of a vascular examination. How far a cross-section is from an ellipse:
the overlap (IoU) of each region that the picture does not cut with the uniform ellipse of its
centroid and second moments, 1 for an exact ellipse (up to its pixels' edges); a vein, whose
thin wall takes the shape its neighbours press into it, is a rounded polygon more often.

Vessel placement. Where the sonographer puts the vessels across the picture: each image's
vessel centroid (the mean column of the pixels of its counted regions, a share of the imaged
width) and its distance from the middle, 0 to 0.5. A simulated probe centred over the vessels
shows them in the middle and little of what lies beside them; real images, aimed at a nerve
or a branch, often show them to one side. An image whose centroid lies `OFF_SIDE_OFFSET` or
more from the middle shows its vessels in an outer quarter. And how many vessel
regions the picture cuts: those touching the imaged area's side or bottom (the face is not an
edge a vessel can cross). Vessels wide apart in a narrow field are cut more often.

Vessel walls. A wall echoes brightly where the beam meets it square (above and below the
lumen: a specular reflection) and hardly at all beside it, where the beam grazes it; a wall
drawn as a bright ring all round is a cue no real image offers. For each vessel region, the
mean grey of a band just outside the lumen (`RealismSettings.wall_band` of the imaged height
wide, other vessels left out) over that of the ring two to four band widths out, beside the
lumen (where the wall's normal, the direction from the nearest lumen pixel, lies within 30
degrees of the rows) and above and below it (within 30 degrees of the columns, the beam): 1
where the wall is no brighter than the tissue beyond it.

The tissue round a vessel. What lies around a lumen, past its wall, decides what a dark
region looks like to a reader: real femoral lumens lie in brighter tissue than the fat beside
it (the connective tissue of the vessels' sheath), a simulator that puts them straight into the
fat draws a dark moat round a thin bright ring. For each region, the mean grey of the ring one
to four wall bands out (other vessels left out) beside the lumen, above it and below it (the
wall figures' sectors), over the mean grey of the tissue in those same pixels' rows (vessels
left out, the whole width of the image): 1 where the vessel's surroundings are as bright as
the rest of their depth, whatever the depth's own brightness.

Vessel lumens. The pooled lumen/tissue ratio weighs every lumen pixel against all the tissue
of the set, at every depth; what a reader (or a network) sees is each lumen against the tissue
around it. So each vessel region also gets its lumen contrast: the mean grey of its interior
(more than one wall band inside its edge, clear of the wall's blur) over that of the same ring
two to four band widths out, all round. Real lumens are seldom black, and seldom nearly as
bright as their surroundings; a simulator that fills them with too much haze teaches a network
to call grey tissue vessel. And a lumen's interior is about as bright in its middle as towards
its sides: each region's middle third of the interior's columns over its outer two thirds (no
figure for a region cut by the image's side, whose middle is not the lumen's). Haze taken from
the tissue beside a lumen alone leaves a dark slit down the middle of a lumen wider than that
reach, a cue no real image offers.

Dark tissue. What a network must learn not to call vessel: tissue as dark as the lumens, at
their depth. Each image that shows a vessel region is smoothed with a Gaussian whose standard
deviation is one wall band (a region's darkness is judged over an area, not a speckle grain);
the lumens' level is the median smoothed grey of the regions' interiors (more than a band
inside the edge), and the figure is the share of the tissue in the rows the regions span, more
than four bands from every vessel (past the lumen contrast's ring), whose smoothed grey is at
most that level. Real groins show muscle bellies and fat lobules as dark as the vessels beside
them; a simulator whose vessels are the darkest thing at their depth teaches a network that
the darkest blob there is the vessel.
"""

from __future__ import annotations

import math
from collections.abc import Sequence
from typing import NamedTuple

import numpy as np

WALL_SECTOR = math.pi / 6
"""Largest angle of a wall's normal from the rows (beside a lumen) or from the columns
(above or below it) in the wall figures."""
MIN_CONTRAST_PIXELS = 10
"""Fewest pixels a lumen's interior, a wall band (in a sector) or its reference ring needs to
give a figure."""
ELONGATED_ASPECT = 3.0
"""A vessel region longer than this many times its width counts as flattened."""
OFF_SIDE_OFFSET = 0.25
"""An image's vessel centroid this far (a share of the imaged width) or further from the
middle lies in an outer quarter: the vessels shown to one side."""
PIXEL_SECOND_MOMENT = 1.0 / 12.0
"""Second moment of a unit square about its centre along either axis: what each pixel adds to
a region's covariance when the region is the union of its pixels' squares."""


def vessel_clearance(vessel: np.ndarray) -> np.ndarray:
    """Each pixel's distance (px) from the nearest vessel pixel; inf in an image without."""
    from scipy import ndimage

    if not vessel.any():
        return np.full(vessel.shape, np.inf)
    return ndimage.distance_transform_edt(~vessel)


Region = tuple[tuple[slice, slice], np.ndarray, np.ndarray]
"""A vessel region: its bounding box, and its pixels' rows and columns within it."""


def find_regions(vessel: np.ndarray, min_area: float) -> list[Region]:
    """(bounding box, rows, columns within it) of each 8-connected region of the imaged
    area's vessel mask `vessel` that covers at least `min_area` of it."""
    from scipy import ndimage

    if not vessel.any():
        return []
    labelled, _ = ndimage.label(vessel, structure=np.ones((3, 3), bool))
    found = []
    for label, region in enumerate(ndimage.find_objects(labelled), start=1):
        assert region is not None  # the labels run from 1 without gaps
        rows, cols = np.nonzero(labelled[region] == label)
        if rows.size >= max(1.0, min_area * vessel.size):
            found.append((region, rows, cols))
    return found


def vessel_regions(vessel: np.ndarray, min_area: float) -> list[tuple[float, float, float]]:
    """(aspect, area share, centre depth share) of each 8-connected region of the imaged
    area's vessel mask `vessel` that covers at least `min_area` of it (module docstring)."""
    return [region_shape(vessel, region) for region in find_regions(vessel, min_area)]


def centroid_offset(vessel: np.ndarray, regions: Sequence[Region]) -> float:
    """Distance of the mean column of `regions`' pixels from the middle of the imaged area
    `vessel`, as a share of its width (module docstring, "Vessel placement")."""
    columns = np.concatenate([box[1].start + cols for box, _, cols in regions])
    return abs((columns.mean() + 0.5) / vessel.shape[1] - 0.5)  # pixel centres at col + 0.5


def is_cut(shape: tuple[int, ...], region: Region) -> bool:
    """Whether `region` of an imaged area of `shape` touches its side or bottom."""
    rows, columns = region[0]
    return columns.start == 0 or columns.stop == shape[1] or rows.stop == shape[0]


def region_moments(region: Region) -> tuple[np.ndarray, np.ndarray]:
    """(its pixels' (rows, cols) within the box, their second moments): each pixel a unit
    square, so the covariance of their centres plus a square's own `PIXEL_SECOND_MOMENT`."""
    _, rows, cols = region
    points = np.stack([rows, cols]).astype(np.float64)
    return points, np.cov(points, bias=True) + PIXEL_SECOND_MOMENT * np.eye(2)


def region_shape(vessel: np.ndarray, region: Region) -> tuple[float, float, float]:
    """(aspect, area share, centre depth share) of one region of `vessel`."""
    box, rows, _ = region
    _, covariance = region_moments(region)
    smallest, largest = np.linalg.eigvalsh(covariance)
    centre_row = box[0].start + rows.mean() + 0.5  # pixel centres lie at row + 0.5
    return math.sqrt(largest / smallest), rows.size / vessel.size, centre_row / vessel.shape[0]


def ellipse_fit(region: Region) -> float:
    """IoU of `region` with the uniform ellipse of its centroid and second moments (each pixel
    a unit square, as for the aspect: a uniform ellipse's second moment along an axis is a
    quarter of its semi-axis squared), counted over pixel centres: 1 for an exact ellipse up
    to its pixels' edges, less the more its outline bends in and out of one."""
    _, rows, cols = region
    points, covariance = region_moments(region)
    centre = points.mean(axis=1)
    reach = 2.0 * math.sqrt(float(np.linalg.eigvalsh(covariance)[-1]))  # its semi-major axis
    low = np.floor(np.minimum(points.min(axis=1), centre - reach)).astype(int)
    high = np.ceil(np.maximum(points.max(axis=1), centre + reach)).astype(int) + 1
    grid_rows, grid_cols = np.mgrid[low[0] : high[0], low[1] : high[1]]
    offsets = np.stack([grid_rows - centre[0], grid_cols - centre[1]], axis=-1)
    inside = np.einsum("...i,ij,...j->...", offsets, np.linalg.inv(covariance), offsets) <= 4.0
    member = np.zeros(inside.shape, bool)
    member[rows - low[0], cols - low[1]] = True
    return float((inside & member).sum() / (inside | member).sum())


class VesselContrast(NamedTuple):
    """One vessel region's contrasts (module docstring), each None where too few pixels
    (`MIN_CONTRAST_PIXELS`) give it."""

    lumen: float | None
    """Interior grey over the tissue's around the lumen."""
    beside: float | None
    """Wall grey over the tissue's beyond it, beside the lumen."""
    above_below: float | None
    """The same above and below the lumen."""
    lumen_middle: float | None
    """Interior grey in the middle third of the region's columns over the outer thirds'
    (None for a region that touches the image's side)."""
    round_beside: float | None
    """The ring 1-4 bands outside the lumen, beside it, over its rows' tissue."""
    round_above: float | None
    """The same above the lumen."""
    round_below: float | None
    """The same below the lumen."""


def vessel_contrasts(
    image: np.ndarray,
    vessel: np.ndarray,
    min_area: float,
    band: float,
    regions: list[Region] | None = None,
) -> list[VesselContrast]:
    """The lumen and wall contrasts of each vessel region of the imaged area `image` (module
    docstring): against the mean grey of the ring 2-4 `band`s of the imaged height outside the
    lumen (other vessels left out), the lumen's pixels more than a band inside its edge, and
    the wall's at most a band outside it, each wall pixel beside the lumen or above or below
    it by the direction from the nearest lumen pixel (the wall's normal), within `WALL_SECTOR`
    of the rows or of the columns; the interior's middle third of columns over its outer
    thirds; and the ring 1-4 bands out over its rows' tissue. `regions`: the regions of at
    least `min_area` (`_regions`), when they are already found."""
    if regions is None:
        regions = find_regions(vessel, min_area)
    if not regions:
        return []
    tissue = ~vessel
    row_tissue = (image * tissue).sum(axis=1) / np.maximum(tissue.sum(axis=1), 1)
    return [_region_contrasts(image, vessel, region, band, row_tissue) for region in regions]


def _region_contrasts(
    image: np.ndarray, vessel: np.ndarray, region: Region, band: float, row_tissue: np.ndarray
) -> VesselContrast:
    """The lumen and wall contrasts of one region of `vessel` (`vessel_contrasts`)."""
    from scipy import ndimage

    box, rows, cols = region
    width = max(1.0, band * vessel.shape[0])
    reach = math.ceil(4 * width) + 1
    top, left = max(0, box[0].start - reach), max(0, box[1].start - reach)
    window = (
        slice(top, min(vessel.shape[0], box[0].stop + reach)),
        slice(left, min(vessel.shape[1], box[1].stop + reach)),
    )
    lumen = np.zeros(vessel[window].shape, bool)
    lumen[rows + box[0].start - top, cols + box[1].start - left] = True
    distance, (nearest_row, nearest_col) = ndimage.distance_transform_edt(
        ~lumen, return_indices=True
    )
    outside = ~vessel[window]
    near = outside & (distance <= width)
    far = outside & (distance > 2 * width) & (distance <= 4 * width)
    interior = ndimage.distance_transform_edt(lumen) > width
    row, col = np.indices(lumen.shape)
    # the wall's normal, from the nearest lumen pixel: 0 beside the lumen, pi / 2 above or
    # below it (along the beam)
    angle = np.arctan2(np.abs(row - nearest_row), np.abs(col - nearest_col))
    grey = image[window].astype(np.float64)
    beside, above_below = angle <= WALL_SECTOR, angle >= math.pi / 2 - WALL_SECTOR
    above, below = above_below & (row < nearest_row), above_below & (row > nearest_row)
    ring = outside & (distance > width) & (distance <= 4 * width)
    rows_tissue = np.broadcast_to(row_tissue[window[0]][:, None], ring.shape)
    first, stop = box[1].start - left, box[1].stop - left
    third = (stop - first) / 3
    middle = (col >= first + third) & (col < stop - third)
    cut = box[1].start == 0 or box[1].stop == vessel.shape[1]
    sides = (beside, above, below)
    return VesselContrast(
        _mean_ratio(grey[interior], grey[far]),
        _mean_ratio(grey[near & beside], grey[far & beside]),
        _mean_ratio(grey[near & above_below], grey[far & above_below]),
        None if cut else _mean_ratio(grey[interior & middle], grey[interior & ~middle]),
        *(_mean_ratio(grey[ring & side], rows_tissue[ring & side]) for side in sides),
    )


def dark_tissue_share(
    image: np.ndarray,
    vessel: np.ndarray,
    min_area: float,
    band: float,
    regions: Sequence[Region] | None = None,
    clearance: np.ndarray | None = None,
) -> float | None:
    """Share of the imaged area `image`'s tissue in the rows that the regions of at least
    `min_area` of the mask `vessel` span, more than four `band`s of the imaged height from
    every vessel, whose grey smoothed over a band is at most the regions' interiors' median
    (module docstring, "Dark tissue"). None without regions, or with fewer than
    `MIN_CONTRAST_PIXELS` interior or tissue pixels. `regions` (`_regions`) and `clearance`
    (`vessel_clearance(vessel)`): when they are already found."""
    from scipy import ndimage

    if regions is None:
        regions = find_regions(vessel, min_area)
    if not regions:
        return None
    width = max(1.0, band * vessel.shape[0])
    lumens = np.zeros(vessel.shape, bool)
    for box, rows, cols in regions:
        lumens[rows + box[0].start, cols + box[1].start] = True
    interior = ndimage.distance_transform_edt(lumens) > width
    if clearance is None:
        clearance = vessel_clearance(vessel)
    top = min(box[0].start for box, _, _ in regions)
    bottom = max(box[0].stop for box, _, _ in regions)
    tissue = np.zeros(vessel.shape, bool)
    tissue[top:bottom] = clearance[top:bottom] > 4 * width
    if min(interior.sum(), tissue.sum()) < MIN_CONTRAST_PIXELS:
        return None
    smoothed = ndimage.gaussian_filter(image.astype(np.float64), width)
    return float((smoothed[tissue] <= np.median(smoothed[interior])).mean())


def _mean_ratio(part: np.ndarray, reference: np.ndarray) -> float | None:
    """`part`'s mean grey over `reference`'s; None when either has fewer than
    `MIN_CONTRAST_PIXELS` pixels or the reference is black."""
    enough = min(part.size, reference.size) >= MIN_CONTRAST_PIXELS and reference.mean() > 0
    return float(part.mean() / reference.mean()) if enough else None
