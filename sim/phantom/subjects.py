"""Seeded subjects: anatomical variants of a phantom spec, the simulator's "pigs".

Subject k draws every quantity in `spec.variation.ranges` uniformly, from a generator seeded
by `(spec.seed, k)`, rebuilds the vessels, and keeps the draw only if the vessels fit: artery
and vein walls at least `min_gap` apart, vessels clear of the bone, and covered by at least
`min_gap` of tissue inside the body. Otherwise it draws again (same generator), so subject k
is always the same phantom. Lymph nodes, muscle bellies and a femoral nerve closer than
`min_gap` to a vessel are left out. The tissue mechanics', the muscle bellies', the nerve's and
the layer waves' ranges are each drawn from a generator of their own, so that adding them kept
every earlier subject's anatomy.
"""

from __future__ import annotations

import dataclasses
from dataclasses import dataclass

import numpy as np

from sim.phantom.anatomy import (
    FemoralNerve,
    build_bones,
    build_muscles,
    build_nerve,
    build_nodes,
    build_vessels,
)
from sim.phantom.centreline import SegmentChain, TubeSamples, sample_tube
from sim.phantom.layer_waves import LayerWaves
from sim.phantom.mechanics import TissueMechanics
from sim.phantom.spec import ARTERY, VEIN, BodySpec, PhantomSpec, SubjectParameters, VesselSpec
from sim.phantom.tube_kernels import brute_force_distance, pack_segments


@dataclass(frozen=True)
class _SampledVessel:
    """A vessel's chain samples, plus the points its fit checks run on."""

    vessel: VesselSpec
    samples: TubeSamples
    points: np.ndarray
    """Chain nodes and segment midpoints."""
    outer_radii: np.ndarray
    """Lumen radius plus wall at `points`, plus the slack for the points' spacing."""

    @classmethod
    def of(cls, vessel: VesselSpec) -> _SampledVessel:
        samples = sample_tube(vessel)
        nodes, radii = samples.nodes, samples.radii
        points = np.concatenate([nodes, (nodes[1:] + nodes[:-1]) / 2])
        point_radii = np.concatenate([radii, (radii[1:] + radii[:-1]) / 2])
        # Any axis point lies within half a midpoint spacing of a checked point; distances are
        # 1-Lipschitz and the radius changes by at most |dr/ds| over that stretch.
        half_spacing = np.linalg.norm(np.diff(nodes, axis=0), axis=1).max() / 4
        slope = np.abs(np.diff(radii)).max() / (4 * half_spacing)
        slack = half_spacing * (1.0 + slope)
        return cls(vessel, samples, points, point_radii + vessel.wall_thickness + slack)


def _clearance(vessels: list[_SampledVessel], others: list[_SampledVessel]) -> float:
    """Lower bound of the gap between the outer walls of `vessels` and those of `others`."""
    if not vessels or not others:
        return np.inf
    chain = SegmentChain.from_samples(
        [
            (0, 0, TubeSamples(o.samples.nodes, o.samples.radii + o.vessel.wall_thickness))
            for o in others
        ]
    )
    points = np.concatenate([v.points for v in vessels])
    radii = np.concatenate([v.outer_radii for v in vessels])
    return float((brute_force_distance(points, pack_segments(chain.segments)) - radii).min())


def _tissue_cover(vessel: _SampledVessel, body: BodySpec) -> float:
    """Least tissue between the vessel's outer wall and the body surface (top, sides, bottom)."""
    points = vessel.points
    if body.kind == "leg":
        radial = np.hypot(points[:, 0], points[:, 2] + body.radius)
        return float((body.radius - radial - vessel.outer_radii).min())
    sx, _, sz = body.size
    margins = np.stack([-points[:, 2], points[:, 2] + sz, sx / 2 - np.abs(points[:, 0])], axis=1)
    return float((margins.min(axis=1) - vessel.outer_radii).min())


def vessels_fit(
    vessels: tuple[VesselSpec, ...], others: tuple[VesselSpec, ...], body: BodySpec, gap: float
) -> bool:
    """Whether artery and vein keep `gap` apart, and from the other tubes (bone, lymph nodes),
    and the vessels stay in the body."""
    sampled = [_SampledVessel.of(v) for v in vessels]
    if min(_tissue_cover(v, body) for v in sampled) < gap:
        return False
    arteries = [v for v in sampled if v.vessel.label == ARTERY]
    veins = [v for v in sampled if v.vessel.label == VEIN]
    if _clearance(arteries, veins) < gap:
        return False
    return _clearance(sampled, [_SampledVessel.of(other) for other in others]) >= gap


MECHANICS_STREAM = 1
"""Mixed into the seed of the generator that draws a subject's mechanics, so that drawing
them never shifts the anatomy's draws (adding mechanics kept every subject's anatomy)."""
MUSCLE_STREAM = 2
"""Likewise for the muscle bellies (adding them kept every subject's vessels)."""
MUSCLE_KEYS = ("muscle_count", "muscle_radius", "muscle_seed")
"""The `FemoralAnatomy` parameters drawn from the muscle stream."""
NERVE_STREAM = 3
"""Likewise for the femoral nerve (adding it kept every subject's vessels, nodes and bellies)."""
NERVE_KEYS = (
    "nerve_count", "nerve_lobes", "nerve_radius", "nerve_gap", "nerve_drop", "nerve_seed"
)  # fmt: skip
"""The `FemoralAnatomy` parameters drawn from the nerve stream."""
LAYER_WAVE_STREAM = 4
"""Likewise for the layers' waves (adding them kept every subject's anatomy and mechanics)."""


