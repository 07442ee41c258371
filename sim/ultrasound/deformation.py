"""The tissue a pressing probe images: one frame's deformation, applied to its pixel points.

The phantom stays rigid; a deformed frame is imaged by mapping each pixel centre back to the
undeformed tissue point that moved there and querying the phantom (labels, materials,
scatterers) at that point, so images and labels in the deformed world are exact samples of
the deformed geometry. The map is the inverse of two forward deformations, applied in turn:

1. **Each vessel's cross-section** (`sim.phantom.mechanics` gives the sizes). Near the image,
   a vessel is taken as straight: the line through the centreline point nearest the image,
   along its tangent. Across that line, a point at distance rho in direction theta of the
   deformed cross-section came from the same direction; inside the deformed edge (an ellipse
   of semi-axes `minor` along the beam and `major` across it, in units of the round radius r,
   bent in and out by a vein's harmonics), from `r * nu`, with nu the point's distance over
   the edge's in its direction; outside, from distances stretched linearly so that the map is
   the identity from `OUTER_RADII * r` on (or short of a neighbouring vessel, so one vessel's
   change never bends another), and beyond the vessel's ends (where the vessel it joins takes
   over). A vein's harmonics (`mechanics.vein_shape_harmonics`) measure their angles round the
   axis from the phantom's up, so they hold their place in the body whatever the probe's
   tilt. The vessel's label region is therefore exactly that shape in any plane across the
   line, and the map is one to one and continuous there.
2. **Bulk compression** under the face: the skin follows the face across its width, each
   image column indented by the face's penetration into the undeformed body at its element,
   and the tissue below shifts along the beam by an amount that decays with depth
   (`mechanics.bulk_row_shifts`). A flat face pressed on a curved skin (the thigh's) thus
   images the skin flat, as a sonographer's pressed probe does: where the skin curves away
   below the face's edges it is drawn up to the face (a negative indentation: the tissue
   pressed aside at the middle bulges up beside it), by at most the face's deepest
   penetration, so a face held above the skin still images its gel gap. A vessel is not squashed
   by it: the cross-section moves rigidly with the tissue at its centre (the shift blends
   into the bulk one over the same outer ring), so its shape is its own law's alone (arteries
   stay round, a vein's minor axis is what its law says).

The load of a frame is the measured contact force along the probe axis (the Sweep's wrench)
and the frame's time (the cardiac and respiratory phase), so the recorded sweep explains each
frame's deformation.
"""

from __future__ import annotations

import itertools
import math
from dataclasses import dataclass

import numba
import numpy as np

from sim.phantom import Phantom
from sim.phantom.mechanics import (
    PASCAL_PER_MMHG,
    VEIN_HARMONICS,
    TissueMechanics,
    bulk_row_shifts,
    face_stress_fraction,
    tissue_shift,
    vein_shape_harmonics,
)
from sim.phantom.spec import ARTERY
from sim.ultrasound.probe import LinearProbe

INDENTATION_LEVELS = 9
"""Indentations at which a frame's compression is inverted exactly (`column_row_shifts`)."""
OUTER_RADII = 3.0
"""Beyond this many round radii from a vessel's axis, its cross-section change moves nothing."""
NEIGHBOUR_REACH = 1.1
"""A neighbouring vessel is given this many of its radii (its pulse's room) when a vessel's
ring is fitted between them."""
RING_MARGIN = 3.0e-4
"""Tissue left between a vessel's ring and a neighbour (m)."""
RING_ROOM = 1.15
"""A ring's outer radius is at least this many times the vessel's largest semi-axis."""
MAP_WIDTH = 26
"""A cross-section map row: centre c (3), axis t (3), beam direction b (3), n = t x b (3),
round radius, deformed semi-axes along b and along n, outer radius, the stretch of the axis
the vessel spans, from c, and how far the bulk compression moved the centre along the beam
(all metres); then the edge's bend, (cos, sin) coefficients of harmonics 2, 3 and 4 of the
angle from b towards n (relative to the ellipse's radius), and the sum of their amplitudes (0:
an unbent edge, which the kernels skip)."""


@dataclass(frozen=True)
class TissueLoad:
    """What deforms the tissue in one frame: the probe's contact force and the time."""

    force: float
    """Contact force along the probe axis (N); negative values count as no contact."""
    time: float
    """The frame's time (s): the cardiac and respiratory phase."""


