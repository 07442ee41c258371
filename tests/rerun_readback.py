"""Reading a saved `.rrd` back for the rerun tests: rows per entity, merged over chunks."""

from __future__ import annotations

from collections import defaultdict
from pathlib import Path

import numpy as np
import pyarrow as pa
from rerun.chunk import RrdReader


class Recording:
    """The temporal and static rows of every entity of the first recording in an `.rrd`."""

    def __init__(self, path: str | Path) -> None:
        reader = RrdReader(path)
        self.blueprints = reader.blueprints()
        self.temporal: dict[str, list[dict]] = defaultdict(list)
        self.static: dict[str, dict] = defaultdict(dict)
        for chunk in reader.store().stream():
            batch = chunk.to_record_batch()
            columns = {
                name: _values(batch.column(name))
                for name in batch.schema.names
                if name != "rerun.controls.RowId"
            }
            if chunk.is_static:
                for name, values in columns.items():
                    self.static[chunk.entity_path][name] = values[-1]
                continue
            for row in range(chunk.num_rows):
                self.temporal[chunk.entity_path].append(
                    {name: values[row] for name, values in columns.items()}
                )
        for rows in self.temporal.values():
            if rows and "frame" in rows[0]:
                rows.sort(key=lambda row: row["frame"])

    @property
    def entities(self) -> set[str]:
        """Every entity path with data, temporal or static."""
        return set(self.temporal) | set(self.static)

    def column(self, entity: str, component: str) -> list:
        """One component's values over the entity's temporal rows (in frame order)."""
        return [row[component] for row in self.temporal[entity]]

    def times(self, entity: str, timeline: str) -> np.ndarray:
        """The entity's rows' times on `timeline`: sequence numbers, or seconds for durations."""
        return np.array(self.column(entity, timeline), dtype=float)


def _values(column: pa.Array) -> list:
    """Python values of a column; durations and timestamps (nanoseconds) become seconds."""
    if pa.types.is_duration(column.type) or pa.types.is_timestamp(column.type):
        return [ns / 1e9 for ns in column.cast(pa.int64()).to_pylist()]
    return column.to_pylist()
