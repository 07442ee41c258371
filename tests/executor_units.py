"""Units of work for the executor tests, shared by the local and the Ray engine's tests.

They live in a module of their own so that a worker can import them by name (a spawned local
worker) or receive them by value (a Ray worker: `test_ray_engine.py` registers this module).
"""

from __future__ import annotations

from dataclasses import dataclass
from pathlib import Path

from resus.acquisition.scanner import ScanAborted, ScanResult
from resus.errors import ResusError
from resus.execution import UnitRecord, granted_cpus


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


@dataclass(frozen=True)
class CountedSquare:
    """A resumable unit for `count_and_square`: its item, and the folder of its run counts
    and its record."""

    item: int
    folder: Path

    def record(self) -> UnitRecord:
        return UnitRecord(self.folder / f"unit_{self.item}.json", {"k": self.item})


def count_and_square(unit: CountedSquare) -> int:
    """A unit that fails for item 2 while a 'fail' file exists in the unit's folder, else
    counts its runs in a file of its own (`ran_ITEM`) and returns the item squared."""
    if unit.item == 2 and (unit.folder / "fail").exists():
        raise ResusError("unit 2 failed")
    with open(unit.folder / f"ran_{unit.item}", "a") as runs:
        runs.write("ran\n")
    return unit.item * unit.item