@dataclass(frozen=True)
class VesselShape:
    """One vessel's cross-section in one frame, as the deformation set it."""

    name: str
    centre: np.ndarray
    """Undeformed centre (phantom frame, m) of the cross-section nearest the image."""
    radius: float
    """Round (undeformed, diastolic) radius there (m)."""
    minor: float
    """Semi-axis along the beam over the round radius."""
    major: float
    """Semi-axis across the beam over the round radius."""
    stress_mmhg: float
    """The probe's stress at the centre (mmHg)."""


@dataclass(frozen=True)
class FrameDeformation:
    """The inverse map of one frame: a shift along the beam per image row, then the vessels'
    cross-section maps."""

    row_shift: np.ndarray
    """(cols, rows) how far (m) along the beam, away from the face, the tissue seen at each
    pixel moved: it lay that much nearer the face before the probe pressed (farther, where
    negative: drawn up to the face)."""
    column_indentation: np.ndarray
    """(cols,) each column's indentation (m): the face's penetration into the undeformed body
    at its element, negative where the skin there was drawn up to the face."""
    maps: np.ndarray
    """(M, MAP_WIDTH) cross-section maps, applied in order."""
    vessels: tuple[VesselShape, ...]
    indentation: float
    """Penetration of the face into the undeformed body (m)."""


