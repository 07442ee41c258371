"""IoU over training seeds: the spread is the sample deviation of the per-seed values, a
difference within it is "no difference", and the paired t-test pairs seed with seed (and
held-out subject with held-out subject)."""

from __future__ import annotations

import statistics

import pytest
from scipy import stats

from resus.errors import ResusError
from resus.experiments.report import comparisons_against, subjects_table
from resus.experiments.results import (
    NO_DIFFERENCE,
    IoUSummary,
    SeedComparison,
    SeededLoso,
    compare_models,
)
from resus.segmentation.metrics import VesselIoU


def cell(*pairs: tuple[float, float]) -> IoUSummary:
    """An IoU cell from one (artery, vein) pair per seed."""
    return IoUSummary.of([VesselIoU(artery, vein) for artery, vein in pairs])


def test_a_cell_is_the_mean_and_sample_deviation_of_its_seeds() -> None:
    summary = cell((0.2, 0.6), (0.4, 0.7), (0.9, 0.8))
    saved = summary.to_dict()
    assert saved["n_seeds"] == 3 and len(saved["runs"]) == 3
    means = [run["mean"] for run in saved["runs"]]
    assert means == pytest.approx([0.4, 0.55, 0.85])
    assert saved["mean"] == pytest.approx(statistics.mean(means))
    assert saved["mean_std"] == pytest.approx(statistics.stdev(means))  # n - 1, not n
    assert saved["artery_std"] == pytest.approx(statistics.stdev([0.2, 0.4, 0.9]))
    assert saved["vein"] == pytest.approx(0.7)


def test_one_seed_gives_no_spread_and_is_refused() -> None:
    with pytest.raises(ResusError, match="at least 2 seeds, got 1"):
        cell((0.5, 0.5))


def test_a_difference_within_the_seed_spread_is_no_difference() -> None:
    # a beats b on every seed's mean, by 0.05 on average, but a's seeds spread over 0.2
    a = cell((0.5, 0.5), (0.7, 0.7), (0.9, 0.9))
    b = cell((0.6, 0.6), (0.65, 0.65), (0.7, 0.7))
    comparison = SeedComparison.of("a", "b", "mean", [a], [b])
    assert comparison.difference == pytest.approx(0.05)
    assert comparison.seed_spread == pytest.approx(statistics.stdev([0.5, 0.7, 0.9]))
    assert comparison.verdict == NO_DIFFERENCE


def test_a_difference_beyond_the_seed_spread_is_a_gain_for_the_better_model() -> None:
    a = cell((0.80, 0.80), (0.82, 0.82), (0.84, 0.84))
    b = cell((0.60, 0.60), (0.63, 0.63), (0.61, 0.61))
    gain = SeedComparison.of("resus", "us", "mean", [a], [b])
    assert gain.difference == pytest.approx(0.82 - statistics.mean([0.60, 0.63, 0.61]))
    assert gain.seed_spread == pytest.approx(statistics.stdev([0.80, 0.82, 0.84]))  # a's, larger
    assert gain.verdict == "resus better"
    assert SeedComparison.of("us", "resus", "mean", [b], [a]).verdict == "resus better"


def test_the_paired_test_pairs_each_seed_and_subject() -> None:
    subjects = {
        "s0": (cell((0.5, 0.7), (0.6, 0.6)), cell((0.4, 0.6), (0.5, 0.4))),
        "s1": (cell((0.8, 0.8), (0.7, 0.9)), cell((0.8, 0.6), (0.6, 0.7))),
        "s2": (cell((0.3, 0.5), (0.4, 0.4)), cell((0.3, 0.3), (0.2, 0.5))),
    }
    a_cells = [a for a, _ in subjects.values()]
    b_cells = [b for _, b in subjects.values()]
    comparison = SeedComparison.of("a", "b", "artery", a_cells, b_cells)
    a_values = [value for c in a_cells for value in c.values("artery")]
    b_values = [value for c in b_cells for value in c.values("artery")]
    expected = stats.ttest_rel(a_values, b_values)
    assert comparison.test.n == 6  # 3 held-out subjects x 2 seeds
    assert comparison.test.p_value == pytest.approx(expected.pvalue)
    # the spread is over the seeds of the average over subjects, seed by seed
    a_per_seed = [statistics.mean(c.values("artery")[k] for c in a_cells) for k in range(2)]
    b_per_seed = [statistics.mean(c.values("artery")[k] for c in b_cells) for k in range(2)]
    assert comparison.seed_spread == pytest.approx(
        max(statistics.stdev(a_per_seed), statistics.stdev(b_per_seed))
    )
    assert comparison.difference == pytest.approx(
        statistics.mean(a_per_seed) - statistics.mean(b_per_seed)
    )
    assert [c.metric for c in compare_models("a", "b", a_cells, b_cells)] == [
        "artery",
        "vein",
        "mean",
    ]


def test_cells_over_different_seeds_are_not_compared() -> None:
    with pytest.raises(ResusError, match="same seeds"):
        SeedComparison.of(
            "a",
            "b",
            "mean",
            [cell((0.1, 0.1), (0.2, 0.2))],
            [cell((0.1, 0.1), (0.2, 0.2), (0.3, 0.3))],
        )


def test_subjects_table_prints_the_spreads_and_the_verdicts_of_results_json() -> None:
    loso = SeededLoso(
        subjects=("s0", "s1"),
        seeds=(4, 5),
        iou={
            "us": {"s0": cell((0.5, 0.5), (0.9, 0.9)), "s1": cell((0.6, 0.6), (0.8, 0.8))},
            "resus": {"s0": cell((0.7, 0.7), (0.8, 0.8)), "s1": cell((0.7, 0.7), (0.9, 0.9))},
        },
        not_run={"imagenet": "no weights"},
    )
    saved = loso.to_dict()
    assert saved["seeds"] == [4, 5] and saved["regimes"]["imagenet"]["status"] == "not run"
    average = saved["regimes"]["us"]["mean_over_subjects"]
    assert average["mean"] == pytest.approx(0.7)
    assert average["mean_std"] == pytest.approx(statistics.stdev([0.55, 0.85]))
    table = subjects_table({"loso": saved})
    assert table[2] == "| s0 | 0.700 ± 0.283 | 0.750 ± 0.071 |"
    resus_spread = statistics.stdev([(0.7 + 0.7) / 2, (0.8 + 0.9) / 2])
    assert table[4] == f"| **average** | **0.700 ± 0.212** | **0.775 ± {resus_spread:.3f}** |"
    against = comparisons_against(saved, "resus", "mean")
    assert against["us"]["verdict"] == NO_DIFFERENCE  # 0.075 apart, spread 0.212
    assert table[-1] == f"| verdict vs resus | {NO_DIFFERENCE} |  |"
    assert table[-2] == f"| p vs resus | {against['us']['p_value']:.3g} |  |"
