"""IgtlProbe against pyigtl's own OpenIGTLink server on 127.0.0.1, sending as PlusServer does:
IMAGE `Image_Reference` (pixel indices to Reference, mm) and TRANSFORM `ProbeToReference` (mm)
with one timestamp per tracked frame. Frames arrive equal to the sweep's, the calibration and
the tracker's poses come out of the stream in metres, a missing server or stream is one line,
and a server that goes away mid-scan ends the scan with every received frame kept."""

from __future__ import annotations

import dataclasses
import signal
import threading
import time
from collections.abc import Iterator
from contextlib import contextmanager

import numpy as np
import pyigtl
import pytest
import yaml
from sweep_samples import sample_sweep

from resus.acquisition.backends.igtl import IgtlProbe, IgtlProbeConfig, ProbeLinkLost, grey_frame
from resus.acquisition.backends.simulated import SimulatedRobot
from resus.acquisition.patterns import linear_sweep
from resus.acquisition.scanner import ScanAborted, Scanner, ScannerSettings
from resus.errors import ResusError
from resus.sweep.igtl import IgtlServer
from resus.sweep.io import read_sweep
from resus.sweep.model import SweepFrame
from sim.ultrasound.probe import LinearProbe

WAIT = 10.0
EPOCH = 1.7e9
"""OpenIGTLink timestamps are seconds since 1970."""
MM = np.diag([1000.0, 1000.0, 1000.0, 1.0])


@contextmanager
def plus_like_server() -> Iterator[tuple[pyigtl.OpenIGTLinkServer, int]]:
    """pyigtl's server on a free port of 127.0.0.1, serving from a thread of ours; stopped and
    joined afterwards. pyigtl installs its own SIGINT/SIGTERM handlers: the test's come back."""
    handlers = {number: signal.getsignal(number) for number in (signal.SIGINT, signal.SIGTERM)}
    server = pyigtl.OpenIGTLinkServer(port=0, start_now=False)
    for number, handler in handlers.items():
        signal.signal(number, handler)
    thread = threading.Thread(target=server.serve_forever, kwargs={"poll_interval": 0.05})
    thread.start()
    try:
        yield server, server.server_address[1]
    finally:
        server.stop()
        thread.join(WAIT)
        assert not thread.is_alive()


def pose_mm(pose: np.ndarray) -> np.ndarray:
    pose = pose.copy()
    pose[:3, 3] *= 1000
    return pose


def send_frame(server, sweep, index: int, *, image_first: bool = True, image=None) -> None:
    """Frame `index` as PLUS sends it: IMAGE and TRANSFORM with the frame's timestamp."""
    stamp = EPOCH + sweep.timestamps[index]
    pose = sweep.probe_to_base[index]
    messages = [
        pyigtl.ImageMessage(
            (sweep.frames[index] if image is None else image)[None],
            ijk_to_world_matrix=MM @ pose @ sweep.image_to_probe,
            timestamp=stamp,
            device_name="Image_Reference",
        ),
        pyigtl.TransformMessage(pose_mm(pose), timestamp=stamp, device_name="ProbeToReference"),
    ]
    for message in messages if image_first else messages[::-1]:
        server.send_message(message, wait=False)


def poll_until(probe: IgtlProbe, count: int) -> list:
    frames: list = []
    deadline = time.monotonic() + WAIT
    while len(frames) < count and time.monotonic() < deadline:
        frames += probe.poll()
        time.sleep(0.005)
    return frames


