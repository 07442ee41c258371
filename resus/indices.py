"""Evenly spaced picks from a sequence: the frames of a preview, the reslices of a sheet."""

from __future__ import annotations

import numpy as np


def evenly_spaced(total: int, count: int) -> list[int]:
    """Up to `count` distinct indices of `range(total)` spread evenly, first and last included."""
    if total <= count:
        return list(range(total))
    return sorted({int(i) for i in np.linspace(0, total - 1, count).round()})
