"""`resus sweep stream`, and `--igtl` on `scan` and `simulate`: a sweep replays over the real
command line to a client; bad ports and flags are one line (in this process, as a user's
shell would show them)."""

from __future__ import annotations

import re
import socket
import subprocess
import sys
import time
from typing import NamedTuple

import numpy as np
import pytest
from cli_runner import free_port, one_line_error, run_main
from sweep_samples import sample_sweep

from resus.acquisition.backends.igtl import IgtlProbe, IgtlProbeConfig, ProbeLinkLost
from resus.acquisition.backends.simulated import SimulatedProbeConfig
from resus.acquisition.patterns import LinearPattern
from resus.acquisition.probe import Frame
from resus.acquisition.simulation import phantom_spec, resolve_scene
from resus.cli.scan import parse_probe
from resus.errors import ResusError
from resus.sweep.io import read_sweep, write_sweep
from sim.phantom import Phantom

WAIT = 10.0
FIRST_FRAME = 60.0
"""A simulated scan builds the robot and approaches before its first frame."""


class Streamed(NamedTuple):
    """What a client of a streaming command received, and how the command ended."""

    line: str
    """The line the command printed once it listened."""
    frames: list[Frame]
    image_to_probe: np.ndarray
    returncode: int
    stdout: str
    stderr: str


def receive_stream(command: list[str], first_frame: float = WAIT) -> Streamed:
    """Run `command`, which prints a line naming 127.0.0.1:PORT once it listens and then
    streams; take every frame from the moment of connecting until the server closes."""
    pipes = {"stdout": subprocess.PIPE, "stderr": subprocess.PIPE, "text": True}
    with subprocess.Popen(command, **pipes) as run:
        try:
            address = None
            while address is None:  # what it prints before it listens (e.g. scan's plan)
                line = run.stdout.readline()
                assert line, "ended before listening"
                address = re.search(r"on 127\.0\.0\.1:(\d+)", line)
            frames: list[Frame] = []
            with (
                IgtlProbe(IgtlProbeConfig(port=int(address[1]), timeout=first_frame)) as probe,
                pytest.raises(ProbeLinkLost, match="the server closed the connection"),
            ):
                while True:
                    frames += probe.poll()
                    time.sleep(0.005)
            out, err = run.communicate(timeout=WAIT)
        finally:
            if run.poll() is None:
                run.kill()
                run.wait(WAIT)
    return Streamed(line, frames, probe.image_to_probe, run.returncode, out, err)


def test_stream_replays_a_sweep_to_a_client(tmp_path):
    sweep = sample_sweep(n=4, rows=32, cols=48, seed=51)
    write_sweep(tmp_path / "scan.h5", sweep)
    port = free_port()
    streamed = receive_stream(
        [sys.executable, "-m", "resus", "sweep", "stream", str(tmp_path / "scan.h5"),
         "--igtl", str(port), "--speed", "2"]
    )  # fmt: skip
    assert "serving 4 frames" in streamed.line and f"on 127.0.0.1:{port}" in streamed.line
    assert streamed.returncode == 0, streamed.stderr
    assert "sent 4 frames" in streamed.stdout
    np.testing.assert_array_equal(np.stack([f.image for f in streamed.frames]), sweep.frames)
    np.testing.assert_allclose(streamed.image_to_probe, sweep.image_to_probe, atol=1e-7)


def test_bad_ports_and_flags_are_one_line(monkeypatch, capsys, tmp_path):
    write_sweep(tmp_path / "scan.h5", sample_sweep(n=2))
    run = (monkeypatch, capsys)
    stream = ["sweep", "stream", tmp_path / "scan.h5", "--igtl"]
    one_line_error(
        run_main(*run, *stream, 70000), "--igtl must be an integer in 0..65535, got 70000"
    )
    with socket.create_server(("127.0.0.1", 0)) as taken:
        port = taken.getsockname()[1]
        one_line_error(
            run_main(*run, *stream, port),
            f"OpenIGTLink server cannot listen on 127.0.0.1:{port}: the port is already in use",
        )
    one_line_error(run_main(*run, *stream, 0, "--speed", "0"), "--speed must be positive, got 0.0")
    scan = ["scan", "--robot", "sim", "--trajectory", "t.yaml", "--out", tmp_path / "s.h5"]
    one_line_error(
        run_main(*run, *scan, "--probe", "sim", "--igtl", 70000),
        "--igtl must be an integer in 0..65535",
    )
    one_line_error(
        run_main(*run, *scan, "--probe", "igtl://127.0.0.1:18944"),
        "--probe igtl needs a real robot clock: use --robot HOST",
    )
    one_line_error(
        run_main(*run, "simulate", "--subjects", "0-1", "--out", tmp_path, "--igtl", 18944),
        "--igtl streams one sweep: not with --subjects",
    )


