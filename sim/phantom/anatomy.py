"""Femoral anatomy as a handful of parameters, and the vessel tubes they imply.

The common femoral artery (CFA) runs distally (+y) and divides at `bifurcation_y` into the
superficial femoral artery (SFA, which keeps the course) and the deep femoral artery (DFA,
which turns deeper and lateral-posterior over `dfa_transition`). The femoral vein lies medial
to the artery (CFV proximal to the bifurcation level, FV distal to it); the great saphenous
vein (GSV) leaves the CFV at `gsv_junction_y`, arching up and medial to run superficially.
Both vessels sway gently sideways and deepen distally. Lengths are metres; "lateral" offsets
are signed by the leg's side (+x on a right leg).
"""

from __future__ import annotations

import math
from dataclasses import dataclass
from typing import TYPE_CHECKING

import numpy as np

if TYPE_CHECKING:
    from collections.abc import Sequence

    from sim.phantom.spec import BodySpec, VesselSpec

CONTROL_STEP = 0.010
"""Spacing of control points along y on straight runs (m)."""
TRANSITION_STEP = 0.005
"""Spacing of control points where a branch diverges (m)."""


@dataclass(frozen=True)
class FemoralAnatomy:
    """Parameters of the femoral vessels (and optional femur) of one subject."""

    centre_offset: float = 0.0
    """Lateral offset of the artery-vein midpoint from x = 0."""
    artery_vein_spacing: float = 0.014
    """Centre-to-centre distance of artery and vein along x."""
    artery_depth: float = 0.016
    """Depth of the CFA centre below the top line at the proximal end."""
    vein_depth_offset: float = 0.002
    """How much deeper the vein centre lies than the artery centre."""
    depth_slope: float = 0.06
    """Extra depth per metre travelled distally."""
    cfa_radius: float = 0.0040
    sfa_radius: float = 0.0034
    dfa_radius: float = 0.0028
    cfv_radius: float = 0.0050
    fv_radius: float = 0.0044
    gsv_radius: float = 0.0020
    artery_wall: float = 0.0006
    vein_wall: float = 0.0004
    gsv_wall: float = 0.0004
    """The great saphenous vein's wall: a muscular vein's, thicker than the femoral vein's
    (about 0.4 mm) for its size, 0.5-0.8 mm on ultrasound; it keeps the GSV round under a
    probe that flattens thinner-walled veins (`TissueMechanics.vein_wall_stiffness_mmhg`)."""
    bifurcation_y: float = -0.020
    """Where the CFA divides (and the CFV becomes the FV)."""
    dfa_lateral: float = 0.008
    """Lateral offset the DFA reaches from the SFA course."""
    dfa_drop: float = 0.012
    """Extra depth the DFA reaches below the SFA course."""
    dfa_transition: float = 0.040
    """Distance along y over which the DFA diverges."""
    gsv_junction_y: float = -0.050
    """Where the GSV joins the CFV."""
    gsv_medial: float = 0.015
    """Medial offset the GSV reaches from the femoral vein course."""
    gsv_depth: float = 0.005
    """Depth of the GSV centre once it runs superficially."""
    gsv_arch: float = 0.035
    """Distance along y over which the GSV rises from the junction."""
    sway_amplitude: float = 0.003
    """Amplitude of the sideways sway of both vessels."""
    sway_wavelength: float = 0.120
    sway_phase: float = 0.0
    femur_depth: float | None = None
    """Depth of the femur's top surface; None for no femur."""
    femur_radius: float = 0.012
    femur_lateral: float = 0.012
    """Lateral offset of the femur's axis at y = 0."""
    femur_tilt: float = 0.10
    """Lateral drift of the femur's axis per metre along y."""
    node_count: float = 0.0
    """Inguinal lymph nodes (its whole part; a float, so subjects can draw it)."""
    node_radius: float = 0.0025
    """Half the short axis of a node."""
    node_length: float = 0.008
    """Distance between the centres of a node's end caps: its long axis is this plus twice
    the radius."""
    node_seed: float = 0.0
    """Seed (its whole part) of where the nodes lie and how they turn."""
    muscle_count: float = 0.0
    """Muscle bellies beside and beneath the vessels (its whole part, like `node_count`)."""
    muscle_radius: float = 0.010
    """Typical radius of a belly's cross-section; each is drawn within +-30 % of it."""
    muscle_seed: float = 0.0
    """Seed (its whole part) of where the bellies lie and how they run."""
    nerve_count: float = 0.0
    """1 for a femoral nerve lateral to the artery, 0 for none (its whole part)."""
    nerve_lobes: float = 3.0
    """Fascicle groups side by side across the nerve (its whole part, at least 1): the nerve
    is their union, a flat oval wider than it is deep."""
    nerve_radius: float = 0.0018
    """Radius of one fascicle group's round cross-section."""
    nerve_gap: float = 0.006
    """Fat between the artery's outer wall and the nerve's medial edge."""
    nerve_drop: float = 0.004
    """How much deeper the nerve's centre lies than the artery's."""
    nerve_seed: float = 0.0
    """Seed (its whole part) of how the fascicles are packed inside the nerve."""


