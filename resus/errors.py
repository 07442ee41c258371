"""The one exception type the command line turns into a one-line message, and the one place
where the simulator's errors become it."""

from __future__ import annotations

from collections.abc import Collection, Iterator
from contextlib import contextmanager
from pathlib import Path


class ResusError(Exception):
    """A problem the user can fix: bad input, a missing file, an unsafe plan.

    The message is one line that names the file or argument and the problem; the CLI prints
    it as `error: <message>` and exits non-zero, without a traceback.
    """

    def __init__(self, message: str, path: str | Path | None = None) -> None:
        self.path = None if path is None else Path(path)
        super().__init__(f"{path}: {message}" if path is not None else message)


def check_choice(setting: str, value: object, choices: Collection[str]) -> None:
    """Raise a ResusError naming `setting` (e.g. `ScanSettings.grid`) unless `value` is one of
    `choices`: one wording for every closed set of names in the library."""
    if value not in choices:
        raise ResusError(f"{setting} must be one of {', '.join(choices)}, got {value!r}")


@contextmanager
def simulator_errors(context: str | None = None) -> Iterator[None]:
    """Turn a `ValueError` from `sim` (a bad phantom spec, scene or setting) into a ResusError.

    `sim` knows nothing of `resus`, so it raises plain `ValueError`s with one-line messages;
    this is where they cross into the pipeline, prefixed with `context` when given.
    """
    try:
        yield
    except ValueError as error:
        raise ResusError(f"{context}: {error}" if context else str(error)) from None