def test_probe_flag_for_an_igtl_server(tmp_path):
    config = parse_probe("igtl://10.0.0.7:18945", 30.0, tmp_path / "probe.yaml", None)
    assert config == IgtlProbeConfig(
        host="10.0.0.7", port=18945, calibration=tmp_path / "probe.yaml"
    )
    assert parse_probe("igtl://127.0.0.1:18944", 30.0, None, None).calibration is None
    for text, crop, message in (
        (
            "igtl://nowhere",
            None,
            "--probe: expected igtl://HOST:PORT (e.g. igtl://127.0.0.1:18944)",
        ),
        ("igtl://h:99999", None, "--probe igtl port must be an integer in 1..65535, got 99999"),
        ("igtl://h:1", "0,0,4,4", "--crop applies to --probe video only"),
        ("usb", None, "--probe: expected sim, sim:COLSxROWS or video:DEVICE|URL|FILE, or igtl://"),
    ):
        with pytest.raises(ResusError) as error:
            parse_probe(text, 30.0, None, crop)
        assert message in str(error.value)


def test_simulate_streams_its_frames_placed_as_its_sweep_file_places_them(tmp_path):
    """`resus simulate --igtl` sends the frames it records with the calibration of the sweep it
    writes. A scanner preset sets the image depth, so the stream cannot assume the probe's
    default geometry: it did, and placed a `vascular` sweep's rows 25 % too deep."""
    out = tmp_path / "sweep.h5"
    streamed = receive_stream(
        [sys.executable, "-m", "resus", "simulate", "--out", str(out), "--length", "0.004",
         "--frame-rate", "10", "--scanner", "vascular", "--igtl", "0"],
        first_frame=FIRST_FRAME,
    )  # fmt: skip
    assert streamed.line.startswith("streaming OpenIGTLink on 127.0.0.1:"), streamed.line
    assert streamed.returncode == 0, streamed.stderr
    sweep = read_sweep(out)
    default = SimulatedProbeConfig().probe.image_to_probe()
    assert not np.allclose(sweep.image_to_probe, default, atol=1e-7)  # the preset's depth
    np.testing.assert_allclose(streamed.image_to_probe, sweep.image_to_probe, atol=1e-7)
    assert 1 <= len(streamed.frames) <= len(sweep)  # those from the moment it connected
    received = np.stack([frame.image for frame in streamed.frames])
    np.testing.assert_array_equal(received, sweep.frames[len(sweep) - len(received) :])


def test_scan_streams_its_frames_placed_as_its_sweep_file_places_them(tmp_path):
    """`resus scan --igtl` sends each frame it records, placed by its probe's calibration."""
    scene, plan, out = resolve_scene("default", None, None), tmp_path / "p.yaml", tmp_path / "s.h5"
    pattern = LinearPattern(length=0.004, speed=0.01, frame_rate=10.0, contact_force=None)
    pattern.trajectory(Phantom(phantom_spec(scene)), scene.phantom_to_base).to_yaml(plan)
    streamed = receive_stream(
        [sys.executable, "-m", "resus", "scan", "--robot", "sim", "--probe", "sim:48x32",
         "--trajectory", str(plan), "--out", str(out), "--yes", "--igtl", "0"],
        first_frame=FIRST_FRAME,
    )  # fmt: skip
    assert streamed.returncode == 0, streamed.stderr
    sweep = read_sweep(out)
    assert sweep.frames.shape[1:] == (32, 48)
    np.testing.assert_allclose(streamed.image_to_probe, sweep.image_to_probe, atol=1e-7)
    assert 1 <= len(streamed.frames) <= len(sweep)
    received = np.stack([frame.image for frame in streamed.frames])
    np.testing.assert_array_equal(received, sweep.frames[len(sweep) - len(received) :])
