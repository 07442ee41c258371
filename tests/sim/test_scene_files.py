"""Scene files: the pose forms they may give the phantom in, and every refused value named with
the file (a scene is the first file a user of the simulator writes)."""

from __future__ import annotations

import numpy as np
import pytest
import yaml

from sim.robot.scene_config import load_scene_config
from sim.transforms import make_pose

HALF_TURN = np.diag([-1.0, -1.0, 1.0])
"""A half turn about z."""


def scene_file(tmp_path, **fields) -> str:
    path = tmp_path / "scene.yaml"
    path.write_text(yaml.safe_dump({"phantom": "default", **fields}))
    return str(path)


def test_a_pose_as_xyz_and_rpy_is_the_same_as_its_matrix(tmp_path) -> None:
    by_angles = {"xyz": [-0.3, -0.1, 0.05], "rpy": [0.0, 0.0, float(np.pi)]}
    from_angles = load_scene_config(scene_file(tmp_path, phantom_to_base=by_angles))
    matrix = make_pose(HALF_TURN, [-0.3, -0.1, 0.05])
    np.testing.assert_allclose(from_angles.phantom_to_base, matrix, atol=1e-12)
    by_matrix = {"matrix": matrix.tolist()}
    assert load_scene_config(scene_file(tmp_path, phantom_to_base=by_matrix)) == from_angles


@pytest.mark.parametrize(
    ("fields", "message"),
    [
        ({"colour": "red"}, r"unknown scene keys \['colour'\]; expected \['leg_side', 'phantom'"),
        ({"phantom": ""}, r"phantom must be a non-empty name, got ''"),
        ({"leg_side": "both"}, r"leg_side must be one of \('right', 'left'\), got 'both'"),
        ({"table_height": float("nan")}, r"table_height must be finite, got nan"),
        ({"phantom_to_base": {"xyz": [0, 0, 0]}}, r"phantom_to_base needs `xyz` and `rpy`"),
        ({"phantom_to_base": {"xyz": [0, 0], "rpy": [0, 0, 0]}},
         r"phantom_to_base xyz and rpy must be three numbers each"),
        ({"phantom_to_base": {"matrix": np.eye(3).tolist()}},
         r"phantom_to_base matrix must be 4x4, got shape \(3, 3\)"),
        ({"phantom_to_base": {"matrix": (2 * np.eye(4)).tolist()}},
         r"phantom_to_base must be a rigid 4x4 transform"),
    ],
)  # fmt: skip
def test_a_refused_value_names_the_file(tmp_path, fields: dict, message: str) -> None:
    path = scene_file(tmp_path, **fields)
    with pytest.raises(ValueError, match=rf"^{path}: {message}"):
        load_scene_config(path)


def test_a_scene_that_is_not_a_mapping_is_refused(tmp_path) -> None:
    path = tmp_path / "list.yaml"
    path.write_text("- phantom: default\n")
    with pytest.raises(ValueError, match=rf"^{path}: a scene file holds a mapping of keys, got"):
        load_scene_config(path)
