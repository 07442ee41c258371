"""`resus emulate` itself (the other emulator tests start `python -m sim.rtde`): it serves
ur_rtde until interrupted, and an address in use or a scene it cannot build is one line."""

from __future__ import annotations

import signal
import subprocess
import sys

import numpy as np
import pytest
import rtde_receive

from sim.robot.ur3e import HOME_JOINTS
from sim.rtde.launch import START_TIMEOUT, free_host

pytestmark = pytest.mark.slow  # emulator processes

STOP_TIMEOUT = 10.0


def emulate(host: str, *args: str) -> list[str]:
    return [sys.executable, "-m", "resus", "emulate", "--host", host, *args]


def test_serves_ur_rtde_until_interrupted_and_an_address_in_use_is_one_line() -> None:
    host = free_host()
    pipes = {"stdout": subprocess.PIPE, "stderr": subprocess.PIPE, "text": True}
    with subprocess.Popen(emulate(host, "--arm", "kinematic"), **pipes) as run:
        try:
            ready = run.stdout.readline()  # the kinematic arm needs no scene: ready at once
            assert ready == f"emulator ready on {host}: dashboard 29999, rtde 30004, script 30003\n"
            receive = rtde_receive.RTDEReceiveInterface(host)
            try:
                np.testing.assert_allclose(receive.getActualQ(), HOME_JOINTS, atol=1e-9)
            finally:
                receive.disconnect()

            second = subprocess.run(
                emulate(host, "--arm", "kinematic"), capture_output=True, text=True,
                timeout=START_TIMEOUT,
            )  # fmt: skip
            assert second.returncode == 2
            assert second.stderr.startswith(f"error: --host {host} --port-base 0: cannot listen (")
            assert len(second.stderr.splitlines()) == 1, second.stderr

            run.send_signal(signal.SIGINT)  # Ctrl-C
            _, err = run.communicate(timeout=STOP_TIMEOUT)
        finally:
            if run.poll() is None:
                run.kill()
                run.wait(STOP_TIMEOUT)
    assert run.returncode == 0, err
    assert "Traceback" not in err


def test_a_scene_it_cannot_build_is_one_line(tmp_path) -> None:
    missing = tmp_path / "nosuch.yaml"
    done = subprocess.run(
        emulate(free_host(), "--scene", str(missing)), capture_output=True, text=True,
        timeout=START_TIMEOUT,
    )  # fmt: skip
    assert done.returncode == 2
    assert done.stderr.startswith(f"error: --scene {missing}: "), done.stderr
    assert str(missing) in done.stderr and len(done.stderr.splitlines()) == 1
