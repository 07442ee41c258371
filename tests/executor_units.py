"""Units of work for the executor tests, shared by the local and the Ray engine's tests.

They live in a module of their own so that a worker can import them by name (a spawned local
worker) or receive them by value (a Ray worker: `test_ray_engine.py` registers this module).
"""

from __future__ import annotations

from pathlib import Path

from resus.acquisition.scanner import ScanAborted, ScanResult
from resus.errors import ResusError
from resus.execution import granted_cpus


def granted(_: object) -> int | None:
    """A unit that reports the cores its engine granted it."""
    return granted_cpus()


def refuse(item: int) -> int:
    """A unit that fails on a negative item."""
    if item < 0:
        raise ResusError(f"item {item} is negative")
    return item


def abort_scan(item: int) -> None:
    """A unit whose scan aborts after `item` frames, as a simulated sweep does when contact
    never settles."""
    raise ScanAborted(f"no stable contact in unit {item}", ScanResult(Path("s.h5"), item, 0.5))


def count_and_square(job: tuple[int, str]) -> int:
    """A unit that fails for item 2 while a 'fail' file exists in the job's folder, else counts
    its runs in a file of its own (`ran_ITEM`) and returns the item squared."""
    item, folder = job
    if item == 2 and (Path(folder) / "fail").exists():
        raise ResusError("unit 2 failed")
    with open(Path(folder) / f"ran_{item}", "a") as runs:
        runs.write("ran\n")
    return item * item
