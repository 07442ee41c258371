"""Paired t-test between two training regimes across the same subjects."""

from __future__ import annotations

from collections.abc import Sequence
from dataclasses import asdict, dataclass

import numpy as np
from scipy import stats


@dataclass(frozen=True)
class PairedTest:
    """Result of a two-sided paired t-test of `a - b`; statistic and p_value are None
    (with the reason in `note`) when the test is undefined."""

    n: int
    mean_difference: float | None
    statistic: float | None
    p_value: float | None
    note: str = ""

    def to_dict(self) -> dict:
        return asdict(self)


def paired_t_test(a: Sequence[float], b: Sequence[float]) -> PairedTest:
    """Paired t-test of scores `a` against `b` (one pair per subject), via scipy.stats.ttest_rel.

    Needs at least 2 pairs; with differences that do not vary the t statistic is undefined.
    """
    x, y = np.asarray(a, dtype=float), np.asarray(b, dtype=float)
    if x.shape != y.shape or x.ndim != 1:
        raise ValueError(
            f"paired t-test needs two equal-length 1-D samples, got {x.shape}, {y.shape}"
        )
    n = len(x)
    if n < 2:
        return PairedTest(n, None, None, None, f"needs at least 2 subjects, got {n}")
    difference = x - y
    mean_difference = float(difference.mean())
    if np.allclose(difference, difference[0], rtol=1e-12, atol=1e-12):  # rounding only
        return PairedTest(
            n, mean_difference, None, None, "differences are identical for every subject"
        )
    result = stats.ttest_rel(x, y)
    return PairedTest(n, mean_difference, float(result.statistic), float(result.pvalue))
