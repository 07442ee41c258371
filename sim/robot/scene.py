"""The MuJoCo scene: `assets/ur3e/scene.xml` (robot, probe, robot table) plus the phantom.

The phantom body is attached programmatically (`mujoco.MjSpec`) at the scene config's
`phantom_to_base`, with a table under it up to `table_height`. Its geom is a gel: soft contact
(`solref`/`solimp`) and low friction, and `priority` so that every contact with it, the probe
face's above all, uses the gel's parameters. Scanning force is then a simulated quantity that
the wrist force/torque sensor reads.
"""

from __future__ import annotations

import dataclasses

import mujoco
import numpy as np
from scipy.spatial.transform import Rotation

from sim.assets import assets_dir
from sim.phantom import BodySpec, PhantomSpec, load_phantom, make_subject
from sim.robot.scene_config import SceneConfig

FLOOR_HEIGHT = -0.75
"""z of the floor in the base frame (the robot stands on a 0.75 m table)."""
GEL_SOLREF = (0.07, 1.0)
"""Contact time constant (s) and damping ratio: a slow, critically damped (no bounce) contact."""
GEL_SOLIMP = (0.5, 0.5, 0.001, 0.5, 2.0)
"""Constant impedance 0.5. With elliptic friction cones (set in ur3e.xml; pyramidal cones make
low-friction contacts far stiffer) this gives about 2.4 N/mm for the probe face pressed into the
phantom at the default pose (MuJoCo scales contact stiffness by the effective mass there)."""
GEL_FRICTION = (0.1, 0.005, 0.0001)
"""A probe slides on coupling gel: low sliding friction."""
TABLE_MARGIN = 0.05
"""How far the phantom table reaches beyond the phantom's footprint (m)."""


def scene_xml_path() -> str:
    """Path of the robot scene MJCF."""
    return str(assets_dir() / "ur3e" / "scene.xml")


def load_scene_phantom(config: SceneConfig, seed: int | None = None) -> PhantomSpec:
    """The scene's phantom spec: the named spec, with its seed replaced if `seed` is given, made
    into the scene's subject if one is set (the subject's anatomy is drawn from the seed)."""
    spec = load_phantom(config.phantom)
    if seed is not None:
        spec = dataclasses.replace(spec, seed=seed)
    return spec if config.subject is None else make_subject(spec, config.subject)


def _phantom_half_extents(body: BodySpec) -> np.ndarray:
    """Half sizes of the phantom's box footprint in the phantom frame (x, y, z)."""
    if body.kind == "block":
        return 0.5 * np.asarray(body.size, dtype=np.float64)
    if body.kind == "leg":
        return np.array([body.radius, 0.5 * body.length, body.radius])
    raise ValueError(f"phantom body kind must be 'block' or 'leg', got {body.kind!r}")


def _add_phantom(spec: mujoco.MjSpec, config: SceneConfig, body: BodySpec) -> None:
    pose = config.phantom_to_base
    quat = Rotation.from_matrix(pose[:3, :3]).as_quat(scalar_first=True)
    phantom = spec.worldbody.add_body(name="phantom", pos=pose[:3, 3], quat=quat)
    half = _phantom_half_extents(body)
    common = {
        "name": "phantom",
        "rgba": (0.85, 0.62, 0.55, 0.85),
        "contype": 0,
        "conaffinity": 1,
        "priority": 1,
        "solref": GEL_SOLREF,
        "solimp": GEL_SOLIMP,
        "friction": GEL_FRICTION,
    }
    if body.kind == "block":
        phantom.add_geom(
            type=mujoco.mjtGeom.mjGEOM_BOX, size=half, pos=(0.0, 0.0, -half[2]), **common
        )
    else:
        phantom.add_geom(
            type=mujoco.mjtGeom.mjGEOM_CYLINDER,
            size=(body.radius, 0.5 * body.length, 0.0),
            pos=(0.0, 0.0, -body.radius),
            quat=(np.sqrt(0.5), np.sqrt(0.5), 0.0, 0.0),
            **common,
        )
    phantom.add_site(name="phantom_frame", size=(0.004, 0.0, 0.0), group=4)
    _add_table(spec, config, half)


def _add_table(spec: mujoco.MjSpec, config: SceneConfig, half: np.ndarray) -> None:
    """A table from the floor up to `table_height`, under the phantom's footprint."""
    height = config.table_height - FLOOR_HEIGHT
    if height <= 0:
        raise ValueError(
            f"table_height {config.table_height} m must lie above the floor at {FLOOR_HEIGHT} m"
        )
    corners = np.array([[sx, sy, 0.0] for sx in (-1, 1) for sy in (-1, 1)]) * half
    corners = corners @ config.phantom_to_base[:3, :3].T + config.phantom_to_base[:3, 3]
    low, high = corners[:, :2].min(axis=0), corners[:, :2].max(axis=0)
    centre = 0.5 * (low + high)
    half_xy = 0.5 * (high - low) + TABLE_MARGIN
    spec.worldbody.add_geom(
        name="phantom_table",
        type=mujoco.mjtGeom.mjGEOM_BOX,
        size=(half_xy[0], half_xy[1], 0.5 * height),
        pos=(centre[0], centre[1], FLOOR_HEIGHT + 0.5 * height),
        material="table",
        contype=0,
        conaffinity=1,
    )


def build_scene_spec(config: SceneConfig, phantom_body: BodySpec | None = None) -> mujoco.MjSpec:
    """The scene as an editable `MjSpec` (phantom shape from the scene's phantom unless given)."""
    body = load_scene_phantom(config).body if phantom_body is None else phantom_body
    spec = mujoco.MjSpec.from_file(scene_xml_path())
    _add_phantom(spec, config, body)
    return spec


def build_scene(config: SceneConfig, phantom_body: BodySpec | None = None) -> mujoco.MjModel:
    """Compile the full scene: robot, probe, F/T sensor, tables and phantom."""
    return build_scene_spec(config, phantom_body).compile()
