"""The description of a vessel phantom: body, tissue layers, materials and tubes.

Phantom frame (metres): origin at the centre of the top (skin) surface, +z out of the skin
(anterior), +y distal along the leg, +x = y cross z (the patient's right). Tissue lies at
z <= skin. A block spans x in [-sx/2, sx/2], y in [-sy/2, sy/2], z in [-sz, 0]; a leg is a
circular cylinder of radius R along y, length L, axis at z = -R (its top line at z = 0).
"""

from __future__ import annotations

import math
from dataclasses import dataclass, field
from typing import TYPE_CHECKING, TypeVar

import numpy as np

from sim.labels import ARTERY, VEIN
from sim.phantom.layer_waves import LayerWaves
from sim.phantom.mechanics import TissueMechanics

if TYPE_CHECKING:
    from sim.phantom.anatomy import FemoralAnatomy

BODY_KINDS = ("block", "leg")
DEFAULT_TEXTURE_SCALE = (2.5e-3, 8.0e-3, 1.5e-3)
"""Texture lattice spacing (m) along x, y, z (see `PhantomSpec.texture_scale`)."""
SIDES = ("right", "left")
SubjectParameters = TypeVar("SubjectParameters", TissueMechanics, LayerWaves)
"""A spec's parameter groups that subjects draw from generators of their own."""
CENTIMETRES_PER_METRE = 100.0
"""Attenuation is given per centimetre (dB/cm/MHz), lengths in metres."""


@dataclass(frozen=True)
class Material:
    """Acoustic properties of one tissue.

    `echogenicity` is the relative scatter amplitude (gel about 0.5, blood about 0.02, bone 2);
    attenuation is in dB/cm/MHz and acoustic impedance in MRayl.
    """

    name: str
    echogenicity: float
    attenuation_db_cm_mhz: float
    impedance_mrayl: float
    texture_variation: float = 0.0
    """Standard deviation (nepers) of a smooth log-normal variation of the scatter amplitude
    over the phantom's texture field: fat lobules brighter and darker than their neighbours."""
    texture_ridges: float = 0.0
    """Echogenicity added along the zero crossings of a second texture field: a network of
    thin bright lines, the septa between fat lobules or the perimysium between fascicles."""

    def __post_init__(self) -> None:
        if self.echogenicity < 0 or self.attenuation_db_cm_mhz < 0:
            raise ValueError(f"material {self.name!r}: echogenicity and attenuation must be >= 0")
        if not self.impedance_mrayl > 0:
            raise ValueError(f"material {self.name!r}: impedance_mrayl must be positive")
        if self.texture_variation < 0 or self.texture_ridges < 0:
            raise ValueError(f"material {self.name!r}: texture_* must be >= 0")

    @property
    def textured(self) -> bool:
        return self.texture_variation > 0 or self.texture_ridges > 0


@dataclass(frozen=True)
class Layer(Material):
    """A tissue layer: a material with a thickness measured along the skin normal (m).

    The deepest layer of a phantom has infinite thickness (it fills the rest of the body).
    """

    thickness: float = math.inf

    def __post_init__(self) -> None:
        super().__post_init__()
        if not self.thickness > 0:
            raise ValueError(f"layer {self.name!r}: thickness must be positive")


@dataclass(frozen=True)
class BodySpec:
    """The phantom's outer shape: a gel `block` (size sx, sy, sz) or a `leg` (radius, length)."""

    kind: str
    size: tuple[float, float, float] = (0.0, 0.0, 0.0)
    radius: float = 0.0
    length: float = 0.0

    def __post_init__(self) -> None:
        if self.kind not in BODY_KINDS:
            raise ValueError(f"body kind must be one of {BODY_KINDS}, got {self.kind!r}")
        if self.kind == "block" and not (len(self.size) == 3 and min(self.size) > 0):
            raise ValueError(f"block size must be three positive numbers, got {self.size}")
        if self.kind == "leg" and not (self.radius > 0 and self.length > 0):
            raise ValueError("leg radius and length must be positive")

    @property
    def extent_y(self) -> float:
        """Length of the body along y (the leg axis)."""
        return self.size[1] if self.kind == "block" else self.length


