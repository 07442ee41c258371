"""Phantom specs from YAML files (`assets/phantoms/NAME.yaml` or any path).

A spec gives the body, tissue layers (outermost first; the last one, without a thickness,
fills the rest), blood/wall/bone (and lymph node, hilum, muscle, nerve, fascicle) materials, and
either `anatomy` (parameters of `FemoralAnatomy`, from which the femoral vessels, an optional
femur, lymph nodes, muscle bellies and the femoral nerve are built) or explicit `vessels` and
`bones` lists (name, label, control_points, radii, wall_thickness); or `extends: NAME` and
only what differs from that spec. `mechanics` (optional) makes the tissue deform under the
probe (`TissueMechanics`), `layer_waves` (optional) the layers' boundaries wave
(`LayerWaves`). `variation` holds the subject generator's ranges. Every problem is reported as
one ValueError naming the file.
"""

from __future__ import annotations

import dataclasses
import math
from pathlib import Path
from typing import Any

from sim.assets import assets_dir, named_or_path
from sim.fingerprint import files_digest
from sim.phantom.anatomy import (
    FemoralAnatomy,
    FemoralNerve,
    LymphNodes,
    build_bones,
    build_muscles,
    build_nerve,
    build_nodes,
    build_vessels,
)
from sim.phantom.layer_waves import LayerWaves
from sim.phantom.mechanics import TissueMechanics
from sim.phantom.spec import (
    DEFAULT_TEXTURE_SCALE,
    BodySpec,
    Layer,
    Material,
    PhantomSpec,
    SubjectParameters,
    Variation,
    VesselSpec,
)
from sim.yaml_file import read_yaml_file

SCALE_KEYS = ("layer_thickness_scale", "echogenicity_scale", "noise_level")
"""Variation keys that are not anatomy parameters."""
ANATOMY_KEYS = tuple(f.name for f in dataclasses.fields(FemoralAnatomy))
PARAMETER_KEYS = (*TissueMechanics.keys(), *LayerWaves.keys())
TOP_KEYS = {
    "name", "description", "side", "seed", "noise_level", "body", "layers", "blood", "wall",
    "bone", "node", "hilum", "muscle", "nerve", "fascicle", "anatomy", "vessels", "bones",
    "variation", "texture_scale", "mechanics", "layer_waves",
}  # fmt: skip
MATERIAL_KEYS = ("name", "echogenicity", "attenuation_db_cm_mhz", "impedance_mrayl")
TEXTURE_KEYS = ("texture_variation", "texture_ridges")
"""Optional material keys (0 when absent)."""


def phantoms_dir() -> Path:
    """Where the named phantom specs live."""
    return assets_dir() / "phantoms"


def _resolve(name_or_path: str | Path) -> Path:
    path, named = named_or_path("phantoms", name_or_path)
    if path.is_file():
        return path
    if not named:
        raise ValueError(f"{path}: phantom spec file not found")
    known = sorted(p.stem for p in phantoms_dir().glob("*.yaml"))
    raise ValueError(
        f"unknown phantom {str(name_or_path)!r}; known: {', '.join(known)} (or a YAML path)"
    )


def _mapping(value: Any, what: str, allowed: tuple[str, ...] | set[str]) -> dict:
    if not isinstance(value, dict):
        raise ValueError(f"{what} must be a mapping, got {type(value).__name__}")
    unknown = sorted(set(value) - set(allowed))
    if unknown:
        raise ValueError(f"{what}: unknown key(s) {', '.join(map(str, unknown))}")
    return value


def _material(value: Any, what: str) -> Material:
    fields = _mapping(value, what, (*MATERIAL_KEYS, *TEXTURE_KEYS))
    missing = [key for key in MATERIAL_KEYS if key not in fields]
    if missing:
        raise ValueError(f"{what}: missing {', '.join(missing)}")
    numbers = {
        key: float(fields[key]) for key in (*MATERIAL_KEYS[1:], *TEXTURE_KEYS) if key in fields
    }
    return Material(str(fields["name"]), **numbers)


