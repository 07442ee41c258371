"""Run the emulator as a process: build the arm, bind the servers, print one ready line.

`resus emulate` and `python -m sim.rtde` both end up in `serve()`. The process exits
cleanly on SIGINT or SIGTERM, closing every socket.
"""

from __future__ import annotations

import argparse
import logging
import signal
import sys
import threading

from sim.rtde.arm import EmulatedArm, KinematicArm
from sim.rtde.controller import Controller
from sim.rtde.faults import FaultPlan
from sim.rtde.server import Emulator, Ports

ARMS = ("mujoco", "kinematic")


def build_arm(kind: str, scene: str | None) -> EmulatedArm:
    """The simulated arm: "mujoco" (physics, the phantom of `scene`) or "kinematic"."""
    if kind == "kinematic":
        return KinematicArm()
    if kind == "mujoco":
        from sim.rtde.mujoco_arm import MujocoArm

        return MujocoArm.from_scene(scene)
    raise ValueError(f"--arm must be one of {ARMS}, got {kind!r}")


def ready_line(emulator: Emulator) -> str:
    ports = emulator.ports
    return (
        f"emulator ready on {emulator.host}: dashboard {ports.dashboard}, rtde {ports.rtde}, "
        f"script {ports.script}"
    )


def serve(
    host: str = "127.0.0.1",
    port_base: int = 0,
    arm: str = "mujoco",
    scene: str | None = None,
    faults: FaultPlan | None = None,
) -> None:
    """Bind, print the ready line, run the control loop until SIGINT/SIGTERM."""
    emulator = Emulator(
        Controller(build_arm(arm, scene)), host, Ports(port_base), faults or FaultPlan()
    )
    emulator.open()
    stop = threading.Event()

    def _stop(*_: object) -> None:
        stop.set()
        emulator.stop()

    signal.signal(signal.SIGTERM, _stop)
    signal.signal(signal.SIGINT, _stop)
    loop = threading.Thread(target=emulator.run, name="control-loop", daemon=True)
    print(ready_line(emulator), flush=True)
    loop.start()
    while not stop.wait(0.2):
        if not loop.is_alive():
            break
    emulator.stop()
    loop.join(timeout=2.0)


def parser() -> argparse.ArgumentParser:
    arguments = argparse.ArgumentParser(prog="python -m sim.rtde", description=__doc__)
    arguments.add_argument("--host", default="127.0.0.1")
    arguments.add_argument("--port-base", type=int, default=0, help="added to every UR port")
    arguments.add_argument("--arm", choices=ARMS, default="mujoco")
    arguments.add_argument("--scene", default=None, help="scene YAML path or name (mujoco arm)")
    arguments.add_argument("--fault", action="append", default=[], help="see sim.rtde.faults")
    arguments.add_argument("--seed", type=int, default=0, help="seed of the jitter fault")
    arguments.add_argument("--log-level", default="INFO")
    return arguments


def main(argv: list[str] | None = None) -> None:
    args = parser().parse_args(argv)
    logging.basicConfig(
        level=args.log_level.upper(),
        stream=sys.stderr,
        format="rtde-emulator %(levelname)s: %(message)s",
    )
    try:
        faults = FaultPlan.parse(args.fault, seed=args.seed)
        Ports(args.port_base)
    except ValueError as error:
        parser().error(str(error))
    serve(args.host, args.port_base, args.arm, args.scene, faults)