def test_frames_arrive_equal_to_the_sweeps_with_calibration_and_tracker_from_the_stream():
    sweep = sample_sweep(n=6, rows=32, cols=48, seed=11)
    with plus_like_server() as (server, port):
        send_frame(server, sweep, 0)  # queued: delivered as soon as the probe connects
        before = time.monotonic()
        with IgtlProbe(IgtlProbeConfig(port=port, timeout=WAIT)) as probe:
            for index in range(1, len(sweep)):  # either order of IMAGE and TRANSFORM pairs
                send_frame(server, sweep, index, image_first=index % 2 == 0)
            frames = poll_until(probe, len(sweep))
            times, poses = probe.tracker_track()
            assert probe.shape == (32, 48) and probe.dropped == 0 and probe.ended is None
            np.testing.assert_allclose(probe.image_to_probe, sweep.image_to_probe, atol=1e-7)
    assert len(frames) == len(sweep)
    stamps = np.array([frame.timestamp for frame in frames])
    assert stamps[0] >= before and np.all(np.diff(stamps) > 0)  # stamped on receipt
    for index, frame in enumerate(frames):
        np.testing.assert_array_equal(frame.image, sweep.frames[index])
        np.testing.assert_allclose(frame.tracker_pose, sweep.probe_to_base[index], atol=1e-7)
        assert frame.sent_at == pytest.approx(EPOCH + sweep.timestamps[index], abs=1e-6)
    np.testing.assert_array_equal(times, stamps)
    np.testing.assert_allclose(poses, sweep.probe_to_base, atol=1e-7)


def test_an_image_in_the_probe_frame_needs_no_tracker(tmp_path):
    sweep = sample_sweep(n=2, rows=32, cols=48, seed=12)
    with plus_like_server() as (server, port):
        server.send_message(
            pyigtl.ImageMessage(
                sweep.frames[0][None], ijk_to_world_matrix=MM @ sweep.image_to_probe,
                timestamp=EPOCH, device_name="Image_Probe",
            ),
            wait=False,
        )  # fmt: skip
        config = IgtlProbeConfig(port=port, image_name="Image_Probe", transform_name=None)
        with IgtlProbe(config) as probe:
            (frame,) = poll_until(probe, 1)
            np.testing.assert_allclose(probe.image_to_probe, sweep.image_to_probe, atol=1e-7)
            assert frame.tracker_pose is None and probe.tracker_track()[1].shape == (0, 4, 4)


def test_a_calibration_file_overrides_the_stream(tmp_path):
    sweep = sample_sweep(n=1, rows=32, cols=48, seed=13)
    calibration = tmp_path / "probe.yaml"
    calibration.write_text(
        yaml.safe_dump({"schema": "resus.probe/1", "pixel_spacing_mm": [0.2, 0.25]})
    )
    with plus_like_server() as (server, port):
        send_frame(server, sweep, 0)
        with IgtlProbe(IgtlProbeConfig(port=port, calibration=calibration)) as probe:
            expected = LinearProbe(width=48 * 0.2e-3, depth=32 * 0.25e-3, cols=48, rows=32)
            np.testing.assert_allclose(probe.image_to_probe, expected.image_to_probe())


def test_no_server_or_no_such_stream_is_one_line():
    with plus_like_server() as (server, port):
        pass  # stopped: nothing listens on the port any more
    with pytest.raises(ResusError) as error:
        IgtlProbe(IgtlProbeConfig(port=port, timeout=1.0))
    assert str(error.value) == (
        f"OpenIGTLink server 127.0.0.1:{port}: connection refused (is the server running?)"
    )
    sweep = sample_sweep(n=1, rows=32, cols=48)
    with plus_like_server() as (server, port):
        server.send_message(
            pyigtl.ImageMessage(sweep.frames[0][None], device_name="Image_Other"), wait=False
        )
        with pytest.raises(ResusError) as error:
            IgtlProbe(IgtlProbeConfig(port=port, timeout=2.0))
    message = str(error.value)
    assert "\n" not in message
    assert message == (
        f"OpenIGTLink server 127.0.0.1:{port}: no IMAGE 'Image_Reference' within 2 s "
        "(received: IMAGE Image_Other)"
    )


