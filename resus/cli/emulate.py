"""`resus emulate`: serve UR's dashboard, RTDE and script protocols from the simulated UR3e."""

from __future__ import annotations

from typing import Annotated

import typer

from resus.cli.parsers import flag_error, parse_choice
from resus.errors import ResusError


def register(app: typer.Typer) -> None:
    """Add the `emulate` command to the root app."""

    @app.command()
    def emulate(
        host: Annotated[str, typer.Option(help="Address to listen on.")] = "127.0.0.1",
        port_base: Annotated[
            int, typer.Option(help="Added to every UR port (ur_rtde's RTDE clients need 0).")
        ] = 0,
        scene: Annotated[
            str, typer.Option(help="Scene name in assets/scenes/ or a scene YAML path.")
        ] = "default",
        arm: Annotated[
            str, typer.Option(help="'mujoco' (physics, phantom contact) or 'kinematic'.")
        ] = "mujoco",
        fault: Annotated[
            list[str] | None,
            typer.Option(
                help="Injected fault, repeatable: drop@T, drop@T+D, protective-stop@T, "
                "latency=L, jitter=J (seconds). T on the emulator clock, or motion+S: S "
                "seconds after the first motion command (e.g. protective-stop@motion+6)."
            ),
        ] = None,
        seed: Annotated[int, typer.Option(help="Seed of the jitter fault.")] = 0,
    ) -> None:
        """Run the RTDE emulator until Ctrl-C; prints one line when it is ready."""
        import logging
        import sys

        from sim.rtde.app import ARMS, serve
        from sim.rtde.faults import FaultPlan
        from sim.rtde.server import Ports

        parse_choice(arm, "--arm", ARMS)
        with flag_error("--port-base"):
            Ports(port_base)
        with flag_error("--fault"):
            faults = FaultPlan.parse(fault or [], seed=seed)
        logging.basicConfig(
            level=logging.INFO, stream=sys.stderr, format="rtde-emulator %(levelname)s: %(message)s"
        )
        try:
            serve(host, port_base, arm, None if arm == "kinematic" else scene, faults)
        except OSError as error:
            raise ResusError(
                f"--host {host} --port-base {port_base}: cannot listen ({error})"
            ) from None
        except ValueError as error:
            raise ResusError(f"--scene {scene}: {error}") from None
