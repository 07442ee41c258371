"""The OpenIGTLink server (`resus.sweep.igtl`) on 127.0.0.1: to pyigtl's own client, frames
arrive as PLUS sends them (TRANSFORM ProbeToReference, IMAGE Image_Reference, millimetres) and
image corners land where the Sweep puts them; a file replays at its recorded timing (received
by the project's IgtlProbe, which keeps every frame); bad ports are one clear line."""

from __future__ import annotations

import socket
import threading
import time
from collections.abc import Iterator
from contextlib import contextmanager

import numpy as np
import pyigtl
import pytest
from sweep_samples import sample_sweep

from resus.errors import ResusError
from resus.sweep.igtl import IMAGE_NAME, TRANSFORM_NAME, IgtlServer, stream_sweep
from resus.sweep.model import frame_corners, pixels_to_world

WAIT = 5.0
"""Longest wait for one message or connection (s); the tests take far less."""


@contextmanager
def igtl_client(port: int) -> Iterator[pyigtl.OpenIGTLinkClient]:
    """pyigtl's client on 127.0.0.1:`port`; stopped and its thread joined afterwards."""
    client = pyigtl.OpenIGTLinkClient("127.0.0.1", port)
    try:
        yield client
    finally:
        client.stop()
        client._client_thread.join(WAIT)
        assert not client._client_thread.is_alive()


def receive(
    client: pyigtl.OpenIGTLinkClient,
) -> tuple[pyigtl.ImageMessage, pyigtl.TransformMessage]:
    image = client.wait_for_message(IMAGE_NAME, timeout=WAIT)
    transform = client.wait_for_message(TRANSFORM_NAME, timeout=WAIT)
    assert image is not None and transform is not None
    return image, transform


def corners_mm(image: pyigtl.ImageMessage) -> np.ndarray:
    """Where the message's own matrix puts the four corner pixel centres (mm)."""
    rows, cols = image.image.shape[1:3]
    i, j = frame_corners((rows, cols))
    ijk = np.stack([i, j, np.zeros(4), np.ones(4)])
    return (image.ijk_to_world_matrix @ ijk)[:3].T


def test_frames_arrive_as_plus_sends_them_and_corners_land_where_the_sweep_says():
    sweep = sample_sweep(n=5, rows=32, cols=48, seed=3)
    with IgtlServer(sweep.image_to_probe, port=0) as server, igtl_client(server.port) as client:
        assert server.host == "127.0.0.1"
        assert server.wait_for_client(WAIT) and server.clients == 1
        for index in range(len(sweep)):
            before = time.time()
            server.append(sweep.frame(index))
            image, transform = receive(client)
            # the frame itself: one 8-bit slice, (k, j, i) = (1, rows, cols), unchanged
            assert image.image.dtype == np.uint8 and image.image.shape == (1, 32, 48)
            np.testing.assert_array_equal(image.image[0], sweep.frames[index])
            # ProbeToReference in millimetres (float32 on the wire)
            expected = sweep.probe_to_base[index].copy()
            expected[:3, 3] *= 1000
            np.testing.assert_allclose(transform.matrix, expected, atol=1e-4)
            # the corners, through the message's own IJK-to-world matrix, at the Sweep's
            world = 1000 * pixels_to_world(
                sweep.probe_to_base[index], sweep.image_to_probe, *frame_corners((32, 48))
            )
            assert np.abs(corners_mm(image) - world).max() < 0.01
            # both stamped at sending, with one timestamp
            assert image.timestamp == transform.timestamp
            assert before - 1e-3 <= image.timestamp <= time.time() + 1e-3
            assert image.world_coordinate_system == "ras"
        assert server.frames == len(sweep) and server.dropped == 0


def test_a_client_that_hangs_up_is_forgotten_and_the_stream_goes_on():
    sweep = sample_sweep(n=3, rows=32, cols=48)
    with IgtlServer(sweep.image_to_probe, port=0) as server:
        quitter = socket.create_connection(("127.0.0.1", server.port), timeout=WAIT)
        assert server.wait_for_client(WAIT)
        quitter.close()
        deadline = time.monotonic() + WAIT
        while server.clients and time.monotonic() < deadline:
            server.append(sweep.frame(0))  # nobody left to send to: must not block or fail
            time.sleep(0.01)
        assert server.clients == 0
        with igtl_client(server.port) as client:
            assert server.wait_for_client(WAIT)
            server.append(sweep.frame(2))
            image, _ = receive(client)
            np.testing.assert_array_equal(image.image[0], sweep.frames[2])