def _stream_draws(
    spec: PhantomSpec, subject: int, names: set[str] | tuple[str, ...], stream: int
) -> dict[str, float]:
    """The subject's draws of the varied quantities in `names`, from generator `stream`."""
    rng = np.random.default_rng([spec.seed, subject, stream])
    return {
        key: float(rng.uniform(low, high))
        for key, (low, high) in sorted(spec.variation.ranges.items())
        if key in names
    }


def _subject_parameters(
    spec: PhantomSpec, subject: int, nominal: SubjectParameters | None, stream: int
) -> SubjectParameters | None:
    """The subject's mechanics or layer waves: the spec's `nominal` ones, with each varied
    parameter drawn from generator `stream`; None where the spec has none."""
    if nominal is None:
        return None
    draws = _stream_draws(spec, subject, type(nominal).keys(), stream)
    return dataclasses.replace(nominal, **draws)


def make_subject(spec: PhantomSpec, subject: int) -> PhantomSpec:
    """Subject `subject` (>= 0) of a nominal spec, deterministic in (spec.seed, subject)."""
    if spec.anatomy is None:
        raise ValueError(f"phantom {spec.name!r} has explicit vessels, no anatomy to vary")
    if spec.subject is not None:
        raise ValueError(f"{spec.name!r} is already subject {spec.subject}; use the nominal spec")
    if subject < 0:
        raise ValueError(f"subject must be >= 0, got {subject}")
    variation = spec.variation
    own_streams = {*TissueMechanics.keys(), *LayerWaves.keys(), *MUSCLE_KEYS, *NERVE_KEYS}
    ranges = dict(sorted(i for i in variation.ranges.items() if i[0] not in own_streams))
    rng = np.random.default_rng([spec.seed, subject])
    anatomy_names = {f.name for f in dataclasses.fields(spec.anatomy)}
    for _ in range(variation.max_attempts):
        draws = {key: rng.uniform(low, high) for key, (low, high) in ranges.items()}
        thickness_scale = rng.uniform(
            *ranges.get("layer_thickness_scale", (1.0, 1.0)), len(spec.layers)
        )
        echo_scale = rng.uniform(*ranges.get("echogenicity_scale", (1.0, 1.0)), len(spec.layers))
        anatomy = dataclasses.replace(
            spec.anatomy, **{k: float(v) for k, v in draws.items() if k in anatomy_names}
        )
        try:
            vessels = build_vessels(anatomy, spec.body, spec.lateral_sign)
            bones = build_bones(anatomy, spec.body, spec.lateral_sign)
        except ValueError:
            continue
        if vessels_fit(vessels, bones, spec.body, variation.min_gap):
            break
    else:
        raise ValueError(
            f"phantom {spec.name!r}: no subject {subject} fits in {variation.max_attempts} "
            "draws; narrow the variation ranges"
        )
    anatomy = dataclasses.replace(
        anatomy,
        **_stream_draws(spec, subject, MUSCLE_KEYS, MUSCLE_STREAM),
        **_stream_draws(spec, subject, NERVE_KEYS, NERVE_STREAM),
    )

    def clear_of_vessels(tube: VesselSpec) -> bool:
        """A node or belly in a vessel's way is left out, not drawn again: no bias on vessels."""
        return vessels_fit(vessels, (tube,), spec.body, variation.min_gap)

    nodes = build_nodes(anatomy, spec.body, spec.lateral_sign)
    kept = [k for k, cortex in enumerate(nodes.cortices) if clear_of_vessels(cortex)]
    node_tubes, hila = nodes.select(kept, with_hila=spec.hilum is not None)
    muscles = tuple(filter(clear_of_vessels, build_muscles(anatomy, spec.body, spec.lateral_sign)))
    layers = tuple(
        dataclasses.replace(
            layer,
            thickness=layer.thickness * float(t),
            echogenicity=layer.echogenicity * float(e),
        )
        for layer, t, e in zip(spec.layers, thickness_scale, echo_scale, strict=True)
    )
    nerve = build_nerve(anatomy, spec.body, spec.lateral_sign)
    if not vessels_fit(vessels, nerve.lobes, spec.body, variation.min_gap):
        nerve = FemoralNerve()  # left out whole, like a node in a vessel's way
    return dataclasses.replace(
        spec,
        name=f"{spec.name}/subject-{subject}",
        mechanics=_subject_parameters(spec, subject, spec.mechanics, MECHANICS_STREAM),
        layer_waves=_subject_parameters(spec, subject, spec.layer_waves, LAYER_WAVE_STREAM),
        layers=layers,
        vessels=vessels,
        bones=bones,
        nodes=node_tubes,
        hila=hila,
        muscles=muscles,
        nerves=nerve.lobes,
        fascicles=nerve.fascicles,
        anatomy=anatomy,
        noise_level=float(draws.get("noise_level", spec.noise_level)),
        subject=subject,
    )