def _smoothstep(t: np.ndarray) -> np.ndarray:
    t = np.clip(t, 0.0, 1.0)
    return t * t * (3.0 - 2.0 * t)


def _stations(start: float, stop: float, step: float) -> np.ndarray:
    count = max(2, math.ceil((stop - start) / step - 1e-9) + 1)
    return np.linspace(start, stop, count)


def _joined(*runs: np.ndarray) -> np.ndarray:
    """Concatenate station runs that share their end points."""
    return np.concatenate([runs[0], *(run[1:] for run in runs[1:])])


class _Course:
    """Centre courses of the artery and vein trunks as functions of y."""

    def __init__(self, anatomy: FemoralAnatomy, lateral: float, y0: float) -> None:
        self.anatomy, self.lateral, self.y0 = anatomy, lateral, y0

    def _mid_x(self, y: np.ndarray) -> np.ndarray:
        a = self.anatomy
        phase = 2.0 * math.pi * (y - self.y0) / a.sway_wavelength + a.sway_phase
        return self.lateral * (a.centre_offset + a.sway_amplitude * np.sin(phase))

    def _depth(self, y: np.ndarray) -> np.ndarray:
        return self.anatomy.artery_depth + self.anatomy.depth_slope * (y - self.y0)

    def artery(self, y: np.ndarray) -> np.ndarray:
        x = self._mid_x(y) + self.lateral * self.anatomy.artery_vein_spacing / 2
        return np.stack([x, y, -self._depth(y)], axis=1)

    def vein(self, y: np.ndarray) -> np.ndarray:
        a = self.anatomy
        x = self._mid_x(y) - self.lateral * a.artery_vein_spacing / 2
        return np.stack([x, y, -(self._depth(y) + a.vein_depth_offset)], axis=1)


def build_vessels(
    anatomy: FemoralAnatomy, body: BodySpec, lateral: float
) -> tuple[VesselSpec, ...]:
    """CFA, SFA, DFA, CFV, FV and GSV tubes spanning the body along y."""
    from sim.phantom.spec import ARTERY, VEIN, VesselSpec

    a = anatomy
    y0, y1 = -body.extent_y / 2, body.extent_y / 2
    yb, yg = a.bifurcation_y, a.gsv_junction_y
    if not y0 + CONTROL_STEP <= yb <= y1 - 2 * CONTROL_STEP:
        raise ValueError(f"bifurcation_y {yb} must lie inside the body, away from its ends")
    if not y0 + CONTROL_STEP <= yg <= y1 - a.gsv_arch - CONTROL_STEP:
        raise ValueError(f"gsv_junction_y {yg} leaves no room for the GSV arch in the body")
    course = _Course(a, lateral, y0)

    def vessel(
        name: str, label: int, points: np.ndarray, radii: np.ndarray, wall: float | None = None
    ) -> VesselSpec:
        if wall is None:
            wall = a.artery_wall if label == ARTERY else a.vein_wall
        radii = np.broadcast_to(radii, (len(points),))
        return VesselSpec(name, label, points, radii, wall)

    proximal, distal = _stations(y0, yb, CONTROL_STEP), _stations(yb, y1, CONTROL_STEP)
    sfa_radii = np.interp(distal - yb, [0.0, 0.015], [a.cfa_radius, a.sfa_radius])
    fv_radii = np.interp(distal - yb, [0.0, 0.030], [a.cfv_radius, a.fv_radius])

    dfa_end = min(yb + a.dfa_transition, y1 - CONTROL_STEP)
    dfa_y = _joined(_stations(yb, dfa_end, TRANSITION_STEP), _stations(dfa_end, y1, CONTROL_STEP))
    dfa_turn = _smoothstep((dfa_y - yb) / a.dfa_transition)
    dfa = course.artery(dfa_y)
    dfa[:, 0] += lateral * a.dfa_lateral * dfa_turn
    dfa[:, 2] -= a.dfa_drop * dfa_turn

    arch_end = yg + a.gsv_arch
    gsv_y = _joined(_stations(yg, arch_end, TRANSITION_STEP), _stations(arch_end, y1, CONTROL_STEP))
    gsv_rise = _smoothstep((gsv_y - yg) / a.gsv_arch)
    gsv = course.vein(gsv_y)
    gsv[:, 0] -= lateral * a.gsv_medial * gsv_rise
    gsv[:, 2] = gsv[:, 2] * (1.0 - gsv_rise) - a.gsv_depth * gsv_rise

    return (
        vessel("CFA", ARTERY, course.artery(proximal), np.asarray(a.cfa_radius)),
        vessel("SFA", ARTERY, course.artery(distal), sfa_radii),
        vessel("DFA", ARTERY, dfa, np.asarray(a.dfa_radius)),
        vessel("CFV", VEIN, course.vein(proximal), np.asarray(a.cfv_radius)),
        vessel("FV", VEIN, course.vein(distal), fv_radii),
        vessel("GSV", VEIN, gsv, np.asarray(a.gsv_radius), a.gsv_wall),
    )


