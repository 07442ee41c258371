"""What "now" is in the files the testbed writes: the clock, or SOURCE_DATE_EPOCH's time."""

from __future__ import annotations

import os
from datetime import UTC, datetime

from resus.errors import ResusError

SOURCE_DATE_EPOCH = "SOURCE_DATE_EPOCH"
"""Environment variable (the reproducible-builds convention): seconds since 1970 that stand
for "now" in every file the testbed writes, so two runs of the same inputs write byte-identical
files instead of files that differ only in their creation times."""


def now() -> datetime:
    """The current UTC time, or SOURCE_DATE_EPOCH's when the environment sets it."""
    epoch = os.environ.get(SOURCE_DATE_EPOCH)
    if epoch is None:
        return datetime.now(UTC)
    try:
        return datetime.fromtimestamp(int(epoch), UTC)
    except (ValueError, OverflowError):
        message = f"{SOURCE_DATE_EPOCH} must be whole seconds since 1970, got {epoch!r}"
        raise ResusError(message) from None


def now_iso() -> str:
    """`now()` as an ISO 8601 string with its UTC offset, to the second."""
    return now().isoformat(timespec="seconds")