def replay_in_thread(sweep, **options) -> tuple[threading.Thread, dict, threading.Event]:
    """`stream_sweep` on a free port in a thread; returns it, its outcome and its stop event."""
    ready = threading.Event()
    outcome: dict = {}
    stop = threading.Event()

    def on_ready(server: IgtlServer) -> None:
        outcome["port"] = server.port
        ready.set()

    def run() -> None:
        try:
            outcome["sent"] = stream_sweep(sweep, 0, stop=stop, on_ready=on_ready, **options)
        except Exception as error:  # reported by the test
            outcome["error"] = error
            ready.set()

    thread = threading.Thread(target=run)
    thread.start()
    assert ready.wait(WAIT) and "error" not in outcome, outcome
    return thread, outcome, stop


def collect(port: int, count: int | None = None) -> list:
    """Frames the replay on `port` sends, received by the project's OpenIGTLink client, which
    keeps every frame (pyigtl's keeps only the newest of a name, so a busy machine would lose
    some): `count` of them, or all until the replay ends."""
    from resus.acquisition.backends.igtl import IgtlProbe, IgtlProbeConfig, ProbeLinkLost

    frames: list = []
    deadline = time.monotonic() + 6 * WAIT
    with IgtlProbe(IgtlProbeConfig(port=port, timeout=6 * WAIT)) as client:
        try:
            while (count is None or len(frames) < count) and time.monotonic() < deadline:
                frames += client.poll()
                time.sleep(0.005)
        except ProbeLinkLost:  # the replay ended and closed the connection
            pass
    return frames


def test_a_file_replays_at_its_recorded_timing(tmp_path):
    from resus.sweep.io import write_sweep

    sweep = sample_sweep(n=6, rows=32, cols=48, seed=5)  # 50-60 ms apart
    write_sweep(tmp_path / "sweep.h5", sweep)
    thread, outcome, _ = replay_in_thread(tmp_path / "sweep.h5", speed=2.0)
    connecting_at = time.monotonic()  # the replay starts once the client has connected
    try:
        frames = collect(outcome["port"])
    finally:
        thread.join(WAIT)
    assert not thread.is_alive() and outcome["sent"] == len(sweep)
    np.testing.assert_array_equal(np.stack([frame.image for frame in frames]), sweep.frames)
    # stamped at the recorded times, twice as fast; and sent no sooner than that
    stamps = np.array([frame.sent_at for frame in frames])
    expected = (sweep.timestamps - sweep.timestamps[0]) / 2.0
    np.testing.assert_allclose(stamps - stamps[0], expected, atol=1e-6)
    # Measured from before the client connected, not from the first frame's arrival: a
    # client that reads the first frame late would make the others look early. The clock
    # reads (monotonic, same process) allow 1 ms.
    received = np.array([frame.timestamp for frame in frames])  # on arrival (monotonic)
    assert np.all(received - connecting_at >= expected - 0.001)


def test_loop_starts_over_until_stopped():
    sweep = sample_sweep(n=3, rows=32, cols=48, seed=6)
    thread, outcome, stop = replay_in_thread(sweep, loop=True, speed=2.0)
    try:
        frames = collect(outcome["port"], 2 * len(sweep) + 1)
    finally:
        stop.set()
        thread.join(WAIT)
    assert not thread.is_alive() and outcome["sent"] >= 2 * len(sweep) + 1
    order = [int(np.argmax([np.array_equal(f.image, s) for s in sweep.frames])) for f in frames]
    assert order == [0, 1, 2, 0, 1, 2, 0]
    stamps = np.array([frame.sent_at for frame in frames])
    assert np.all(np.diff(stamps) > 0)  # one clock across the loops


@pytest.mark.parametrize("port", [70000, -1, 1.5, "18944"])
def test_an_out_of_range_port_is_one_line(port):
    with pytest.raises(ResusError, match=r"OpenIGTLink port must be an integer in 0\.\.65535"):
        IgtlServer(np.eye(4), port=port)


def test_a_port_in_use_is_one_line_naming_it():
    with socket.create_server(("127.0.0.1", 0)) as taken:
        port = taken.getsockname()[1]
        with pytest.raises(ResusError) as error:
            IgtlServer(np.eye(4), port=port)
    message = str(error.value)
    assert message == f"OpenIGTLink server cannot listen on 127.0.0.1:{port}: " + (
        "the port is already in use (another server?)"
    )


def test_a_bad_speed_or_host_is_one_line():
    sweep = sample_sweep(n=2)
    with pytest.raises(ResusError, match="replay speed must be a positive number, got 0"):
        stream_sweep(sweep, 0, speed=0)
    with pytest.raises(ResusError, match="is not an address of this machine"):
        IgtlServer(np.eye(4), port=0, host="192.0.2.1")
