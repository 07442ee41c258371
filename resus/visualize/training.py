"""Training curves in rerun: every number of every epoch as a time series on "epoch"."""

from __future__ import annotations

from collections.abc import Mapping, Sequence
from numbers import Real

import numpy as np
import rerun as rr

from resus.errors import ResusError
from resus.visualize.entities import EPOCH, TRAINING


def flatten_numbers(record: Mapping, prefix: str = "") -> dict[str, float]:
    """Numbers of a nested mapping keyed by their path, e.g. `validation_iou/artery`."""
    flat: dict[str, float] = {}
    for key, value in record.items():
        path = f"{prefix}{key}"
        if isinstance(value, Mapping):
            flat.update(flatten_numbers(value, f"{path}/"))
        elif isinstance(value, Real) and not isinstance(value, bool):
            flat[path] = float(value)
    return flat


def log_training_curves(
    stream: rr.RecordingStream, history: Sequence[Mapping], *, prefix: str = TRAINING
) -> list[str]:
    """Log per-epoch records (e.g. `EpochRecord.to_dict()`: losses, nested IoU dicts) as curves
    `training/<key>` on the "epoch" timeline; returns the entity paths logged.

    A record's "epoch" number is its time (else its position); missing values are skipped.
    """
    if not history:
        raise ResusError("no training history to log (empty list of epochs)")
    rows = [flatten_numbers(record) for record in history]
    epochs = np.array([row.pop(EPOCH, index) for index, row in enumerate(rows)], dtype=np.int64)
    paths = []
    for key in sorted({key for row in rows for key in row}):
        present = [index for index, row in enumerate(rows) if key in row]
        path = f"{prefix}/{key}"
        stream.send_columns(
            path,
            indexes=[rr.TimeColumn(EPOCH, sequence=epochs[present])],
            columns=rr.Scalars.columns(scalars=[rows[index][key] for index in present]),
        )
        paths.append(path)
    return paths
