"""The UR3e in rerun: DH body poses agree with MuJoCo's kinematics, shapes with the MJCF."""

from __future__ import annotations

import mujoco
import numpy as np
import pytest
from scipy.spatial.transform import Rotation
from sim.assets import assets_dir

from resus.visualize.robot import BODY_NAMES, body_poses, ur3e_shapes


@pytest.fixture(scope="module")
def model():
    return mujoco.MjModel.from_xml_path(str(assets_dir() / "ur3e" / "ur3e.xml"))


def test_body_poses_match_mujoco_kinematics(model):
    data = mujoco.MjData(model)
    rng = np.random.default_rng(7)
    for q in rng.uniform(-np.pi, np.pi, (20, 6)):
        data.qpos[:6] = q
        mujoco.mj_kinematics(model, data)
        poses = body_poses(q)
        for k, name in enumerate(BODY_NAMES):
            body = model.body(name)
            np.testing.assert_allclose(poses[k, :3, 3], data.xpos[body.id], atol=1e-12)
            np.testing.assert_allclose(
                poses[k, :3, :3], data.xmat[body.id].reshape(3, 3), atol=1e-12
            )


def test_every_visual_geom_is_drawn_once(model):
    kinds = {int(t) for t in (mujoco.mjtGeom.mjGEOM_CYLINDER, mujoco.mjtGeom.mjGEOM_CAPSULE)}
    kinds.add(int(mujoco.mjtGeom.mjGEOM_BOX))
    visual = sum(
        1
        for g in range(model.ngeom)
        if model.geom_group[g] == 2 and int(model.geom_type[g]) in kinds
    )
    assert visual > 20
    drawn = 0
    for shapes in ur3e_shapes().values():
        for archetype in shapes.values():
            for field in ("radii", "half_sizes"):
                batch = getattr(archetype, field, None)
                if batch is not None:
                    drawn += len(batch.as_arrow_array())
    assert drawn == visual


def test_upper_arm_capsule_spans_its_mjcf_fromto():
    """MJCF: capsule fromto (-0.03, 0, 0.12) -> (-0.21, 0, 0.12) in the upper arm body."""
    capsule = ur3e_shapes()["upper_arm_link"]["capsules"]
    start = np.array(capsule.translations.as_arrow_array().to_pylist()[0])
    length = capsule.lengths.as_arrow_array().to_pylist()[0]
    quaternion = capsule.quaternions.as_arrow_array().to_pylist()[0]
    end = start + Rotation.from_quat(quaternion).apply([0.0, 0.0, length])
    ends = sorted([start.tolist(), end.tolist()])
    np.testing.assert_allclose(ends, [[-0.21, 0.0, 0.12], [-0.03, 0.0, 0.12]], atol=1e-6)
