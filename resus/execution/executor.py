"""The executor interface: run independent units of work, in order, with one progress bar.

A unit is a top-level function applied to one picklable item (one subject's scan, one training
run). Where it runs is the engine's business: `LocalExecutor` uses worker processes of this
machine, `RayExecutor` a Ray cluster. Library code asks `make_executor` for one by name, so a
command's `--executor local|ray [--address ...]` is all that changes between the two.
"""

from __future__ import annotations

import math
import os
from abc import ABC, abstractmethod
from collections.abc import Callable, Iterator, Sequence
from dataclasses import dataclass
from types import TracebackType
from typing import Any, TypeVar

from tqdm import tqdm

from resus.errors import ResusError

Item = TypeVar("Item")
Result = TypeVar("Result")

EXECUTORS = ("local", "ray")


@dataclass(frozen=True)
class Resources:
    """What one unit needs: CPU cores, and a share of a GPU (Ray schedules by both; the local
    engine runs as many units side by side as its cores allow and leaves the GPU to --device)."""

    cpus: int = 1
    gpus: float = 0.0
    """A fraction (0.25: four units share a GPU) or a whole number of GPUs."""

    def __post_init__(self) -> None:
        if self.cpus < 1:
            raise ResusError(f"Resources.cpus must be at least 1, got {self.cpus}")
        fraction_or_whole = self.gpus <= 1 or float(self.gpus).is_integer()
        if not (math.isfinite(self.gpus) and self.gpus >= 0 and fraction_or_whole):
            raise ResusError(
                f"Resources.gpus must be a fraction in [0, 1] or a whole number, got {self.gpus}"
            )


ONE_CPU = Resources()


def available_cores() -> int:
    """CPU cores this process may run on (its affinity mask where the OS has one)."""
    if hasattr(os, "sched_getaffinity"):
        return len(os.sched_getaffinity(0))
    return os.cpu_count() or 1


_granted_cpus: int | None = None
"""CPU cores the running unit was granted, in a worker process; None in the caller's own."""


def grant_cpus(cpus: int | None) -> None:
    """Record the cores granted to units in this process (each engine calls it in its workers)."""
    global _granted_cpus
    _granted_cpus = cpus


def granted_cpus() -> int | None:
    """CPU cores the unit running in this worker may use, or None when the unit runs in the
    caller's own process (which keeps every core). Units size their thread pools by it."""
    return _granted_cpus


def limit_numba_threads() -> None:
    """In a worker, cap numba's threads at the cores granted to the unit, so units side by
    side do not oversubscribe the machine (the caller's own process keeps them all)."""
    cpus = granted_cpus()
    if cpus is not None:
        import numba

        threads = numba.config.NUMBA_NUM_THREADS  # type: ignore[attr-defined]  # set at import
        numba.set_num_threads(max(1, min(threads, cpus)))


class WorkerLost(Exception):
    """An engine lost the worker under a unit (killed, out of memory, a node gone): not the
    unit's own error. `Executor.map` reports it as a ResusError that says how to resume."""


class Executor(ABC):
    """Runs `function(item)` for every item and returns the results in the items' order.

    Use it as a context manager: an engine may hold workers or a cluster connection until the
    block ends. `function` must be importable by name (defined at a module's top level), and
    items and results picklable; a unit's exception is raised here, after the units that were
    already running have finished or been cancelled.

    An engine says only how units run (`_finished`) and what it readies first (`_prepare`);
    the progress bar, the order of the results and the resume message are the same for all.
    """

    name: str

    def map(
        self,
        function: Callable[[Item], Result],
        items: Sequence[Item],
        desc: str,
        unit: str,
        resources: Resources = ONE_CPU,
        progress: bool = True,
    ) -> list[Result]:
        """`function(item)` for every item, each with `resources`, one progress bar
        (`desc`, counting `unit`s); the results in order. No items: no bar, no engine work."""
        if not items:
            return []
        self._prepare(resources, desc)
        results: list[Any] = [None] * len(items)
        with tqdm(total=len(items), desc=desc, unit=unit, disable=not progress) as bar:
            try:
                for index, result in self._finished(function, items, resources):
                    results[index] = result
                    bar.update()
            except WorkerLost as lost:
                raise ResusError(
                    f"{desc}: {lost}; finished units are kept, run again to resume"
                ) from None
        return results

    @abstractmethod
    def _prepare(self, resources: Resources, desc: str) -> None:
        """Before a map's units start: ready the engine, and refuse units it can never run
        (a ResusError naming the map, `desc`)."""

    @abstractmethod
    def _finished(
        self, function: Callable[[Item], Result], items: Sequence[Item], resources: Resources
    ) -> Iterator[tuple[int, Result]]:
        """Run the units; yield each one's index and result as it finishes. A unit's own
        exception propagates as raised; a worker lost under a unit is a `WorkerLost`."""

    @abstractmethod
    def describe(self) -> str:
        """One line for run records: the engine and its size."""

    @abstractmethod
    def close(self) -> None:
        """Release what the engine holds between maps (a Ray it started)."""

    def __enter__(self) -> Executor:
        return self

    def __exit__(
        self,
        kind: type[BaseException] | None,
        error: BaseException | None,
        trace: TracebackType | None,
    ) -> None:
        self.close()


def check_executor(name: str, address: str | None = None) -> None:
    """Refuse an unknown engine name, or an address for an engine that takes none; the
    address itself is checked by `RayExecutor` (its form, and that something answers)."""
    if name not in EXECUTORS:
        raise ResusError(f"unknown executor {name!r}, expected {' or '.join(EXECUTORS)}")
    if address is not None and name != "ray":
        raise ResusError(f"only the ray executor takes an address, got executor {name!r}")


def make_executor(name: str = "local", jobs: int = 2, address: str | None = None) -> Executor:
    """The executor called `name`: "local" (`jobs` worker processes of this machine) or
    "ray" (a Ray cluster at `address`; without one, a Ray of `jobs` CPUs started on this
    machine, bound to 127.0.0.1, when the first unit needs it)."""
    check_executor(name, address)
    if jobs < 1:
        raise ResusError(f"executor jobs must be at least 1, got {jobs}")
    if name == "local":
        from resus.execution.local import LocalExecutor

        return LocalExecutor(jobs)
    from resus.execution.ray_cluster import RayExecutor

    return RayExecutor(jobs, address)
