"""The `resus` command line: one sub-command per pipeline stage.

Each module in `resus.cli` registers its commands on the root app with `register(app)`
and imports its heavy dependencies (torch, mujoco) inside the command, so `resus --help`
stays fast. A `ResusError` anywhere becomes one line on stderr and exit status 2.
"""

from __future__ import annotations

import importlib
import sys

import typer

from resus.errors import ResusError

COMMAND_MODULES: tuple[str, ...] = (
    "resus.cli.demo",
    "resus.cli.sweep",
    "resus.cli.simulate",
    "resus.cli.reconstruct",
    "resus.cli.reslice",
    "resus.cli.train",
    "resus.cli.emulate",
    "resus.cli.view",
    "resus.cli.plan",
    "resus.cli.scan",
    "resus.cli.calibrate_time",
    "resus.cli.vessels",
    "resus.cli.experiment",
)

app = typer.Typer(
    name="resus",
    help="RESUS testbed: simulate, scan, reconstruct, reslice, segment and map vessels.",
    no_args_is_help=True,
    add_completion=False,
    pretty_exceptions_enable=False,
)

for module_name in COMMAND_MODULES:
    importlib.import_module(module_name).register(app)


def main() -> None:
    """Console-script entry point: run the app, turning user errors into one line."""
    try:
        status = app(standalone_mode=False)
    except ResusError as error:
        print(f"error: {error}", file=sys.stderr)
        sys.exit(2)
    except KeyboardInterrupt:
        print("error: interrupted", file=sys.stderr)
        sys.exit(130)
    except typer.Exit as done:
        sys.exit(done.exit_code)
    except Exception as error:  # click usage errors carry their own exit code and message
        import click

        if isinstance(error, click.exceptions.ClickException):
            error.show()
            sys.exit(error.exit_code)
        if isinstance(error, click.exceptions.Abort):
            print("error: aborted", file=sys.stderr)
            sys.exit(1)
        raise
    sys.exit(status if isinstance(status, int) else 0)
