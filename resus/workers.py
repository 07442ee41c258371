"""How many cores this process may use, and the old name of the local engine's map.

Where units run is `resus.execution`'s business (worker processes of this machine, or Ray);
`map_in_processes` is `LocalExecutor.map`, for callers not yet given an executor.
"""

from __future__ import annotations

import os
from collections.abc import Callable, Sequence
from typing import TypeVar

Item = TypeVar("Item")
Result = TypeVar("Result")


def available_cores() -> int:
    """CPU cores this process may run on (its affinity mask where the OS has one)."""
    if hasattr(os, "sched_getaffinity"):
        return len(os.sched_getaffinity(0))
    return os.cpu_count() or 1


def map_in_processes(
    function: Callable[[Item], Result],
    items: Sequence[Item],
    jobs: int,
    desc: str,
    unit: str,
    progress: bool = True,
) -> list[Result]:
    """`function(item)` for every item, in order, on `LocalExecutor(jobs)` (in this process
    when `jobs <= 1` or there is one item)."""
    from resus.execution.local import LocalExecutor

    return LocalExecutor(max(1, jobs)).map(function, items, desc, unit, progress=progress)
