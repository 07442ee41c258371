"""The local engine: units in spawned worker processes of this machine, as many at a time as
its cores allow; in this process when only one would run.

Workers are spawned, not forked: MuJoCo, numba and torch hold threads and state that a forked
child would inherit half-initialised. A worker that dies (killed, out of memory) ends the map
with a ResusError; units that finished before it keep their outputs, so a rerun resumes.
"""

from __future__ import annotations

import multiprocessing
from collections.abc import Callable, Iterator, Sequence
from concurrent.futures import ProcessPoolExecutor, as_completed
from concurrent.futures.process import BrokenProcessPool
from typing import TypeVar

from resus.execution.executor import (
    ONE_CPU,
    Executor,
    Resources,
    WorkerLost,
    available_cores,
    grant_cpus,
)

Item = TypeVar("Item")
Result = TypeVar("Result")


class LocalExecutor(Executor):
    """`jobs` CPU slots of this machine; a unit needing `cpus` takes that many of them."""

    name = "local"

    def __init__(self, jobs: int = 2) -> None:
        self.jobs = jobs

    def describe(self) -> str:
        return f"local, {self.jobs} worker processes"

    def close(self) -> None:
        """Nothing to release: each map's worker processes end with it."""

    def workers(self, units: int, resources: Resources = ONE_CPU) -> int:
        """Processes a map of `units` units with `resources` each uses (1: this process)."""
        return max(1, min(units, self.jobs // resources.cpus))

    def _prepare(self, resources: Resources, desc: str) -> None:
        """Nothing to ready: each map spawns its own workers, and `workers` fits any unit."""

    def _finished(
        self, function: Callable[[Item], Result], items: Sequence[Item], resources: Resources
    ) -> Iterator[tuple[int, Result]]:
        """In this process, in order, when one worker would run; else in spawned workers."""
        workers = self.workers(len(items), resources)
        if workers == 1:
            for index, item in enumerate(items):
                yield index, function(item)
            return
        # each worker gets an equal share of this machine's cores, at least the unit's own
        share = max(resources.cpus, available_cores() // workers)
        context = multiprocessing.get_context("spawn")
        with ProcessPoolExecutor(workers, context, grant_cpus, (share,)) as pool:
            futures = {pool.submit(function, item): index for index, item in enumerate(items)}
            try:
                for future in as_completed(futures):
                    yield futures[future], future.result()  # the first failure ends the map
            except BrokenProcessPool:
                raise WorkerLost(
                    "a worker process died (killed, out of memory, or started from a script "
                    "without an `if __name__ == '__main__':` guard, which spawned workers re-run)"
                ) from None
            finally:
                for future in futures:
                    future.cancel()  # those not started yet; running ones finish