class ProbeDeformation:
    """Per-frame deformations of `phantom` (whose spec has `mechanics`) under `probe`."""

    def __init__(self, phantom: Phantom, probe: LinearProbe) -> None:
        mechanics = phantom.spec.mechanics
        if mechanics is None:
            raise ValueError(f"phantom {phantom.spec.name!r} has no mechanics: it is rigid")
        self.mechanics: TissueMechanics = mechanics
        self.phantom = phantom
        self.probe = probe
        self._names = [vessel.name for vessel in phantom.spec.vessels]
        self._arteries = [vessel.label == ARTERY for vessel in phantom.spec.vessels]
        self._walls = [vessel.wall_thickness for vessel in phantom.spec.vessels]
        self._harmonics = [
            vein_shape_harmonics(
                0.0 if artery else mechanics.vein_irregularity,
                phantom.spec.seed,
                phantom.spec.subject,
                index,
            )
            for index, artery in enumerate(self._arteries)
        ]
        """Per vessel, its edge's harmonics (amplitude, phase); none bend an artery's."""
        self._bends = [float(harmonics[:, 0].sum()) for harmonics in self._harmonics]
        """Per vessel, the most its edge bends out over the ellipse's radius (0: unbent)."""
        centrelines, radii = phantom.centrelines(), phantom.centreline_radii()
        self._nodes = np.concatenate([centrelines[name] for name in self._names])
        self._radii = np.concatenate([radii[name] for name in self._names])
        ends = np.cumsum([0] + [len(centrelines[name]) for name in self._names])
        self._slices = [slice(start, stop) for start, stop in itertools.pairwise(ends)]
        self._depths = (np.arange(probe.rows) + 0.5) * probe.pixel_height
        self._face_area = probe.width * probe.face_thickness
        self._face_x = np.linspace(-probe.width / 2, probe.width / 2, 9)
        """Where `indentation` measures along the face's centre line."""
        self._element_x = probe.column_x()
        """Each image column's element, across the face (m)."""

    def indentation(self, probe_to_phantom: np.ndarray) -> float:
        """Mean penetration (m) of the face's centre line into the undeformed body, measured
        along the phantom's z (0 where a part of the face is not in contact)."""
        elements = probe_to_phantom[:3, 0:1] * self._face_x + probe_to_phantom[:3, 3:4]
        penetration = self.phantom.skin_height(elements[0], elements[1]) - elements[2]
        penetration[~(penetration > 0.0)] = 0.0  # off the body (NaN) or above the skin
        return float(penetration.mean())

    def column_indentation(self, probe_to_phantom: np.ndarray) -> np.ndarray:
        """(cols,) how far (m) the skin below each column's element follows the face in:
        the face's penetration into the undeformed body there, measured along the phantom's
        z; where the skin lies below the face, minus the gap, down to minus the face's
        deepest penetration (the skin drawn up that far at most), 0 off the body."""
        elements = probe_to_phantom[:3, 0:1] * self._element_x + probe_to_phantom[:3, 3:4]
        penetration = self.phantom.skin_height(elements[0], elements[1]) - elements[2]
        penetration[np.isnan(penetration)] = 0.0
        deepest = max(float(penetration.max()), 0.0)
        return np.maximum(penetration, -deepest)

    def frame(self, probe_to_phantom: np.ndarray, load: TissueLoad) -> FrameDeformation:
        """The deformation of the frame taken at `probe_to_phantom` under `load`."""
        indentation = self.indentation(probe_to_phantom)
        length = self.mechanics.compression_length
        columns = self.column_indentation(probe_to_phantom)
        row_shift = column_row_shifts(self._depths, columns, length)
        rotation, origin = probe_to_phantom[:3, :3], probe_to_phantom[:3, 3]
        beam = rotation[:, 2]
        local = (self._nodes - origin) @ rotation  # probe frame: x lateral, y elevation, z depth
        outside_x = np.clip(np.abs(local[:, 0]) - self.probe.width / 2, 0.0, None)
        outside_z = np.clip(-local[:, 2], 0.0, None) + np.clip(
            local[:, 2] - self.probe.depth, 0.0, None
        )
        distance = np.sqrt(local[:, 1] ** 2 + outside_x**2 + outside_z**2)
        crossings = [
            (index, crossing)
            for index in range(len(self._slices))
            if (crossing := self._crossing(index, local, distance)) is not None
        ]
        if not crossings:
            return FrameDeformation(row_shift, columns, np.zeros((0, MAP_WIDTH)), (), indentation)
        centres = np.array([c.centre for _, c in crossings])
        x, y, z = ((centres - origin) @ rotation).T
        sunk = np.interp(x, self._element_x, columns)  # the indentation above each centre
        centre_shifts = np.array(
            [tissue_shift(d + s, s, length) for d, s in zip(z, sunk, strict=True)]
        )
        pressure_mmhg = max(0.0, load.force) / self._face_area / PASCAL_PER_MMHG
        stresses = pressure_mmhg * face_stress_fraction(
            x, y, np.maximum(z, 1e-4), self.probe.width, self.probe.face_thickness
        )
        in_image = np.abs(y) <= np.array([c.radius for _, c in crossings])
        maps, shapes = [], []
        for m, ((index, crossing), stress, centre_shift) in enumerate(
            zip(crossings, stresses, centre_shifts, strict=True)
        ):
            axis, radius = crossing.axis, crossing.radius
            if self._arteries[index]:
                minor = major = self.mechanics.artery_scale(load.time)
            else:
                minor, major = self.mechanics.vein_semi_axes(
                    float(stress), load.time, self._walls[index] / radius
                )
            neighbours = [c for k, (_, c) in enumerate(crossings) if k != m and in_image[k]]
            outer, major = _fitted_ring(crossing, neighbours, minor, major)
            across = beam - (beam @ axis) * axis
            norm = math.sqrt(across @ across)
            if norm < 1e-6:  # the vessel runs along the beam: nothing to flatten
                continue
            across = across / norm
            other = np.array(
                [
                    axis[1] * across[2] - axis[2] * across[1],
                    axis[2] * across[0] - axis[0] * across[2],
                    axis[0] * across[1] - axis[1] * across[0],
                ]
            )
            maps.append(
                [
                    *crossing.centre,
                    *axis,
                    *across,
                    *other,
                    radius,
                    minor * radius,
                    major * radius,
                    outer,
                    *crossing.span,
                    centre_shift,
                    *_edge_bend(self._harmonics[index], axis, across, other),
                    self._bends[index],
                ]
            )
            shapes.append(
                VesselShape(
                    self._names[index], crossing.centre, radius, minor, major, float(stress)
                )
            )
        table = np.array(maps, dtype=np.float64).reshape(-1, MAP_WIDTH)
        return FrameDeformation(row_shift, columns, table, tuple(shapes), indentation)

    def _crossing(self, index: int, local: np.ndarray, distance: np.ndarray) -> _Crossing | None:
        """Where vessel `index` passes nearest the image, given every node's probe-frame
        position and distance from the image; None when it stays farther from the image than
        its outer radius."""
        part = self._slices[index]
        nodes, radii = self._nodes[part], self._radii[part]
        local, distance = local[part], distance[part]
        k = int(np.argmin(distance))
        if distance[k] > OUTER_RADII * radii[k]:
            return None
        centre, radius = nodes[k], float(radii[k])
        for j in (k - 1, k):  # refine to the plane crossing on either side of node k
            if 0 <= j < len(nodes) - 1 and local[j, 1] * local[j + 1, 1] <= 0:
                step = local[j, 1] - local[j + 1, 1]
                f = 0.0 if step == 0 else local[j, 1] / step
                centre = nodes[j] + f * (nodes[j + 1] - nodes[j])
                radius = float(radii[j] + f * (radii[j + 1] - radii[j]))
                break
        tangent = nodes[min(k + 1, len(nodes) - 1)] - nodes[max(k - 1, 0)]
        tangent = tangent / math.sqrt(tangent @ tangent)
        ends = (nodes[[0, -1]] - centre) @ tangent
        cap = float(radii.max())
        span = (float(ends.min()) - cap, float(ends.max()) + cap)
        return _Crossing(centre, tangent, radius, span, 1.0 + self._bends[index])