NODE_DEPTHS = (0.006, 0.014)
"""Depths of a node's centre below the top line (m): in the superficial fat of the groin."""
NODE_MEDIAL = (0.002, 0.016)
"""Medial gap between a node and the common femoral vein's wall (m): the superficial inguinal
nodes lie beside the femoral vein and the saphenous junction."""


HILUM_RADIUS = (0.35, 0.6)
"""Range of a node's hilum radius, over the node's: the fatty centre of a normal node, its
hypoechoic cortex a band of a millimetre or two around it (a cortex thicker than about 3 mm
is what reads as abnormal)."""
HILUM_CORTEX = 0.0003
"""Least cortex left between a hilum and its node's surface (m)."""
HILUM_OFFSET = (0.0, 0.8)
"""How far off the node's axis a hilum lies, as a share of the room its cortex leaves: the
hilum is often eccentric, towards the side where the node's vessels enter."""


@dataclass(frozen=True)
class LymphNodes:
    """Inguinal lymph nodes: their hypoechoic cortices (the nodes' outlines) and inside each
    the echogenic fatty hilum, the two-tone oval a sonographer tells from a vessel."""

    cortices: tuple[VesselSpec, ...] = ()
    hila: tuple[VesselSpec, ...] = ()
    """One per cortex, in the same order, each inside its cortex."""

    def select(
        self, kept: Sequence[int] | None = None, *, with_hila: bool = True
    ) -> tuple[tuple[VesselSpec, ...], tuple[VesselSpec, ...]]:
        """`PhantomSpec`'s `nodes` and `hila` for the nodes `kept` (all when None), each
        with its hilum; no hila when the spec has no hilum material (`with_hila` False)."""
        kept = range(len(self.cortices)) if kept is None else kept
        cortices = tuple(self.cortices[k] for k in kept)
        return cortices, tuple(self.hila[k] for k in kept) if with_hila else ()


def build_nodes(anatomy: FemoralAnatomy, body: BodySpec, lateral: float) -> LymphNodes:
    """Inguinal lymph nodes: `node_count` capsules (a cylinder with hemispherical caps) in the
    superficial fat, medial to the vein, each turned by its own angle in the skin's plane
    (`make_subject` leaves out a node that would touch a vessel). A
    node whose long axis runs along the leg shows in a transverse image as a disc of the
    vessels' size, one across it as an oval: hypoechoic shapes that are not vessels, with an
    echogenic hilum inside. Each hilum is a capsule on its node's axis segment moved sideways
    by less than the node's radius minus its own and `HILUM_CORTEX`, so it lies wholly inside
    the node; hila are drawn from a generator of their own, after every node, so adding them
    moved no node."""
    from sim.phantom.spec import VesselSpec

    a = anatomy
    rng = np.random.default_rng([int(a.node_seed), 0x10DE])
    half_y = body.extent_y / 2 - a.node_length - a.node_radius
    cortices = []
    for k in range(int(a.node_count)):
        y = rng.uniform(-half_y, half_y)
        centre = _Course(a, lateral, -body.extent_y / 2).vein(np.array([y]))[0]
        turn = rng.uniform(0.0, math.pi)
        axis = 0.5 * a.node_length * np.array([math.sin(turn), math.cos(turn), 0.0])
        reach = a.cfv_radius + a.vein_wall + a.node_radius + abs(axis[0])
        centre[0] -= lateral * (reach + rng.uniform(*NODE_MEDIAL))
        centre[2] = -rng.uniform(*NODE_DEPTHS)
        points = np.stack([centre - axis, centre + axis])
        cortices.append(VesselSpec(f"node{k}", 0, points, np.full(2, a.node_radius)))
    hilum_rng = np.random.default_rng([int(a.node_seed), 0x4111])
    up = np.array([0.0, 0.0, 1.0])
    hila = []
    for k, cortex in enumerate(cortices):
        radius = a.node_radius * hilum_rng.uniform(*HILUM_RADIUS)
        room = max(a.node_radius - radius - HILUM_CORTEX, 0.0)
        side = np.cross(np.diff(cortex.control_points, axis=0)[0], up)
        side /= np.linalg.norm(side)
        angle = hilum_rng.uniform(0.0, 2.0 * math.pi)
        offset = room * hilum_rng.uniform(*HILUM_OFFSET)
        shift = offset * (math.cos(angle) * side + math.sin(angle) * up)
        hila.append(VesselSpec(f"hilum{k}", 0, cortex.control_points + shift, np.full(2, radius)))
    return LymphNodes(tuple(cortices), tuple(hila))


