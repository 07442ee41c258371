"""A sweep logged to rerun, saved to .rrd and read back: entities, timelines, quads, series."""

from __future__ import annotations

import numpy as np
import pytest
from rerun_readback import Recording
from sweep_samples import sample_sweep

from resus.errors import ResusError
from resus.visualize import SweepLogger, log_sweep, make_blueprint, open_recording
from resus.visualize.quads import tinted_texture
from resus.visualize.robot import BODY_NAMES

N = 5


@pytest.fixture(scope="module")
def sweep():
    return sample_sweep(N, rows=12, cols=16, seed=3)


@pytest.fixture(scope="module")
def saved(sweep, tmp_path_factory):
    path = tmp_path_factory.mktemp("rerun") / "sweep.rrd"
    predictions = np.roll(sweep.labels, 1, axis=2)
    with open_recording("test", save=path, blueprint=make_blueprint()) as session:
        log_sweep(session.stream, sweep, predictions=predictions)
    return Recording(path), predictions


def edge_corners(pose: np.ndarray, image_to_probe: np.ndarray, rows: int, cols: int) -> np.ndarray:
    """Pixel-edge corners computed directly: pose @ image_to_probe @ (col, row, 0, 1)."""
    edges = [(-0.5, -0.5), (cols - 0.5, -0.5), (cols - 0.5, rows - 0.5), (-0.5, rows - 0.5)]
    return np.array([(pose @ image_to_probe @ [c, r, 0.0, 1.0])[:3] for c, r in edges])


def test_every_stage_entity_is_there_with_a_blueprint(saved):
    recording, _ = saved
    expected = {
        "/world/ultrasound/frame",
        "/frame/image",
        "/frame/labels",
        "/frame/prediction",
        "/world/probe",
        "/world/probe_path",
        "/signals/force",
        "/signals/torque",
        "/signals/joints",
    } | {f"/world/robot/{body}" for body in BODY_NAMES}
    assert expected <= recording.entities
    assert len(recording.blueprints) == 1
    assert "AnnotationContext:context" in recording.static["/frame"]


@pytest.mark.parametrize(
    "entity", ["/world/ultrasound/frame", "/frame/image", "/frame/labels", "/world/probe"]
)
def test_one_row_per_frame_on_both_timelines(saved, sweep, entity):
    recording, _ = saved
    assert recording.times(entity, "frame").tolist() == list(range(N))
    np.testing.assert_allclose(recording.times(entity, "time"), sweep.timestamps, atol=1e-9)


def test_quad_corners_are_the_frame_pixel_edges_in_the_world(saved, sweep):
    recording, _ = saved
    rows, cols = sweep.frame_shape
    quads = recording.column("/world/ultrasound/frame", "Mesh3D:vertex_positions")
    for i, quad in enumerate(quads):
        expected = edge_corners(sweep.probe_to_base[i], sweep.image_to_probe, rows, cols)
        np.testing.assert_allclose(np.array(quad), expected, atol=1e-6)
    texcoords = recording.column("/world/ultrasound/frame", "Mesh3D:vertex_texcoords")[0]
    assert texcoords == [[0, 0], [1, 0], [1, 1], [0, 1]]


def test_quad_texture_is_the_frame_tinted_by_its_labels(saved, sweep):
    recording, _ = saved
    rows, cols = sweep.frame_shape
    rows_of_quads = recording.temporal["/world/ultrasound/frame"]
    for i, row in enumerate(rows_of_quads):
        texture = np.array(row["Mesh3D:albedo_texture_buffer"][0], dtype=np.uint8)
        texture = texture.reshape(rows, cols, 3)
        assert row["Mesh3D:albedo_texture_format"][0]["width"] == cols
        background = sweep.labels[i] == 0
        np.testing.assert_array_equal(texture[background, 0], sweep.frames[i][background])
        np.testing.assert_array_equal(texture, tinted_texture(sweep.frames[i], sweep.labels[i]))
        artery = sweep.labels[i] == 1
        assert (texture[artery, 0] >= texture[artery, 2]).all()  # red wins over blue


def test_2d_images_and_labels_are_the_frames(saved, sweep):
    recording, predictions = saved
    images = recording.column("/frame/image", "Image:buffer")
    labels = recording.column("/frame/labels", "SegmentationImage:buffer")
    predicted = recording.column("/frame/prediction", "SegmentationImage:buffer")
    for i in range(N):
        np.testing.assert_array_equal(np.ravel(images[i]), sweep.frames[i].ravel())
        np.testing.assert_array_equal(np.ravel(labels[i]), sweep.labels[i].ravel())
        np.testing.assert_array_equal(np.ravel(predicted[i]), predictions[i].ravel())


def test_probe_pose_and_time_series_match_the_sweep(saved, sweep):
    recording, _ = saved
    translations = recording.column("/world/probe", "Transform3D:translation")
    np.testing.assert_allclose(np.squeeze(translations), sweep.probe_to_base[:, :3, 3], atol=1e-6)
    force = recording.column("/signals/force", "Scalars:scalars")
    torque = recording.column("/signals/torque", "Scalars:scalars")
    joints = recording.column("/signals/joints", "Scalars:scalars")
    np.testing.assert_allclose(np.hstack([force, torque]), sweep.wrench)
    np.testing.assert_allclose(joints, sweep.joint_positions)
    assert recording.static["/signals/joints"]["SeriesLines:names"][0] == "shoulder_pan"


def test_live_logging_frame_by_frame_equals_the_bulk_log(saved, sweep, tmp_path):
    bulk, _ = saved
    path = tmp_path / "live.rrd"
    with open_recording("test", save=path) as session:
        logger = SweepLogger(session.stream, sweep.image_to_probe, sweep.label_names)
        for i in range(N):
            logger.append(sweep.frame(i))
    live = Recording(path)
    assert logger.count == N
    for entity, component in [
        ("/world/ultrasound/frame", "Mesh3D:vertex_positions"),
        ("/world/robot/probe", "Transform3D:translation"),
        ("/signals/force", "Scalars:scalars"),
    ]:
        assert live.times(entity, "frame").tolist() == list(range(N))
        np.testing.assert_array_equal(
            live.column(entity, component), bulk.column(entity, component)
        )


def test_a_sweep_without_joints_or_wrench_logs_no_robot_or_series(tmp_path):
    bare = sample_sweep(3, rows=8, cols=8, optional=False)
    path = tmp_path / "bare.rrd"
    with open_recording("test", save=path) as session:
        log_sweep(session.stream, bare)
    recording = Recording(path)
    assert len(recording.temporal["/world/ultrasound/frame"]) == 3
    assert not any(entity.startswith("/world/robot") for entity in recording.entities)
    assert "/signals/force" not in recording.temporal
    assert "/frame/labels" not in recording.entities


def test_recording_needs_somewhere_to_go_and_an_rrd_name(tmp_path):
    with pytest.raises(ResusError, match="nowhere to send the recording"):
        open_recording("test")
    with pytest.raises(ResusError, match=r"\.rrd"):
        open_recording("test", save=tmp_path / "out.h5")
    with pytest.raises(ResusError, match="serve, spawn"):
        open_recording("test", live="browser")


def test_spawn_without_a_display_is_refused(monkeypatch):
    monkeypatch.delenv("DISPLAY", raising=False)
    monkeypatch.delenv("WAYLAND_DISPLAY", raising=False)
    with pytest.raises(ResusError, match="needs a display"):
        open_recording("test", live="spawn")