@pytest.mark.parametrize(
    ("field", "value", "message"),
    [
        ("port", 70000, r"IgtlProbeConfig.port must be an integer in 1\.\.65535, got 70000"),
        ("port", 0, r"IgtlProbeConfig.port must be an integer in 1\.\.65535, got 0"),
        ("timeout", 0.0, "IgtlProbeConfig.timeout must be positive"),
    ],
)
def test_bad_settings_are_one_line(field, value, message):
    with pytest.raises(ResusError, match=message):
        IgtlProbeConfig(**{field: value})


def test_a_server_that_goes_away_ends_the_stream_after_its_last_frame():
    sweep = sample_sweep(n=4, rows=32, cols=48, seed=14)
    with plus_like_server() as (server, port):
        send_frame(server, sweep, 0)
        probe = IgtlProbe(IgtlProbeConfig(port=port))
        for index in range(1, len(sweep)):
            send_frame(server, sweep, index)
        deadline = time.monotonic() + WAIT
        while server.outgoing_messages and time.monotonic() < deadline:
            time.sleep(0.01)  # until pyigtl has sent every queued message
    try:
        deadline = time.monotonic() + WAIT
        while probe.ended is None and time.monotonic() < deadline:
            time.sleep(0.01)
        frames = probe.poll()  # everything received before the link ended...
        assert [f.image.tobytes() for f in frames] == [f.tobytes() for f in sweep.frames]
        with pytest.raises(ProbeLinkLost, match="the server closed the connection"):
            probe.poll()  # ...then the loss
    finally:
        probe.close()
        assert not probe._thread.is_alive()


class Counter:
    """A scanner listener that counts the recorded frames and says when it has seen enough."""

    def __init__(self, enough: int) -> None:
        self.frames: list[SweepFrame] = []
        self.enough = threading.Event()
        self.count = enough

    def append(self, frame: SweepFrame) -> None:
        self.frames.append(frame)
        if len(self.frames) >= self.count:
            self.enough.set()


def numbered(index: int) -> np.ndarray:
    """A 32 x 48 frame that tells its number."""
    image = np.full((32, 48), index % 251, np.uint8)
    image[0, :4] = np.frombuffer(np.uint32(index).tobytes(), np.uint8)
    return image


def test_a_scan_whose_server_goes_away_stops_with_every_received_frame_kept(
    tmp_path, default_phantom
):
    robot = SimulatedRobot()
    sweep = sample_sweep(n=1, rows=32, cols=48)
    trajectory = linear_sweep(
        default_phantom, robot.scene.phantom_to_base, length=0.05, speed=0.005,
        contact_force=None,
    )  # fmt: skip  # 10 s of robot time: far longer than the test lets the server live
    counter = Counter(enough=5)
    with plus_like_server() as (server, port):
        send_frame(server, sweep, 0, image=numbered(0))

        def feed() -> None:  # PLUS at 200 Hz until the scan has recorded enough frames
            index = 1
            while not counter.enough.wait(0.005):
                send_frame(server, sweep, 0, image=numbered(index))
                index += 1
            server.stop()

        # stamped on the simulated robot's clock, which runs faster than the wall clock
        probe = IgtlProbe(IgtlProbeConfig(port=port), clock=robot.time)
        feeder = threading.Thread(target=feed)
        feeder.start()
        try:
            scanner = Scanner(
                robot, probe, settings=ScannerSettings(progress=False), listeners=[counter]
            )
            with pytest.raises(ScanAborted) as aborted:
                scanner.run(trajectory, tmp_path / "sweep.h5", source="real")
        finally:
            counter.enough.set()
            feeder.join(WAIT)
            probe.close()
        assert not feeder.is_alive() and not probe._thread.is_alive()
    message = str(aborted.value)
    assert "\n" not in message and message.startswith(
        f"scan stopped: OpenIGTLink server 127.0.0.1:{port}: the server closed the connection"
    )
    kept = read_sweep(tmp_path / "sweep.h5")
    assert len(kept) == aborted.value.result.frames == len(counter.frames) >= 5
    np.testing.assert_array_equal(kept.frames, np.stack([f.image for f in counter.frames]))
    numbers = [int(np.frombuffer(image[0, :4].tobytes(), np.uint32)[0]) for image in kept.frames]
    assert numbers == sorted(numbers)  # in the order they were sent


