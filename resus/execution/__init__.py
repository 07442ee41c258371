"""Where independent units of work run: worker processes of this machine, or a Ray cluster.

- `executor`: the `Executor` interface (`map(function, items, desc, unit, resources)`, in
  order, one progress bar), per-unit `Resources` (CPUs, a GPU fraction), `make_executor`
  by name ("local" or "ray"), the cores this process may use and those granted to the unit
  running in a worker.
- `local`: `LocalExecutor`, spawned worker processes (the default).
- `ray_cluster`: `RayExecutor`, Ray tasks on a cluster or on a Ray started on 127.0.0.1.
- `units`: resumable units, each finished one recorded with the settings it ran with.
"""

from resus.execution.executor import (
    EXECUTORS,
    ONE_CPU,
    Executor,
    Resources,
    available_cores,
    check_executor,
    grant_cpus,
    granted_cpus,
    limit_numba_threads,
    make_executor,
)
from resus.execution.local import LocalExecutor
from resus.execution.ray_cluster import RayExecutor, check_address, start_local_ray
from resus.execution.units import (
    RecordedUnit,
    UnitRecord,
    as_json,
    file_digest,
    read_json,
    run_pending,
    write_json,
)

__all__ = [
    "EXECUTORS",
    "ONE_CPU",
    "Executor",
    "LocalExecutor",
    "RayExecutor",
    "RecordedUnit",
    "Resources",
    "UnitRecord",
    "as_json",
    "available_cores",
    "check_address",
    "check_executor",
    "file_digest",
    "grant_cpus",
    "granted_cpus",
    "limit_numba_threads",
    "make_executor",
    "read_json",
    "run_pending",
    "start_local_ray",
    "write_json",
]