MUSCLE_GAP = (0.001, 0.010)
"""Fat between a muscle belly and the vessel pair it lies beside or beneath (m)."""
MUSCLE_COVER = 0.004
"""Least depth of a belly's top below the top line (m): under the skin and superficial fat."""
MUSCLE_DRIFT = 0.15
"""Largest sideways drift of a belly per metre along the leg: the sartorius crosses the
femoral triangle obliquely, the iliopsoas and pectineus run nearly along it."""


def build_muscles(
    anatomy: FemoralAnatomy, body: BodySpec, lateral: float
) -> tuple[VesselSpec, ...]:
    """Muscle bellies: `muscle_count` tubes along the leg that follow the vessel pair's course,
    each beside it (either side, at the vessels' depth: sartorius, adductor longus) or beneath
    it (iliopsoas, pectineus), drifting sideways as it runs (`make_subject` leaves out a belly
    that would touch a vessel). In a transverse image a belly is a large hypoechoic disc with
    bright fascia at its border: a dark shape as big as a vein that is not one."""
    from sim.phantom.spec import VesselSpec

    a = anatomy
    rng = np.random.default_rng([int(a.muscle_seed), 0x3C1E])
    y = _stations(-body.extent_y / 2, body.extent_y / 2, 2 * CONTROL_STEP)
    course = _Course(a, lateral, -body.extent_y / 2)
    middle = (course.artery(y) + course.vein(y)) / 2  # the pair's midline, as it sways and dips
    width = abs(a.artery_vein_spacing)  # the artery lies lateral or (transposed) medial
    reach = width / 2 + a.cfv_radius + a.vein_wall
    muscles = []
    for k in range(int(a.muscle_count)):
        radius = a.muscle_radius * rng.uniform(0.7, 1.3)
        gap = rng.uniform(*MUSCLE_GAP)
        if rng.uniform() < 0.5:  # beside the pair, at its depth
            offset_x = rng.choice((-1.0, 1.0)) * (reach + gap + radius)
            offset_depth = rng.uniform(-0.5, 1.0) * radius
        else:  # beneath it
            offset_x = rng.uniform(-1.0, 1.0) * width
            offset_depth = a.cfv_radius + a.vein_wall + gap + radius
        drift = rng.uniform(-MUSCLE_DRIFT, MUSCLE_DRIFT)
        points = middle.copy()
        points[:, 0] += offset_x + drift * y
        points[:, 2] = -np.maximum(-middle[:, 2] + offset_depth, radius + MUSCLE_COVER)
        muscles.append(VesselSpec(f"muscle{k}", 0, points, np.full(len(y), radius)))
    return tuple(muscles)


NERVE_DIVISION = 0.010
"""How far past the artery's bifurcation the nerve's trunk runs (m): a few centimetres below
the inguinal ligament it divides into small branches, about where the deep femoral artery
leaves; the phantom ends it there."""
NERVE_LOBE_SPACING = 1.3
"""Centre spacing of neighbouring fascicle groups, in group radii: they overlap into one oval."""
FASCICLE_RADII = (0.0003, 0.0008)
"""Range of a fascicle's radius (m): 0.6-1.6 mm across, the dark dots a groin image resolves."""
EPINEURIUM = 0.00015
"""Least epineurium between a fascicle and the nerve's surface, and between two fascicles (m)."""
FASCICLE_FILL = 0.4
"""Fraction of the nerve's cross-section the fascicles fill (packing stops there)."""
FASCICLE_TRIES = 400
"""Candidate positions drawn per nerve while packing its fascicles."""


