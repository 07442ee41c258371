"""The one exception type the command line turns into a one-line message."""

from __future__ import annotations

from pathlib import Path


class ResusError(Exception):
    """A problem the user can fix: bad input, a missing file, an unsafe plan.

    The message is one line that names the file or argument and the problem; the CLI prints
    it as `error: <message>` and exits non-zero, without a traceback.
    """

    def __init__(self, message: str, path: str | Path | None = None) -> None:
        self.path = None if path is None else Path(path)
        super().__init__(f"{path}: {message}" if path is not None else message)