def _layers(value: Any) -> tuple[Layer, ...]:
    if not isinstance(value, list) or not value:
        raise ValueError("layers must be a non-empty list")
    layers = []
    for number, entry in enumerate(value):
        fields = _mapping(entry, f"layers[{number}]", (*MATERIAL_KEYS, *TEXTURE_KEYS, "thickness"))
        last = number == len(value) - 1
        if last == ("thickness" in fields):
            raise ValueError(f"layers[{number}]: every layer but the last needs a thickness")
        material = _material({k: v for k, v in fields.items() if k != "thickness"}, "layer")
        thickness = math.inf if last else float(fields["thickness"])
        layers.append(Layer(**dataclasses.asdict(material), thickness=thickness))
    return tuple(layers)


def _body(value: Any) -> BodySpec:
    fields = _mapping(value, "body", ("kind", "size", "radius", "length"))
    if "size" in fields:
        fields = {**fields, "size": tuple(float(v) for v in fields["size"])}
    return BodySpec(**fields)


def _tubes(value: Any, what: str) -> tuple[VesselSpec, ...]:
    if not isinstance(value, list):
        raise ValueError(f"{what} must be a list")
    keys = ("name", "label", "control_points", "radii", "wall_thickness")
    return tuple(
        VesselSpec(**_mapping(entry, f"{what}[{i}]", keys)) for i, entry in enumerate(value)
    )


def _variation(value: Any) -> Variation:
    fields = _mapping(value or {}, "variation", ("ranges", "min_gap", "max_attempts"))
    ranges = {}
    for key, bounds in _mapping(
        fields.get("ranges", {}), "variation.ranges", (*ANATOMY_KEYS, *PARAMETER_KEYS, *SCALE_KEYS)
    ).items():
        if not (isinstance(bounds, list) and len(bounds) == 2 and bounds[0] <= bounds[1]):
            raise ValueError(f"variation.ranges.{key} must be [low, high] with low <= high")
        ranges[key] = (float(bounds[0]), float(bounds[1]))
    return Variation(
        ranges, float(fields.get("min_gap", 1.0e-3)), int(fields.get("max_attempts", 200))
    )


def _texture_scale(value: Any) -> tuple[float, float, float]:
    """`texture_scale: [sx, sy, sz]` in metres."""
    if not (isinstance(value, list) and len(value) == 3):
        raise ValueError("texture_scale must be [sx, sy, sz] in metres")
    return float(value[0]), float(value[1]), float(value[2])


def _parameters(value: Any, what: str, kind: type[SubjectParameters]) -> SubjectParameters | None:
    """`WHAT: {NAME: value, ...}`: `kind`'s fields (floats), its defaults for the rest."""
    if value is None:
        return None
    fields = _mapping(value, what, kind.keys())
    return kind(**{key: float(number) for key, number in fields.items()})