def _edge_bend(
    harmonics: np.ndarray, axis: np.ndarray, across: np.ndarray, other: np.ndarray
) -> list[float]:
    """A map row's (cos, sin) coefficients of each harmonic of the angle from `across`
    towards `other` (unit vectors across `axis`), for an edge bend whose phases are measured
    from the phantom's up projected across the axis (its x for a vessel along z): the bend
    turns with the vessel, not with the probe."""
    up = np.array([0.0, 0.0, 1.0]) - axis[2] * axis
    if up @ up < 1e-12:
        up = np.array([1.0, 0.0, 0.0]) - axis[0] * axis
    offset = math.atan2(float(up @ other), float(up @ across))  # up's angle in the map's frame
    coefficients = []
    for order, (amplitude, phase) in zip(VEIN_HARMONICS, harmonics, strict=True):
        turned = order * (offset + phase)
        coefficients += [amplitude * math.cos(turned), amplitude * math.sin(turned)]
    return coefficients


def _fitted_ring(
    crossing: _Crossing, neighbours: list[_Crossing], minor: float, major: float
) -> tuple[float, float]:
    """The outer radius of a vessel's cross-section map, and its major semi-axis (over its
    radius): the ring reaches `OUTER_RADII` radii, but stops `RING_MARGIN` short of every
    neighbour crossing the image (taken at `NEIGHBOUR_REACH` of its radius, room for its
    pulse), so that one vessel's change never bends another (vessels that overlap, a
    junction's, are one lumen and no neighbours); a vein hemmed in that tightly widens only
    as far as its ring leaves room for. Radii count with each vessel's `bulge`."""
    radius, outer = crossing.radius, OUTER_RADII * crossing.radius
    for other in neighbours:
        offset = other.centre - crossing.centre
        across = offset - (offset @ crossing.axis) * crossing.axis
        distance = math.sqrt(across @ across)
        if distance < radius + other.radius:  # overlapping: one lumen (a junction), not a neighbour
            continue
        reach = NEIGHBOUR_REACH * other.radius * other.bulge
        outer = min(outer, distance - reach - RING_MARGIN)
    room = outer / (RING_ROOM * radius * crossing.bulge)
    major = max(minor, min(major, room))
    return max(outer, RING_ROOM * radius * crossing.bulge * max(minor, major, 1.0)), major


@dataclass(frozen=True)
class _Crossing:
    """Where a vessel passes nearest the image: its undeformed centre there, unit tangent and
    radius, and the stretch of the axis (from the centre) that it and its end caps span."""

    centre: np.ndarray
    axis: np.ndarray
    radius: float
    span: tuple[float, float]
    bulge: float
    """The most its edge bends out, over the ellipse's radius (1 + the harmonics' amplitudes)."""


REACH_PAD = 1.0e-6
"""How much farther than its outer radius (m) a map's reach along an image column is taken:
far more than the kernels' rounding (about 1e-17 m here), so culling by the reach never skips
a point that the map's own test would have reached."""


@numba.njit(cache=True, parallel=True)
def column_row_shifts(depths: np.ndarray, columns: np.ndarray, length: float) -> np.ndarray:
    """(cols, rows) bulk shift along the beam of the tissue seen at each pixel, for the
    columns' indentations `columns` and the rows' `depths`: `bulk_row_shifts` at
    `INDENTATION_LEVELS` indentations spanning the columns', interpolated linearly between
    them (the shift is smooth in the indentation; for a span of a few millimetres the
    interpolation is off by well under a micrometre, tested), at a fraction of the cost of
    inverting the compression for every column."""
    low, high = columns.min(), columns.max()
    out = np.empty((columns.shape[0], depths.shape[0]))
    if high == low:  # every column sunk alike: one inversion
        out[:] = bulk_row_shifts(depths, low, length)
        return out
    spacing = (high - low) / (INDENTATION_LEVELS - 1)
    shifts = np.empty((INDENTATION_LEVELS, depths.shape[0]))
    for k in numba.prange(INDENTATION_LEVELS):
        shifts[k] = bulk_row_shifts(depths, low + k * spacing, length)
    for col in numba.prange(columns.shape[0]):
        position = (columns[col] - low) / spacing
        below = min(int(position), INDENTATION_LEVELS - 2)
        above = position - below
        for row in range(depths.shape[0]):
            out[col, row] = (1.0 - above) * shifts[below, row] + above * shifts[below + 1, row]
    return out


