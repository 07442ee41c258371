"""Resumable units: a unit counts as finished when its record holds the settings it ran with.

A `UnitRecord` is one JSON file, `{"key": SETTINGS, "result": RESULT}`, written by the unit
itself (in its worker) after its outputs, atomically (a temporary file renamed over it): a
unit killed halfway leaves no record and runs again, and a record of other settings does not
count. A unit knows its record (`RecordedUnit`); `run_pending` runs only the units without a
finished record and returns every unit's result from the records, so a rerun after a crash, a
killed worker or a lost node costs only the units that had not finished.
"""

from __future__ import annotations

import functools
import json
import os
from collections.abc import Callable, Sequence
from dataclasses import dataclass, field
from pathlib import Path
from typing import Any, Protocol, TypeVar

from resus.execution.executor import ONE_CPU, Executor, Resources
from sim.fingerprint import files_digest


def read_json(path: Path) -> dict:
    """The JSON object in `path`, or {} when it is missing or unreadable."""
    try:
        data = json.loads(Path(path).read_text())
    except (OSError, ValueError):
        return {}
    return data if isinstance(data, dict) else {}


def write_json(path: Path, data: dict) -> None:
    """Write `data` to `path` atomically: readers see the old file or the whole new one."""
    path = Path(path)
    path.parent.mkdir(parents=True, exist_ok=True)
    partial = path.with_name(f".{path.name}.{os.getpid()}.tmp")
    partial.write_text(json.dumps(data, indent=2) + "\n")
    os.replace(partial, path)


def file_digest(path: Path) -> str:
    """16 hex digits of a SHA-256 over a file's bytes: what a key holds for a file that may be
    replaced under the same name. Remembered per path, size and modification time, so the
    units that share a file (every imagenet run of an experiment) read it once."""
    stat = Path(path).stat()
    return _file_digest(Path(path).resolve(), stat.st_size, stat.st_mtime_ns)


@functools.lru_cache(maxsize=64)
def _file_digest(path: Path, size: int, modified_ns: int) -> str:
    return files_digest([path])


def as_json(value: Any) -> Any:
    """`value` as JSON gives it back (tuples become lists), so keys compare with records."""
    return json.loads(json.dumps(value))


@dataclass(frozen=True)
class UnitRecord:
    """Where a unit records that it finished, with what settings, and the files it made."""

    path: Path
    key: dict
    """Every setting the unit's outputs depend on (JSON-able)."""
    outputs: tuple[Path, ...] = field(default=())
    """Files the unit writes besides the record; a finished unit's must all exist."""

    def __post_init__(self) -> None:
        object.__setattr__(self, "key", as_json(self.key))

    def done(self) -> bool:
        """Finished with these settings, and its outputs are still there."""
        finished = read_json(self.path).get("key") == self.key
        return finished and all(Path(output).is_file() for output in self.outputs)

    def result(self) -> Any:
        """What the finished unit returned (as JSON gives it back)."""
        return read_json(self.path)["result"]

    def finish(self, result: Any) -> None:
        """Record the unit as finished, returning `result`."""
        write_json(self.path, {"key": self.key, "result": as_json(result)})


class RecordedUnit(Protocol):
    """A unit of work that knows where it records that it finished, and with what key."""

    def record(self) -> UnitRecord: ...


Unit = TypeVar("Unit", bound=RecordedUnit)


def run_pending(
    executor: Executor,
    function: Callable[[Unit], Any],
    units: Sequence[Unit],
    desc: str,
    unit: str,
    resources: Resources = ONE_CPU,
    progress: bool = True,
) -> list[Any]:
    """`function(unit)` for every unit whose record is not finished, each recorded by its
    worker as it ends; then every unit's result, in order, from the records. Each unit's
    record (and so its key) is taken once, here."""
    records = [item.record() for item in units]
    pending = [
        (item, record) for item, record in zip(units, records, strict=True) if not record.done()
    ]
    executor.map(
        functools.partial(_run_and_record, function), pending, desc, unit, resources, progress
    )
    return [record.result() for record in records]


def _run_and_record(function: Callable[[Unit], Any], unit: tuple[Unit, UnitRecord]) -> None:
    """One unit in a worker: run it, then write its record."""
    item, record = unit
    record.finish(function(item))