@dataclass(frozen=True, eq=False)
class VesselSpec:
    """A tube: a cubic-spline centreline through `control_points` (K, 3) with radius `radii` (K,).

    The spline is scipy's `CubicSpline` (not-a-knot ends) over the cumulative chord length of the
    control points; the radius is interpolated linearly in that parameter. `label` is 1 (artery)
    or 2 (vein); bones, lymph nodes, muscle bellies and nerves use label 0. `wall_thickness` is
    the echogenic wall outside the lumen.
    """

    name: str
    label: int
    control_points: np.ndarray
    radii: np.ndarray
    wall_thickness: float = 0.0

    def __post_init__(self) -> None:
        points = np.array(self.control_points, dtype=np.float64)
        radii = np.array(self.radii, dtype=np.float64)
        if points.ndim != 2 or points.shape[1] != 3 or len(points) < 2:
            raise ValueError(f"vessel {self.name!r}: control_points must be (K >= 2, 3)")
        if radii.shape != (len(points),) or not (radii > 0).all():
            raise ValueError(f"vessel {self.name!r}: radii must be K positive numbers")
        if not (np.linalg.norm(np.diff(points, axis=0), axis=1) > 0).all():
            raise ValueError(f"vessel {self.name!r}: consecutive control points coincide")
        if self.label not in (0, ARTERY, VEIN) or self.wall_thickness < 0:
            raise ValueError(f"vessel {self.name!r}: label must be 0, 1 or 2 and wall >= 0")
        points.setflags(write=False)
        radii.setflags(write=False)
        object.__setattr__(self, "control_points", points)
        object.__setattr__(self, "radii", radii)

    def __eq__(self, other: object) -> bool:
        if not isinstance(other, VesselSpec):
            return NotImplemented
        return (
            (self.name, self.label, self.wall_thickness)
            == (other.name, other.label, other.wall_thickness)
            and np.array_equal(self.control_points, other.control_points)
            and np.array_equal(self.radii, other.radii)
        )

    __hash__ = None  # type: ignore[assignment]


@dataclass(frozen=True)
class Variation:
    """How subjects differ: uniform ranges `[low, high]` per varied quantity.

    Keys are `FemoralAnatomy`, `TissueMechanics` and `LayerWaves` field names, plus
    `layer_thickness_scale` and `echogenicity_scale` (independent factor per layer) and
    `noise_level`. `min_gap` is the smallest allowed gap between artery and vein walls (and
    between vessels and bone).
    """

    ranges: dict[str, tuple[float, float]] = field(default_factory=dict)
    min_gap: float = 1.0e-3
    max_attempts: int = 200


