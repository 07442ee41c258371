"""The UR3e in rerun: its MJCF's visual shapes per body, placed by DH forward kinematics.

The shapes (cylinders, capsules, boxes, with their materials' colours) are read once from
`assets/ur3e/ur3e.xml` through MuJoCo's compiler and logged as static data in each body's
frame; per frame only the bodies' poses change. The MJCF puts each link body at the DH frame
before its joint, so body k+1 sits at `frame_chain(q)[k] @ Rz(q[k])` and the probe body at the
flange; `tests/test_rerun_robot.py` checks these poses against MuJoCo's own kinematics.
"""

from __future__ import annotations

from functools import cache
from typing import TYPE_CHECKING

import numpy as np
import rerun as rr
from scipy.spatial.transform import Rotation
from sim.assets import assets_dir

from resus.visualize.entities import ROBOT
from resus.visualize.transforms import pose_columns
from sim.robot.kinematics import LINK_NAMES, frame_chain

if TYPE_CHECKING:
    import mujoco

BODY_NAMES = ("base", *LINK_NAMES, "probe")
"""The UR3e model's bodies, base first; body k + 1 moves with joint k."""
VISUAL_GROUP = 2
"""MJCF geom group of the drawn (not collision) shapes."""


def body_poses(joint_positions: np.ndarray) -> np.ndarray:
    """Base-frame poses (len(BODY_NAMES), 4, 4) of the UR3e's bodies at joints `q` (rad)."""
    q = np.asarray(joint_positions, dtype=np.float64)
    chain = frame_chain(q)
    poses = np.empty((len(BODY_NAMES), 4, 4))
    poses[0] = np.eye(4)
    for k in range(6):
        c, s = np.cos(q[k]), np.sin(q[k])
        turn = np.array([[c, -s, 0, 0], [s, c, 0, 0], [0, 0, 1, 0], [0, 0, 0, 1.0]])
        poses[k + 1] = chain[k] @ turn
    poses[-1] = chain[6]
    return poses


@cache
def ur3e_shapes() -> dict[str, dict[str, rr.AsComponents]]:
    """Per body, its visual shapes as rerun archetypes keyed "cylinders", "capsules", "boxes"."""
    import mujoco

    model = mujoco.MjModel.from_xml_path(str(assets_dir() / "ur3e" / "ur3e.xml"))
    kinds = {
        int(mujoco.mjtGeom.mjGEOM_CYLINDER): "cylinders",
        int(mujoco.mjtGeom.mjGEOM_CAPSULE): "capsules",
        int(mujoco.mjtGeom.mjGEOM_BOX): "boxes",
    }
    found: dict[str, dict[str, list[int]]] = {name: {} for name in BODY_NAMES}
    for geom in range(model.ngeom):
        kind = kinds.get(int(model.geom_type[geom]))
        if model.geom_group[geom] != VISUAL_GROUP or kind is None:
            continue
        body = model.body(int(model.geom_bodyid[geom])).name
        found[body].setdefault(kind, []).append(geom)
    return {
        body: {kind: _shapes(model, kind, geoms) for kind, geoms in kinds_of_body.items()}
        for body, kinds_of_body in found.items()
    }


def _shapes(model: mujoco.MjModel, kind: str, geoms: list[int]) -> rr.AsComponents:
    """One archetype holding the geoms `geoms` (all of one kind) in their body's frame."""
    size = model.geom_size[geoms]
    centre = model.geom_pos[geoms]
    quaternions = model.geom_quat[geoms][:, [1, 2, 3, 0]]  # MuJoCo's w x y z -> x y z w
    material = model.geom_matid[geoms]
    rgba = np.where(
        (material >= 0)[:, None], model.mat_rgba[np.maximum(material, 0)], model.geom_rgba[geoms]
    )
    colours = np.rint(255 * rgba).astype(np.uint8)
    solid = rr.components.FillMode.Solid
    if kind == "cylinders":
        return rr.Cylinders3D(
            lengths=2 * size[:, 1], radii=size[:, 0], centers=centre, quaternions=quaternions,
            colors=colours, fill_mode=solid,
        )  # fmt: skip
    if kind == "capsules":  # MuJoCo centres a capsule on its origin; rerun starts it there
        axis = Rotation.from_quat(quaternions).as_matrix()[:, :, 2]
        return rr.Capsules3D(
            lengths=2 * size[:, 1], radii=size[:, 0], translations=centre - axis * size[:, 1:2],
            quaternions=quaternions, colors=colours, fill_mode=solid,
        )  # fmt: skip
    return rr.Boxes3D(
        half_sizes=size, centers=centre, quaternions=quaternions, colors=colours, fill_mode=solid
    )


def log_robot_shapes(stream: rr.RecordingStream) -> None:
    """Log every body's shapes once (static), under `world/robot/<body>/<kind>`."""
    for body, shapes in ur3e_shapes().items():
        for kind, archetype in shapes.items():
            stream.log(f"{ROBOT}/{body}/{kind}", archetype, static=True)


def send_robot_poses(
    stream: rr.RecordingStream, indexes: list[rr.TimeColumn], joint_positions: np.ndarray
) -> None:
    """Send the bodies' poses for (N, 6) joint rows on the time columns `indexes`."""
    poses = np.stack([body_poses(q) for q in joint_positions])
    for k, body in enumerate(BODY_NAMES):
        stream.send_columns(f"{ROBOT}/{body}", indexes=indexes, columns=pose_columns(poses[:, k]))
