"""Evenly spaced picks: first and last always in, distinct, never more than asked."""

import pytest

from resus.indices import evenly_spaced


@pytest.mark.parametrize(
    ("total", "count", "expected"),
    [
        (10, 4, [0, 3, 6, 9]),
        (5, 24, [0, 1, 2, 3, 4]),
        (7, 1, [0]),
        (0, 3, []),
        (100, 3, [0, 50, 99]),
    ],
)
def test_known_answers(total: int, count: int, expected: list[int]) -> None:
    assert evenly_spaced(total, count) == expected


def test_distinct_sorted_and_ends_included() -> None:
    for total in range(2, 60):
        for count in range(2, 12):
            picks = evenly_spaced(total, count)
            assert picks == sorted(set(picks)) and len(picks) == min(total, count)
            assert picks[0] == 0 and picks[-1] == total - 1
