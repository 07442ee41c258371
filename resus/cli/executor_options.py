"""`--executor` and `--address`, shared by the commands whose units can run on a Ray cluster
(`simulate --subjects`, `experiment ...`), and their check before any work starts."""

from __future__ import annotations

from typing import Annotated

import typer

from resus.cli.parsers import flag_error

ExecutorOption = Annotated[
    str,
    typer.Option(help="Where the units run: local (worker processes here) or ray (a cluster)."),
]
JobsOption = Annotated[
    int, typer.Option(min=1, help="Local worker processes (or the CPUs of a Ray started here).")
]
AddressOption = Annotated[
    str | None,
    typer.Option(
        help="With --executor ray: the cluster, auto, ray://HOST:10001 or HOST:6379; "
        "without it, a Ray of --jobs CPUs started here, on 127.0.0.1 only."
    ),
]


def check_executor_flags(executor: str, address: str | None) -> None:
    """Refuse an unknown `--executor`, an `--address` without ray, or an address of the wrong
    form or where nothing answers: one line naming the flag, before anything runs."""
    from resus.execution import check_address, check_executor

    with flag_error("--executor"):
        check_executor(executor)
    with flag_error("--address"):
        check_executor(executor, address)
        check_address(address)
