"""A simulated scan streamed live: `simulate_sweep(listeners=[IgtlServer])` sends every frame
the scanner records, as it records it; what a client receives is the Sweep written to disk."""

from __future__ import annotations

import threading
import time

import numpy as np

from resus.acquisition.backends.igtl import IgtlProbe, IgtlProbeConfig, ProbeLinkLost
from resus.acquisition.backends.simulated import SimulatedProbeConfig
from resus.acquisition.patterns import LinearPattern
from resus.acquisition.simulation import resolve_scene, simulate_sweep
from resus.sweep.igtl import IgtlServer
from resus.sweep.io import read_sweep
from sim.ultrasound.probe import LinearProbe

WAIT = 10.0
FIRST_FRAME = 60.0
"""The simulator builds the robot and approaches before the first frame: minutes on a busy
machine would still pass."""


def test_a_simulated_scan_streams_every_frame_live(tmp_path):
    probe = SimulatedProbeConfig(probe=LinearProbe(cols=48, rows=32), frame_rate=20.0)
    pattern = LinearPattern(length=0.004, speed=0.01, contact_force=None, frame_rate=20.0)
    received: list = []
    outcome: dict = {}

    def receive(port: int) -> None:
        try:
            with IgtlProbe(IgtlProbeConfig(port=port, timeout=FIRST_FRAME)) as client:
                outcome["image_to_probe"] = client.image_to_probe
                while True:
                    received.extend(client.poll())
                    time.sleep(0.005)
        except ProbeLinkLost:  # the server closed after the scan: every frame is in
            pass
        except Exception as error:  # reported below
            outcome["error"] = error

    with IgtlServer(probe.probe.image_to_probe(), port=0) as server:
        receiver = threading.Thread(target=receive, args=(server.port,))
        receiver.start()
        try:
            assert server.wait_for_client(WAIT)
            result = simulate_sweep(
                tmp_path / "sweep.h5", resolve_scene("default", None, None), pattern,
                probe=probe, progress=False, listeners=[server],
            )  # fmt: skip
        finally:
            server.close()
            receiver.join(WAIT)
    assert not receiver.is_alive() and "error" not in outcome, outcome
    sweep = read_sweep(tmp_path / "sweep.h5")
    assert len(sweep) == result.frames == len(received) >= 5
    np.testing.assert_array_equal(np.stack([frame.image for frame in received]), sweep.frames)
    tracked = np.stack([frame.tracker_pose for frame in received])
    np.testing.assert_allclose(tracked, sweep.probe_to_base, atol=1e-7)
    np.testing.assert_allclose(outcome["image_to_probe"], sweep.image_to_probe, atol=1e-7)
    assert server.frames == len(sweep) and server.dropped == 0
