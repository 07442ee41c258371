"""VideoProbe on a real OpenCV capture: an MJPG video file written here, opened as the source."""

from __future__ import annotations

import time

import cv2
import numpy as np
import pytest
import yaml

from resus.acquisition.backends.video import VideoProbe, VideoProbeConfig
from resus.acquisition.calibration.probe import ProbeCalibration
from resus.errors import ResusError
from sim.ultrasound.probe import LinearProbe

FPS = 25.0
FRAMES = 12
WIDTH, HEIGHT = 160, 120
CROP = (32, 24, 96, 64)
"""(x, y, width, height) of the 'B-mode image' on the grabbed 'screen'."""


def screen(index: int) -> np.ndarray:
    """A colour frame: dark screen, a grey image region whose level encodes the frame index,
    a bright marker outside the crop that must not show up."""
    frame = np.full((HEIGHT, WIDTH, 3), 10, np.uint8)
    x, y, width, height = CROP
    frame[y : y + height, x : x + width] = 40 + 15 * index
    frame[0:16, 0:16] = (0, 0, 255)  # red marker, outside the crop
    return frame


@pytest.fixture(scope="module")
def video(tmp_path_factory):
    path = tmp_path_factory.mktemp("video") / "screen.avi"
    writer = cv2.VideoWriter(str(path), cv2.VideoWriter_fourcc(*"MJPG"), FPS, (WIDTH, HEIGHT))
    assert writer.isOpened()
    for index in range(FRAMES):
        writer.write(screen(index))
    writer.release()
    return path


def calibration_file(tmp_path, **fields) -> str:
    path = tmp_path / "probe.yaml"
    path.write_text(yaml.safe_dump({"schema": "resus.probe/1", **fields}))
    return str(path)


def test_grabs_cropped_grey_frames_stamped_at_capture(video, tmp_path):
    calibration = calibration_file(tmp_path, crop=list(CROP), pixel_spacing_mm=[0.2, 0.25])
    before = time.monotonic()
    with VideoProbe(VideoProbeConfig(str(video), calibration)) as probe:
        assert probe.shape == (64, 96) and probe.frame_rate == FPS
        frames = []
        deadline = time.monotonic() + 5.0
        while probe.ended is None and time.monotonic() < deadline:
            frames += probe.poll()
            time.sleep(0.02)
        frames += probe.poll()
    assert probe.ended == "end of the video" and probe.dropped == 0
    assert len(frames) == FRAMES
    stamps = np.array([frame.timestamp for frame in frames])
    assert stamps[0] >= before and np.all(np.diff(stamps) > 0)
    # a file plays at its recorded rate, as a grabber would deliver it
    assert np.median(np.diff(stamps)) == pytest.approx(1 / FPS, abs=0.01)
    for index, frame in enumerate(frames):
        assert frame.image.shape == (64, 96) and frame.image.dtype == np.uint8
        # grey level of the crop (MJPG is lossy: a few levels), no trace of the marker
        assert abs(float(np.median(frame.image)) - (40 + 15 * index)) <= 3
        assert frame.image.max() - frame.image.min() < 20
    # pixel spacing in mm -> image_to_probe in metres, placed like the simulated probe
    expected = LinearProbe(width=96 * 0.2e-3, depth=64 * 0.25e-3, cols=96, rows=64)
    np.testing.assert_allclose(probe.image_to_probe, expected.image_to_probe())


def test_plus_style_matrix_in_millimetres_and_crop_override(video, tmp_path):
    matrix_mm = np.array([[0.2, 0, 0, -9.5], [0, 0, -0.2, 0], [0, 0.25, 0, 0.1], [0, 0, 0, 1]])
    calibration = calibration_file(tmp_path, image_to_probe_mm=matrix_mm.tolist())
    config = VideoProbeConfig(str(video), calibration, crop=(0, 0, 20, 10), pace=False)
    with VideoProbe(config) as probe:
        assert probe.shape == (10, 20)
        np.testing.assert_allclose(probe.image_to_probe[:3], 1e-3 * matrix_mm[:3])
        first = probe.poll()[0]
    # the red marker in the top-left corner is now inside: grey of pure red (BGR 0,0,255)
    assert abs(int(first.image[4, 4]) - 76) <= 6


@pytest.mark.parametrize(
    ("fields", "message"),
    [
        ({"crop": [0, 0, 10, 10]}, "give exactly one of pixel_spacing"),
        ({"pixel_spacing": [1e-4]}, "pixel_spacing must be \\[column, row\\]"),
        ({"pixel_spacing": [1e-4, 1e-4], "crop": [0, 0, 0, 5]}, "crop: x, y must be >= 0"),
        ({"image_to_probe": np.eye(3).tolist()}, "must be a 4x4 matrix"),
        ({"image_to_probe": np.zeros((4, 4)).tolist()}, "bottom row"),
    ],
)
def test_bad_calibration_is_one_line_naming_the_file(tmp_path, fields, message):
    path = calibration_file(tmp_path, **fields)
    with pytest.raises(ResusError, match=message) as error:
        ProbeCalibration.from_yaml(path)
    assert str(error.value).startswith(path) and "\n" not in str(error.value)


def test_a_calibration_built_in_code_names_its_fields() -> None:
    with pytest.raises(ResusError, match=r"^ProbeCalibration needs exactly one .*, got neither"):
        ProbeCalibration()
    with pytest.raises(ResusError, match=r"^ProbeCalibration needs exactly one .*, got both"):
        ProbeCalibration(pixel_spacing=(1e-4, 1e-4), matrix=np.eye(4))
    with pytest.raises(ResusError, match=r"^ProbeCalibration\.pixel_spacing must be positive"):
        ProbeCalibration(pixel_spacing=(1e-4, 0.0))


def test_bad_source_or_crop_is_a_clear_error(video, tmp_path):
    calibration = calibration_file(tmp_path, pixel_spacing=[1e-4, 1e-4])
    with pytest.raises(ResusError, match=r"video source '.*missing\.avi' cannot be opened"):
        VideoProbe(VideoProbeConfig(str(tmp_path / "missing.avi"), calibration))
    with pytest.raises(ResusError, match="reaches outside the video's 160 x 120 frames"):
        VideoProbe(VideoProbeConfig(str(video), calibration, crop=(100, 0, 100, 10)))
    with pytest.raises(ResusError, match="probe calibration file not found"):
        VideoProbe(VideoProbeConfig(str(video), tmp_path / "none.yaml"))
