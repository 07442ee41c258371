"""From a tube's spline description to the chain of round-cone segments that IS its geometry.

The centreline is sampled at equal arc-length steps, short enough that the chord between two
samples never strays more than `chord_tolerance` from the spline (sagitta = kappa h^2 / 8), and
at most `max_segment_length`. Consecutive samples with their radii become round cones (the
convex hull of two spheres), so the tube is the union of those cones, exactly.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np
from scipy.interpolate import CubicSpline

from sim.phantom.spec import VesselSpec

MAX_SEGMENT_LENGTH = 1.0e-3
CHORD_TOLERANCE = 2.0e-6
MIN_SEGMENT_LENGTH = 5.0e-5
_FINE_SAMPLES_PER_SPAN = 200


@dataclass(frozen=True)
class TubeSamples:
    """A tube's centreline sampled into chain nodes, with the radius at each node."""

    nodes: np.ndarray
    radii: np.ndarray


def centreline_spline(vessel: VesselSpec) -> tuple[CubicSpline, np.ndarray]:
    """The vessel's centreline spline and its knot parameters (cumulative chord length)."""
    chords = np.linalg.norm(np.diff(vessel.control_points, axis=0), axis=1)
    knots = np.concatenate([[0.0], np.cumsum(chords)])
    return CubicSpline(knots, vessel.control_points), knots


def sample_tube(
    vessel: VesselSpec,
    max_segment_length: float = MAX_SEGMENT_LENGTH,
    chord_tolerance: float = CHORD_TOLERANCE,
) -> TubeSamples:
    """Sample the centreline at equal arc-length steps fine enough for `chord_tolerance`."""
    spline, knots = centreline_spline(vessel)
    fine = np.linspace(0.0, knots[-1], _FINE_SAMPLES_PER_SPAN * (len(knots) - 1) + 1)
    velocity, acceleration = spline(fine, 1), spline(fine, 2)
    speed = np.linalg.norm(velocity, axis=1)
    curvature = np.linalg.norm(np.cross(velocity, acceleration), axis=1) / speed**3
    step = np.sqrt(8.0 * chord_tolerance / max(curvature.max(), 1e-12))
    step = float(np.clip(step, MIN_SEGMENT_LENGTH, max_segment_length))
    arc = np.concatenate([[0.0], np.cumsum(np.linalg.norm(np.diff(spline(fine), axis=0), axis=1))])
    count = max(1, int(np.ceil(arc[-1] / step)))
    parameters = np.interp(np.linspace(0.0, arc[-1], count + 1), arc, fine)
    return TubeSamples(spline(parameters), np.interp(parameters, knots, vessel.radii))


@dataclass(frozen=True)
class SegmentChain:
    """Round-cone segments of several tubes: rows `(ax, ay, az, bx, by, bz, ra, rb)`.

    `tube[i]` is the index of segment i's tube in the list it was built from, `label[i]` that
    tube's label.
    """

    segments: np.ndarray
    tube: np.ndarray
    label: np.ndarray

    @classmethod
    def from_tubes(cls, tubes: tuple[VesselSpec, ...], indices: list[int]) -> SegmentChain:
        """Chain the tubes `tubes[i]` for i in `indices` (their index is kept in `tube`)."""
        return cls.from_samples([(i, tubes[i].label, sample_tube(tubes[i])) for i in indices])

    @classmethod
    def from_samples(cls, tubes: list[tuple[int, int, TubeSamples]]) -> SegmentChain:
        """Chain already sampled tubes given as `(tube index, label, samples)`."""
        rows, owners, labels = [np.zeros((0, 8))], [np.zeros(0, np.int16)], [np.zeros(0, np.uint8)]
        for index, label, samples in tubes:
            nodes, radii = samples.nodes, samples.radii
            rows.append(np.column_stack([nodes[:-1], nodes[1:], radii[:-1], radii[1:]]))
            owners.append(np.full(len(nodes) - 1, index, np.int16))
            labels.append(np.full(len(nodes) - 1, label, np.uint8))
        return cls(
            np.ascontiguousarray(np.concatenate(rows)),
            np.concatenate(owners),
            np.concatenate(labels),
        )

    def __len__(self) -> int:
        return len(self.segments)