@dataclass(frozen=True)
class PhantomSpec:
    """Everything that defines one phantom (or one generated subject of it)."""

    name: str
    side: str
    body: BodySpec
    layers: tuple[Layer, ...]
    blood: Material
    wall: Material
    bone: Material | None
    vessels: tuple[VesselSpec, ...]
    bones: tuple[VesselSpec, ...] = ()
    node: Material | None = None
    """Lymph node cortex (hypoechoic); its tubes carry label 0, like bones."""
    nodes: tuple[VesselSpec, ...] = ()
    muscle: Material | None = None
    """Skeletal muscle (hypoechoic, with bright perimysium); its bellies carry label 0."""
    muscles: tuple[VesselSpec, ...] = ()
    """Muscle bellies beside and beneath the vessels: large dark shapes that are not vessels."""
    nerve: Material | None = None
    """The nerve's epineurium (hyperechoic); its tubes carry label 0."""
    nerves: tuple[VesselSpec, ...] = ()
    """The femoral nerve's fascicle groups (`FemoralNerve.lobes`): their union is the nerve."""
    fascicle: Material | None = None
    """A nerve fascicle (hypoechoic): the dark cells of the nerve's honeycomb."""
    fascicles: tuple[VesselSpec, ...] = ()
    """Fascicles; a point is fascicle only inside the nerve (its epineurium wraps them)."""
    hilum: Material | None = None
    """A lymph node's hilum (echogenic fat and vessels); without it, nodes have no hilum."""
    hila: tuple[VesselSpec, ...] = ()
    """Hila (`LymphNodes.hila`); a point is hilum only inside a node (its cortex wraps it)."""
    noise_level: float = 0.2
    texture_scale: tuple[float, float, float] = DEFAULT_TEXTURE_SCALE
    """Lattice spacing (m) of the texture fields along x, y, z: lobules and fascicles are
    flattened under the skin and drawn out along the leg."""
    seed: int = 0
    subject: int | None = None
    variation: Variation = field(default_factory=Variation)
    anatomy: FemoralAnatomy | None = None
    """The parameters the vessels were built from; `make_subject` varies them."""
    mechanics: TissueMechanics | None = None
    """How the tissue deforms under the probe and pulses with the heart; None: rigid."""
    layer_waves: LayerWaves | None = None
    """How the layers' boundaries wave about their depths (`sim.phantom.layer_waves`); None:
    every boundary parallel to the skin."""

    def structures(self) -> dict[str, tuple[Material | None, tuple[VesselSpec, ...]]]:
        """Tissue inside tubes that carry no label, kind by kind (material, tubes), in the
        order their materials follow the layers' and blood's: bone, lymph node, muscle belly,
        nerve, fascicle, hilum."""
        return {
            "bone": (self.bone, self.bones),
            "node": (self.node, self.nodes),
            "muscle": (self.muscle, self.muscles),
            "nerve": (self.nerve, self.nerves),
            "fascicle": (self.fascicle, self.fascicles),
            "hilum": (self.hilum, self.hila),
        }

    def __post_init__(self) -> None:
        if self.side not in SIDES:
            raise ValueError(f"side must be one of {SIDES}, got {self.side!r}")
        if not self.layers or not math.isinf(self.layers[-1].thickness):
            raise ValueError("layers must end with a deep layer of unlimited thickness")
        if any(math.isinf(layer.thickness) for layer in self.layers[:-1]):
            raise ValueError("only the deepest layer may have unlimited thickness")
        if any(vessel.label not in (ARTERY, VEIN) for vessel in self.vessels):
            raise ValueError("every vessel needs label 1 (artery) or 2 (vein)")
        if self.bones and self.bone is None:
            raise ValueError("bones are given but no bone material")
        if self.nodes and self.node is None:
            raise ValueError("lymph nodes are given but no node material")
        if self.muscles and self.muscle is None:
            raise ValueError("muscle bellies are given but no muscle material")
        if self.nerves and self.nerve is None:
            raise ValueError("a nerve is given but no nerve material")
        if self.fascicles and (self.fascicle is None or not self.nerves):
            raise ValueError("fascicles need a fascicle material and a nerve to lie in")
        if self.hila and (self.hilum is None or not self.nodes):
            raise ValueError("hila need a hilum material and lymph nodes to lie in")
        if not self.noise_level >= 0:
            raise ValueError(f"noise_level must be >= 0, got {self.noise_level}")
        if len(self.texture_scale) != 3 or not min(self.texture_scale) > 0:
            raise ValueError(
                f"texture_scale must be three positive lengths, got {self.texture_scale}"
            )

    def attenuation_below_skin(self, depths: np.ndarray) -> np.ndarray:
        """One-way attenuation (dB/MHz) the layers put between the skin and each of `depths`
        (m, along the skin normal): each layer's dB/cm/MHz times the centimetres of it above
        that depth, the layers at their own thickness. What a TGC curve must undo for the
        layered tissue to look evenly bright."""
        thickness = np.array([layer.thickness for layer in self.layers])
        tops = np.concatenate([[0.0], np.cumsum(thickness[:-1])])
        alpha = np.array([layer.attenuation_db_cm_mhz for layer in self.layers])
        inside = np.clip(np.asarray(depths, dtype=np.float64)[..., None] - tops, 0.0, thickness)
        return (inside * alpha).sum(axis=-1) * CENTIMETRES_PER_METRE

    @property
    def lateral_sign(self) -> float:
        """+1 for a right leg (lateral is +x), -1 for a left leg."""
        return 1.0 if self.side == "right" else -1.0