def test_resus_server_to_resus_probe(tmp_path):
    """The two ends of this project talk: what IgtlServer sends, IgtlProbe receives."""
    sweep = sample_sweep(n=3, rows=32, cols=48, seed=15)
    with IgtlServer(sweep.image_to_probe, port=0) as server:

        def send() -> None:
            assert server.wait_for_client(WAIT)
            for index in range(len(sweep)):
                server.append(sweep.frame(index))
                time.sleep(0.02)

        sender = threading.Thread(target=send)
        sender.start()
        try:
            with IgtlProbe(IgtlProbeConfig(port=server.port)) as probe:
                frames = poll_until(probe, 3)
                np.testing.assert_allclose(probe.image_to_probe, sweep.image_to_probe, atol=1e-7)
        finally:
            sender.join(WAIT)
    assert [f.image.tobytes() for f in frames] == [f.tobytes() for f in sweep.frames]
    np.testing.assert_allclose(
        np.stack([f.tracker_pose for f in frames]), sweep.probe_to_base, atol=1e-7
    )


def test_colour_images_turn_grey_and_unusable_ones_are_one_line():
    import cv2

    rgb = np.random.default_rng(16).integers(0, 256, (32, 48, 3), dtype=np.uint8)
    config = IgtlProbeConfig(image_name="Image_Probe", transform_name=None, timeout=WAIT)
    with plus_like_server() as (server, port):
        image = pyigtl.ImageMessage(rgb[None], device_name="Image_Probe", timestamp=EPOCH)
        server.send_message(image, wait=False)
        with IgtlProbe(dataclasses.replace(config, port=port)) as probe:
            (frame,) = poll_until(probe, 1)
    np.testing.assert_array_equal(frame.image, cv2.cvtColor(rgb, cv2.COLOR_RGB2GRAY))
    with plus_like_server() as (server, port):
        deep = np.zeros((1, 32, 48), np.uint16)
        server.send_message(pyigtl.ImageMessage(deep, device_name="Image_Probe"), wait=False)
        with pytest.raises(ResusError) as error:
            IgtlProbe(dataclasses.replace(config, port=port))
    assert str(error.value) == (
        f"OpenIGTLink server 127.0.0.1:{port}: IMAGE pixels are uint16; expected 8-bit images "
        "(received: IMAGE Image_Probe)"
    )


def test_images_that_are_not_one_grey_or_rgb_frame_are_refused_by_name():
    """An IMAGE array is (slices, rows, cols[, components]): one slice of grey, RGB or RGBA."""
    rgba = np.random.default_rng(17).integers(0, 256, (1, 8, 12, 4), dtype=np.uint8)
    np.testing.assert_array_equal(grey_frame(rgba), grey_frame(rgba[..., :3]))  # alpha ignored
    with pytest.raises(ResusError, match=r"^IMAGE is a volume of 3 slices; expected one frame$"):
        grey_frame(np.zeros((3, 8, 12), np.uint8))
    with pytest.raises(
        ResusError, match=r"^IMAGE has 2 components per pixel; expected grey or RGB"
    ):
        grey_frame(np.zeros((1, 8, 12, 2), np.uint8))


def test_a_calibration_that_crops_is_refused_for_an_igtl_stream(tmp_path):
    calibration = tmp_path / "probe.yaml"
    document = {"schema": "resus.probe/1", "pixel_spacing_mm": [0.2, 0.2], "crop": [0, 0, 8, 8]}
    calibration.write_text(yaml.safe_dump(document))
    with pytest.raises(ResusError) as error:
        IgtlProbe(IgtlProbeConfig(port=18944, calibration=calibration))  # refused before connecting
    assert str(error.value) == (
        f"{calibration}: crop does not apply to OpenIGTLink images (the server sends the B-mode "
        "image itself)"
    )