@numba.njit(cache=True)
def column_reach(
    points: np.ndarray, rows: int, row_height: float, beam: np.ndarray, maps: np.ndarray
) -> np.ndarray:
    """(M, cols, 2): for each cross-section map and image column, the stretch [lo, hi] of
    distance along `beam` from the column's top pixel centre within which the column's line
    passes within the map's outer radius (plus `REACH_PAD`) of its vessel's axis; lo > hi where
    it never does. The pixel centres (`points`, column-major, as `grid_points` lays them) lie
    on those lines `row * row_height` down, and the bulk shift moves a point along its line,
    so a pixel outside a map's reach is not changed by that map (`undeform_points`)."""
    cols = points.shape[0] // rows
    reach = np.empty((maps.shape[0], cols, 2))
    for m in range(maps.shape[0]):
        row = maps[m]
        tx, ty, tz = row[3], row[4], row[5]
        along_beam = beam[0] * tx + beam[1] * ty + beam[2] * tz
        wx, wy, wz = beam[0] - along_beam * tx, beam[1] - along_beam * ty, beam[2] - along_beam * tz
        ww = wx * wx + wy * wy + wz * wz  # the beam across the axis: how fast the line nears it
        radius = row[15] + REACH_PAD
        for col in range(cols):
            x = points[col * rows, 0] - row[0] - row[18] * beam[0]
            y = points[col * rows, 1] - row[1] - row[18] * beam[1]
            z = points[col * rows, 2] - row[2] - row[18] * beam[2]
            along = x * tx + y * ty + z * tz
            bx, by, bz = x - along * tx, y - along * ty, z - along * tz
            if ww < 1e-12:  # the column runs along the axis: in reach everywhere or nowhere
                inside = bx * bx + by * by + bz * bz < radius * radius
                reach[m, col, 0] = -np.inf if inside else np.inf
                reach[m, col, 1] = np.inf if inside else -np.inf
                continue
            nearest = -(bx * wx + by * wy + bz * wz) / ww
            gap = bx * bx + by * by + bz * bz - nearest * nearest * ww  # squared, at the nearest
            half = math.sqrt(max(radius * radius - gap, 0.0) / ww)
            if gap > radius * radius:
                reach[m, col, 0], reach[m, col, 1] = np.inf, -np.inf
            else:
                reach[m, col, 0], reach[m, col, 1] = nearest - half, nearest + half
    return reach


@numba.njit(cache=True, parallel=True)
def undeform_points(
    points: np.ndarray,
    rows: int,
    row_height: float,
    beam: np.ndarray,
    row_shift: np.ndarray,
    maps: np.ndarray,
    reach: np.ndarray,
) -> None:
    """Map deformed pixel centres (column-major, `rows` per column) in place to the
    undeformed tissue points that moved there: undo the bulk shift along `beam` (inside a
    vessel, its centre's shift), then each cross-section map in turn (see the module
    docstring). Each column runs map by map over its rows, so `reach` (`column_reach`) and a
    map's constants are read once per column and the rows no map can touch cost one
    comparison each (the vessels' rings cover a small part of an image); every point still
    meets the maps in their order, so the points are the same as a point-by-point loop's."""
    cols = points.shape[0] // rows
    for col in numba.prange(cols):
        first = col * rows
        shift = row_shift[col].copy()  # each row's shift along the beam, blended into the vessels'
        for m in range(maps.shape[0]):  # a vessel moves rigidly with the tissue at its centre
            row = maps[m]
            centre_shift = row[18]
            low, high = reach[m, col, 0], reach[m, col, 1]
            for r in range(*_rows_between(low, high, row_height, rows)):
                if not low <= r * row_height <= high:
                    continue  # the map's weight is 0 here
                n = first + r
                weight = _cross_section_weight(
                    points[n, 0] - row[0] - centre_shift * beam[0],
                    points[n, 1] - row[1] - centre_shift * beam[1],
                    points[n, 2] - row[2] - centre_shift * beam[2],
                    row,
                )
                shift[r] += weight * (centre_shift - shift[r])
        on_line = np.ones(rows, dtype=np.bool_)  # still on the column's line, r * row_height
        for r in range(rows):  # - shift[r] along it
            n = first + r
            for axis in range(3):
                points[n, axis] -= shift[r] * beam[axis]
        for m in range(maps.shape[0]):
            row = maps[m]
            low, high, centre_shift = reach[m, col, 0], reach[m, col, 1], row[18]
            for r in range(rows):
                if on_line[r] and not low <= r * row_height - shift[r] + centre_shift <= high:
                    continue
                n = first + r
                reached, ax, ay, az, rho, nu = _section_coordinates(
                    points[n, 0] - row[0], points[n, 1] - row[1], points[n, 2] - row[2], row
                )
                if not reached or rho <= 0.0:
                    continue
                radius, outer = row[12], row[15]
                if nu <= 1.0:
                    scale = radius * nu / rho
                else:
                    edge = rho / nu
                    scale = (radius + (rho - edge) * (outer - radius) / (outer - edge)) / rho
                points[n, 0] += (scale - 1.0) * ax
                points[n, 1] += (scale - 1.0) * ay
                points[n, 2] += (scale - 1.0) * az
                on_line[r] = False


