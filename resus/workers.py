"""Worker processes, in one place: how many cores there are, and a parallel map over them.

Workers are spawned, not forked: MuJoCo, numba and torch hold threads and state that a
forked child would inherit half-initialised.
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
    """`function(item)` for every item, in order, `jobs` spawned processes at a time, with a
    progress bar; with `jobs <= 1` or a single item, in this process.

    `function` must be importable at module level (the workers import it by name).
    """
    import multiprocessing
    from concurrent.futures import ProcessPoolExecutor

    from tqdm import tqdm

    bar = {"total": len(items), "desc": desc, "unit": unit, "disable": not progress}
    if jobs <= 1 or len(items) <= 1:
        return [function(item) for item in tqdm(items, **bar)]
    context = multiprocessing.get_context("spawn")
    with ProcessPoolExecutor(max_workers=min(jobs, len(items)), mp_context=context) as pool:
        return list(tqdm(pool.map(function, items), **bar))
