"""The `resus` command line: one sub-command per pipeline stage.

Each module in `resus.cli` registers its commands on the root app with `register(app)`
and imports its heavy dependencies (torch, mujoco) inside the command, so `resus --help`
stays fast. Every error the user can fix ends the same way: one `error: ...` line on stderr
(a usage error adds click's "Try 'resus CMD --help' for help." line) and exit status 2,
never a traceback.
"""

from __future__ import annotations

import importlib
import os
import signal
import sys
from types import ModuleType
from typing import Annotated, NoReturn

import typer

from resus import __version__
from resus.errors import ResusError

COMMAND_MODULES: tuple[str, ...] = (
    "resus.cli.demo",
    "resus.cli.sweep",
    "resus.cli.simulate",
    "resus.cli.reconstruct",
    "resus.cli.reslice",
    "resus.cli.train",
    "resus.cli.evaluate",
    "resus.cli.emulate",
    "resus.cli.view",
    "resus.cli.plan",
    "resus.cli.scan",
    "resus.cli.calibrate_time",
    "resus.cli.vessels",
    "resus.cli.experiment",
    "resus.cli.realism",
)
USAGE_STATUS = 2
INTERRUPTED_STATUS = 130

app = typer.Typer(
    name="resus",
    no_args_is_help=True,
    add_completion=False,
    pretty_exceptions_enable=False,
)


def _show_version(show: bool) -> None:
    """`--version`: print it and stop before any command runs."""
    if show:
        typer.echo(f"resus {__version__}")
        raise typer.Exit()


@app.callback()
def _root(
    version: Annotated[
        bool,
        typer.Option(
            "--version", is_eager=True, callback=_show_version, help="Print the version and exit."
        ),
    ] = False,
) -> None:
    """RESUS testbed: simulate, scan, reconstruct, reslice, segment and map vessels."""


for module_name in COMMAND_MODULES:
    importlib.import_module(module_name).register(app)


def click_exceptions() -> ModuleType:
    """The exceptions module of the click that typer runs on: its own vendored copy
    (`typer._click`, typer >= 0.29) or else the `click` package."""
    vendored = getattr(typer.main, "_click", None)
    if vendored is not None:
        return vendored.exceptions
    import click

    return click.exceptions


def _fail(message: str, hint: str | None = None, status: int = USAGE_STATUS) -> NoReturn:
    """One `error:` line (whitespace folded, so it is one line), an optional hint, exit."""
    print(f"error: {' '.join(message.split())}", file=sys.stderr)
    if hint:
        print(hint, file=sys.stderr)
    sys.exit(status)


def _usage_hint(error: Exception) -> str | None:
    """Click's "Try 'resus CMD --help' for help." for the command the usage error is about."""
    context = getattr(error, "ctx", None)
    if context is None or context.command.get_help_option(context) is None:
        return None
    return f"Try '{context.command_path} {context.help_option_names[0]}' for help."


def _interrupt(signum: int, frame: object) -> None:
    """A SIGTERM handler: raise KeyboardInterrupt, so context managers and `finally` blocks
    close what the command opened (a served viewer's process, a sweep file) before it exits."""
    raise KeyboardInterrupt


def main() -> None:
    """Console-script entry point: parse `sys.argv`, run the command, exit with its status.

    The command is parsed and invoked here rather than through typer's standalone `main`,
    so every exception reaches the handlers below as raised, whatever typer's version does
    with it (typer 0.29 turns Ctrl-C into a silent exit status, older ones into Abort).
    """
    exceptions = click_exceptions()
    command = typer.main.get_command(app)
    signal.signal(signal.SIGTERM, _interrupt)  # `kill` cleans up like Ctrl-C: servers, files
    try:
        with command.make_context("resus", sys.argv[1:]) as context:
            command.invoke(context)
    except ResusError as error:
        _fail(str(error))
    except typer.Exit as done:
        sys.exit(done.exit_code)
    except (KeyboardInterrupt, typer.Abort):
        _fail("interrupted", status=INTERRUPTED_STATUS)
    except exceptions.UsageError as error:
        no_args_is_help = getattr(exceptions, "NoArgsIsHelpError", None)  # not in every click
        if no_args_is_help is not None and isinstance(error, no_args_is_help):
            help_text = error.format_message()  # empty when rich has printed the help already
            if help_text:
                typer.echo(help_text)
            sys.exit(error.exit_code)
        _fail(error.format_message(), _usage_hint(error), error.exit_code)
    except exceptions.ClickException as error:  # e.g. a typer.FileText that cannot be opened
        _fail(error.format_message(), status=error.exit_code)
    except BrokenPipeError:  # whoever read stdout has gone (`resus --help | head`)
        os.dup2(os.open(os.devnull, os.O_WRONLY), sys.stdout.fileno())  # no error at exit
        sys.exit(1)
    sys.exit(0)