@numba.njit(cache=True, inline="always")
def _rows_between(low: float, high: float, row_height: float, rows: int) -> tuple[int, int]:
    """A range of rows, one past each end, that holds every row r with `low <= r *
    row_height <= high` (empty where low > high); the caller keeps the exact test."""
    if not low <= high:
        return 0, 0
    first = max(0.0, min(float(rows), math.floor(low / row_height) - 1.0))
    last = max(0.0, min(float(rows), math.ceil(high / row_height) + 2.0))
    return int(first), int(last)


@numba.njit(cache=True, inline="always")
def _section_coordinates(
    x: float, y: float, z: float, row: np.ndarray
) -> tuple[bool, float, float, float, float, float]:
    """Where the offset (x, y, z) from map `row`'s centre lies across its vessel: whether
    the map reaches it (within the outer radius and the vessel's stretch of axis), the offset
    across the axis, its distance from the axis and its radius in the deformed cross-section
    (1 on the edge: the ellipse's radius in its direction, bent by the harmonics). The
    harmonics' cosines and sines come from the direction's by the multiple-angle formulas:
    no trigonometric call per point."""
    along = x * row[3] + y * row[4] + z * row[5]
    outer = row[15]
    if x * x + y * y + z * z - along * along >= outer * outer:
        return False, 0.0, 0.0, 0.0, 0.0, 0.0  # most points: far from this vessel's axis
    if not row[16] <= along <= row[17]:
        return False, 0.0, 0.0, 0.0, 0.0, 0.0
    ax, ay, az = x - along * row[3], y - along * row[4], z - along * row[5]
    xb = ax * row[6] + ay * row[7] + az * row[8]
    xn = ax * row[9] + ay * row[10] + az * row[11]
    rho = np.sqrt(xb * xb + xn * xn)
    nu = np.sqrt((xb / row[13]) ** 2 + (xn / row[14]) ** 2)
    if rho > 0.0 and row[25] > 0.0:  # a bent edge (a vein with harmonics)
        c1, s1 = xb / rho, xn / rho
        c2, s2 = c1 * c1 - s1 * s1, 2.0 * c1 * s1
        c3, s3 = c2 * c1 - s2 * s1, s2 * c1 + c2 * s1
        c4, s4 = c2 * c2 - s2 * s2, 2.0 * c2 * s2
        bend = row[19] * c2 + row[20] * s2 + row[21] * c3 + row[22] * s3
        nu /= 1.0 + bend + row[23] * c4 + row[24] * s4
    return True, ax, ay, az, rho, nu


@numba.njit(cache=True, inline="always")
def _cross_section_weight(x: float, y: float, z: float, row: np.ndarray) -> float:
    """1 inside the deformed cross-section of map `row` (offset x, y, z from its centre),
    falling linearly to 0 at its outer radius, 0 beyond it or its vessel's ends."""
    reached, _, _, _, rho, nu = _section_coordinates(x, y, z, row)
    if not reached:
        return 0.0
    if nu <= 1.0:
        return 1.0
    outer = row[15]
    return (outer - rho) / (outer - rho / nu)