@dataclass(frozen=True)
class FemoralNerve:
    """The femoral nerve: fascicle groups (`lobes`, whose union is the hyperechoic epineurium)
    and the hypoechoic `fascicles` inside them, the "honeycomb" of a nerve in cross-section."""

    lobes: tuple[VesselSpec, ...] = ()
    fascicles: tuple[VesselSpec, ...] = ()


def _fascicle_offsets(
    lobe_centres: np.ndarray, lobe_radius: float, rng: np.random.Generator
) -> list[tuple[float, float, float]]:
    """(lateral offset, depth offset, radius) of fascicles packed at random inside the union of
    discs of `lobe_radius` about `lobe_centres` (lateral offsets, depth 0), each clear of the
    surface and of the others by `EPINEURIUM`, until they fill `FASCICLE_FILL` of it."""
    lobe_area = math.pi * lobe_radius**2 * len(lobe_centres)  # overlaps make this an upper bound
    low, high = lobe_centres.min() - lobe_radius, lobe_centres.max() + lobe_radius
    placed: list[tuple[float, float, float]] = []
    filled = 0.0
    for _ in range(FASCICLE_TRIES):
        if filled >= FASCICLE_FILL * lobe_area:
            break
        radius = rng.uniform(*FASCICLE_RADII)
        u, v = rng.uniform(low, high), rng.uniform(-lobe_radius, lobe_radius)
        room = lobe_radius - np.hypot(u - lobe_centres, v).min()
        if room < radius + EPINEURIUM:
            continue
        if any(math.hypot(u - pu, v - pv) < radius + pr + EPINEURIUM for pu, pv, pr in placed):
            continue
        placed.append((u, v, radius))
        filled += math.pi * radius**2
    return placed


def build_nerve(anatomy: FemoralAnatomy, body: BodySpec, lateral: float) -> FemoralNerve:
    """The femoral nerve (none if `nerve_count` < 1): `nerve_lobes` fascicle groups side by side
    lateral to the artery, `nerve_gap` from its wall and `nerve_drop` deeper (below the top
    line, like the vessels' depths), following its sway and dip along the leg from the body's
    proximal end to `NERVE_DIVISION` past the bifurcation; fascicles packed inside by
    `nerve_seed`. In the groin the nerve lies on the iliopsoas under the fascia iliaca, outside
    the femoral sheath, a little deeper than the artery; the phantom's fasciae are sheets at
    fixed depths, so the nerve keeps to the artery rather than to a sheet (`make_subject` leaves
    out a nerve in a vessel's way)."""
    from sim.phantom.spec import VesselSpec

    a = anatomy
    if int(a.nerve_count) < 1:
        return FemoralNerve()
    if int(a.nerve_lobes) < 1:
        raise ValueError(f"nerve_lobes must be >= 1, got {a.nerve_lobes}")
    rng = np.random.default_rng([int(a.nerve_seed), 0xF5E7])
    division = min(a.bifurcation_y + NERVE_DIVISION, body.extent_y / 2)
    y = _stations(-body.extent_y / 2, division, 2 * CONTROL_STEP)
    artery = _Course(a, lateral, -body.extent_y / 2).artery(y)
    reach = max(a.cfa_radius, a.sfa_radius) + a.artery_wall + a.nerve_gap + a.nerve_radius
    centres = reach + NERVE_LOBE_SPACING * a.nerve_radius * np.arange(int(a.nerve_lobes))

    def tube(name: str, offset: float, depth_offset: float, radius: float) -> VesselSpec:
        points = artery + np.array([lateral * offset, 0.0, -(a.nerve_drop + depth_offset)])
        return VesselSpec(name, 0, points, np.full(len(y), radius))

    lobes = tuple(tube(f"nerve{k}", c, 0.0, a.nerve_radius) for k, c in enumerate(centres))
    fascicles = tuple(
        tube(f"fascicle{k}", u, v, r)
        for k, (u, v, r) in enumerate(_fascicle_offsets(centres, a.nerve_radius, rng))
    )
    return FemoralNerve(lobes, fascicles)


def build_bones(anatomy: FemoralAnatomy, body: BodySpec, lateral: float) -> tuple[VesselSpec, ...]:
    """The femur as a straight, slightly oblique tube along y (none if `femur_depth` is None)."""
    from sim.phantom.spec import VesselSpec

    a = anatomy
    if a.femur_depth is None:
        return ()
    y = np.linspace(-body.extent_y / 2, body.extent_y / 2, 3)
    x = lateral * (a.femur_lateral + a.femur_tilt * y)
    z = np.full(3, -(a.femur_depth + a.femur_radius))
    return (VesselSpec("femur", 0, np.stack([x, y, z], axis=1), np.full(3, a.femur_radius)),)
