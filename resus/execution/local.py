"""The local engine: units in spawned worker processes of this machine, as many at a time as
its cores allow; in this process when only one would run.

Workers are spawned, not forked: MuJoCo, numba and torch hold threads and state that a forked
child would inherit half-initialised. A worker that dies (killed, out of memory) ends the map
with a ResusError; units that finished before it keep their outputs, so a rerun resumes.
"""

from __future__ import annotations

import multiprocessing
from collections.abc import Callable, Sequence
from concurrent.futures import ProcessPoolExecutor, as_completed
from concurrent.futures.process import BrokenProcessPool
from typing import TypeVar

from tqdm import tqdm

from resus.errors import ResusError
from resus.execution.executor import ONE_CPU, Executor, Resources, grant_cpus
from resus.workers import available_cores

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

    def map(
        self,
        function: Callable[[Item], Result],
        items: Sequence[Item],
        desc: str,
        unit: str,
        resources: Resources = ONE_CPU,
        progress: bool = True,
    ) -> list[Result]:
        bar = tqdm(total=len(items), desc=desc, unit=unit, disable=not progress)
        with bar:
            workers = self.workers(len(items), resources)
            if workers == 1:
                results = []
                for item in items:
                    results.append(function(item))
                    bar.update()
                return results
            # each worker gets an equal share of this machine's cores, at least the unit's own
            share = max(resources.cpus, available_cores() // workers)
            context = multiprocessing.get_context("spawn")
            with ProcessPoolExecutor(workers, context, grant_cpus, (share,)) as pool:
                futures = [pool.submit(function, item) for item in items]
                try:
                    for future in as_completed(futures):
                        future.result()  # the first failure ends the map
                        bar.update()
                except BrokenProcessPool:
                    raise ResusError(
                        f"{desc}: a worker process died (killed, or out of memory); finished "
                        "units are kept, run again to resume"
                    ) from None
                finally:
                    for future in futures:
                        future.cancel()  # those not started yet; running ones finish
                return [future.result() for future in futures]