def spec_from_mapping(data: Any) -> PhantomSpec:
    """Build a spec from parsed YAML (raises ValueError without the file name)."""
    data = _mapping(data, "spec", TOP_KEYS)
    if ("anatomy" in data) == ("vessels" in data):
        raise ValueError("give exactly one of `anatomy` or `vessels`")
    for key in ("name", "side", "body", "layers", "blood", "wall"):
        if key not in data:
            raise ValueError(f"missing required key `{key}`")
    side = str(data["side"])
    lateral = {"right": 1.0, "left": -1.0}.get(side)
    if lateral is None:
        raise ValueError(f"side must be right or left, got {side!r}")
    body, layers = _body(data["body"]), _layers(data["layers"])
    anatomy, nerve, nodes = None, FemoralNerve(), LymphNodes()
    if "anatomy" in data:
        anatomy = FemoralAnatomy(**_mapping(data["anatomy"], "anatomy", ANATOMY_KEYS))
        vessels = build_vessels(anatomy, body, lateral)
        bones = build_bones(anatomy, body, lateral)
        nodes = build_nodes(anatomy, body, lateral)
        muscles = build_muscles(anatomy, body, lateral)
        nerve = build_nerve(anatomy, body, lateral)
    else:
        muscles = ()
        vessels, bones = _tubes(data["vessels"], "vessels"), _tubes(data.get("bones", []), "bones")
    bone, node, muscle = data.get("bone"), data.get("node"), data.get("muscle")
    nerve_material, fascicle = data.get("nerve"), data.get("fascicle")
    hilum = data.get("hilum")
    node_tubes, hila = nodes.select(with_hila=hilum is not None)
    return PhantomSpec(
        name=str(data["name"]),
        side=side,
        body=body,
        layers=layers,
        blood=_material(data["blood"], "blood"),
        wall=_material(data["wall"], "wall"),
        bone=None if bone is None else _material(bone, "bone"),
        vessels=vessels,
        bones=bones,
        node=None if node is None else _material(node, "node"),
        nodes=node_tubes,
        hilum=None if hilum is None else _material(hilum, "hilum"),
        hila=hila,
        muscle=None if muscle is None else _material(muscle, "muscle"),
        muscles=muscles,
        nerve=None if nerve_material is None else _material(nerve_material, "nerve"),
        nerves=nerve.lobes,
        fascicle=None if fascicle is None else _material(fascicle, "fascicle"),
        fascicles=nerve.fascicles,
        noise_level=float(data.get("noise_level", 0.2)),
        texture_scale=_texture_scale(data.get("texture_scale", list(DEFAULT_TEXTURE_SCALE))),
        seed=int(data.get("seed", 0)),
        variation=_variation(data.get("variation")),
        anatomy=anatomy,
        mechanics=_parameters(data.get("mechanics"), "mechanics", TissueMechanics),
        layer_waves=_parameters(data.get("layer_waves"), "layer_waves", LayerWaves),
    )


def load_phantom(name_or_path: str | Path) -> PhantomSpec:
    """Load `default`, `leg` (from assets/phantoms) or a YAML file by path."""
    path = _resolve(name_or_path)
    data, _ = _read_spec(path, ())
    try:
        return spec_from_mapping(data)
    except (ValueError, TypeError) as error:
        raise ValueError(f"{path}: {error}") from error


def phantom_digest(name_or_path: str | Path) -> str:
    """16 hex digits of a SHA-256 over the texts a spec is read from: its file and every spec
    it `extends`. A cache of simulated data keys on it, since a spec file edited in place keeps
    its name (the named specs are also in `simulator_fingerprint`)."""
    return files_digest(_read_spec(_resolve(name_or_path), ())[1])


def _read_spec(path: Path, seen: tuple[Path, ...]) -> tuple[dict[str, Any], tuple[Path, ...]]:
    """The spec's YAML mapping and the files it was read from (this one first); `extends:
    NAME` (a named spec or a path) starts from that spec's mapping, this file's keys laid over
    it (mappings merged key by key, anything else replaced): a variant says only what it
    changes."""
    if path.resolve() in seen:
        raise ValueError(f"{path}: `extends` loops back to {seen[0]}")
    data = read_yaml_file(path, "phantom spec")
    if "extends" not in data:
        return data, (path,)
    changes = {key: value for key, value in data.items() if key != "extends"}
    base, sources = _read_spec(_resolve(str(data["extends"])), (*seen, path.resolve()))
    return _laid_over(base, changes), (path, *sources)


def _laid_over(base: Any, changes: Any) -> Any:
    """`changes` laid over `base`: mappings merged key by key, anything else replaced."""
    if not (isinstance(base, dict) and isinstance(changes, dict)):
        return changes
    merged = dict(base)
    for key, value in changes.items():
        merged[key] = _laid_over(base.get(key), value)
    return merged
