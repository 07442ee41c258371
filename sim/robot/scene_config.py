"""Where the phantom lies in the robot's world: the scene config and its YAML file.

The world frame is the robot's base frame. A scene names the phantom (a spec that
`sim.phantom.load_phantom` knows), the subject, the leg side, the phantom's pose in the base
frame and the height of the table top it lies on. YAML (see `assets/scenes/default.yaml`):

    phantom: default
    subject: null
    leg_side: right
    table_height: 0.0          # table top, z in the base frame (m)
    phantom_to_base:           # pose of the phantom frame (top-face centre, z up)
      xyz: [-0.30, -0.13, 0.06]  # m
      rpy: [0.0, 0.0, 0.0]       # rad, extrinsic x-y-z (roll, pitch, yaw)

`phantom_to_base` may instead be given as `matrix:` with four rows of four numbers.
"""

from __future__ import annotations

from dataclasses import dataclass, field
from pathlib import Path

import numpy as np
import yaml
from scipy.spatial.transform import Rotation

from sim.assets import named_or_path
from sim.transforms import is_rigid, make_pose
from sim.yaml_file import read_yaml_file

LEG_SIDES = ("right", "left")


def scene_path(scene: str | Path) -> Path:
    """A scene file: a path (it has a suffix or a folder), or a name in `assets/scenes/`."""
    return named_or_path("scenes", scene)[0]


def default_scene_path() -> Path:
    """The default scene file shipped with the package."""
    return scene_path("default")


def _default_phantom_to_base() -> np.ndarray:
    return make_pose(np.eye(3), np.array([-0.30, -0.13, 0.06]))


@dataclass(frozen=True, eq=False)
class SceneConfig:
    """The phantom and its placement in the robot base frame (metres, radians)."""

    phantom: str = "default"
    """Name of the phantom spec (`sim.phantom.load_phantom(name)`)."""
    subject: int | None = None
    """Subject index for phantom variations; None keeps the spec's nominal anatomy."""
    leg_side: str = "right"
    """Which leg is scanned: "right" or "left"."""
    table_height: float = 0.0
    """Height of the table top under the phantom, z in the base frame (m)."""
    phantom_to_base: np.ndarray = field(default_factory=_default_phantom_to_base)
    """Pose of the phantom frame (top-face centre, z up) in the base frame, 4x4."""

    def __post_init__(self) -> None:
        if self.leg_side not in LEG_SIDES:
            raise ValueError(f"leg_side must be one of {LEG_SIDES}, got {self.leg_side!r}")
        if not (isinstance(self.phantom, str) and self.phantom):
            raise ValueError(f"phantom must be a non-empty name, got {self.phantom!r}")
        if not np.isfinite(self.table_height):
            raise ValueError(f"table_height must be finite, got {self.table_height}")
        pose = np.asarray(self.phantom_to_base, dtype=np.float64)
        if pose.shape != (4, 4) or not is_rigid(pose):
            raise ValueError("phantom_to_base must be a rigid 4x4 transform")
        object.__setattr__(self, "phantom_to_base", pose)

    def __eq__(self, other: object) -> bool:
        if not isinstance(other, SceneConfig):
            return NotImplemented
        same_fields = (self.phantom, self.subject, self.leg_side, self.table_height) == (
            other.phantom,
            other.subject,
            other.leg_side,
            other.table_height,
        )
        return same_fields and np.allclose(self.phantom_to_base, other.phantom_to_base, atol=1e-9)

    @classmethod
    def from_dict(cls, data: dict, source: str = "scene") -> SceneConfig:
        """Build from the YAML mapping; errors name `source` and the offending key."""
        if not isinstance(data, dict):
            raise ValueError(f"{source}: a scene is a mapping of keys, got {type(data).__name__}")
        known = {"phantom", "subject", "leg_side", "table_height", "phantom_to_base"}
        unknown = sorted(set(data) - known)
        if unknown:
            raise ValueError(f"{source}: unknown scene keys {unknown}; expected {sorted(known)}")
        kwargs = {key: data[key] for key in ("phantom", "subject", "leg_side") if key in data}
        try:
            if "table_height" in data:
                kwargs["table_height"] = float(data["table_height"])
            if "phantom_to_base" in data:
                kwargs["phantom_to_base"] = _pose_from_yaml(data["phantom_to_base"])
            return cls(**kwargs)
        except (ValueError, TypeError) as error:
            raise ValueError(f"{source}: {error}") from None

    def to_dict(self) -> dict:
        """The YAML mapping (pose as xyz + rpy)."""
        rpy = Rotation.from_matrix(self.phantom_to_base[:3, :3]).as_euler("xyz")
        return {
            "phantom": self.phantom,
            "subject": self.subject,
            "leg_side": self.leg_side,
            "table_height": float(self.table_height),
            "phantom_to_base": {
                "xyz": [round(float(v), 12) for v in self.phantom_to_base[:3, 3]],
                "rpy": [round(float(v), 12) for v in rpy],
            },
        }


def _pose_from_yaml(value: object) -> np.ndarray:
    if not isinstance(value, dict) or not ({"xyz", "rpy"} <= set(value) or "matrix" in value):
        raise ValueError("phantom_to_base needs `xyz` and `rpy` (m, rad) or a 4x4 `matrix`")
    if "matrix" in value:
        matrix = np.asarray(value["matrix"], dtype=np.float64)
        if matrix.shape != (4, 4):
            raise ValueError(f"phantom_to_base matrix must be 4x4, got shape {matrix.shape}")
        return matrix
    xyz = np.asarray(value["xyz"], dtype=np.float64)
    rpy = np.asarray(value["rpy"], dtype=np.float64)
    if xyz.shape != (3,) or rpy.shape != (3,):
        raise ValueError("phantom_to_base xyz and rpy must be three numbers each")
    return make_pose(Rotation.from_euler("xyz", rpy).as_matrix(), xyz)


def load_scene_config(path: str | Path | None = None) -> SceneConfig:
    """Read a scene YAML file (the default scene when `path` is None)."""
    path = default_scene_path() if path is None else Path(path)
    return SceneConfig.from_dict(read_yaml_file(path, "scene"), source=str(path))


def save_scene_config(config: SceneConfig, path: str | Path) -> None:
    """Write a scene YAML file."""
    Path(path).write_text(yaml.safe_dump(config.to_dict(), sort_keys=False))
