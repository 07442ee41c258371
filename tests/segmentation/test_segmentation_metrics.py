"""Vessel IoU and the paired t-test against hand computations and scipy."""

import numpy as np
import pytest
from scipy import stats

from resus.segmentation.metrics import VesselIoU, intersection_and_union, vessel_iou
from resus.segmentation.stats import paired_t_test


def test_iou_matches_hand_count() -> None:
    predicted = np.array([[0, 1, 1], [2, 2, 0]])
    truth = np.array([[1, 1, 0], [2, 0, 0]])
    # artery: overlap at (0,1); union (0,0),(0,1),(0,2). vein: overlap (1,0); union (1,0),(1,1).
    np.testing.assert_array_equal(intersection_and_union(predicted, truth), [[1, 3], [1, 2]])
    iou = vessel_iou(predicted, truth)
    assert (iou.artery, iou.vein, iou.mean) == pytest.approx((1 / 3, 1 / 2, 5 / 12))


def test_empty_classes() -> None:
    nothing = np.zeros((4, 4), dtype=np.uint8)
    some_vein = nothing.copy()
    some_vein[1, 1] = 2
    # Absent from both: 1.0. Missed or invented vessel: 0.0.
    assert vessel_iou(nothing, nothing) == VesselIoU(1.0, 1.0)
    assert vessel_iou(nothing, some_vein) == VesselIoU(1.0, 0.0)
    assert vessel_iou(some_vein, nothing) == VesselIoU(1.0, 0.0)


def test_iou_is_pooled_over_frames_not_averaged() -> None:
    truth = np.zeros((2, 10, 10), dtype=np.uint8)
    truth[0, :5] = 1  # 50 artery pixels in frame 0
    truth[1, 0, 0] = 1  # 1 artery pixel in frame 1
    predicted = truth.copy()
    predicted[1, 0, 0] = 0  # frame 1 misses its single pixel: per-frame mean would be 0.5
    counts = intersection_and_union(predicted[0], truth[0]) + intersection_and_union(
        predicted[1], truth[1]
    )
    assert VesselIoU.from_counts(counts).artery == pytest.approx(50 / 51)
    assert vessel_iou(predicted, truth).artery == pytest.approx(50 / 51)


def test_iou_rejects_mismatched_shapes() -> None:
    with pytest.raises(ValueError, match="shape"):
        intersection_and_union(np.zeros((2, 3)), np.zeros((3, 2)))


def test_paired_t_test_matches_formula_and_scipy() -> None:
    a = [0.71, 0.64, 0.80, 0.58, 0.69]
    b = [0.62, 0.60, 0.71, 0.59, 0.61]
    d = np.subtract(a, b)  # 0.09, 0.04, 0.09, -0.01, 0.08
    t = d.mean() / (d.std(ddof=1) / np.sqrt(len(d)))
    p = 2 * stats.t.sf(abs(t), df=len(d) - 1)
    result = paired_t_test(a, b)
    assert result.n == 5
    assert result.mean_difference == pytest.approx(0.058)
    assert result.statistic == pytest.approx(t)
    assert result.p_value == pytest.approx(p)
    assert result.statistic == pytest.approx(stats.ttest_rel(a, b).statistic)
    # by hand: sd of d = sqrt(0.00748 / 4) = 0.043243, t = 0.058 / (0.043243 / sqrt(5))
    assert result.statistic == pytest.approx(2.9991, abs=1e-4)


def test_paired_t_test_undefined_cases() -> None:
    one = paired_t_test([0.7], [0.6])
    assert one.p_value is None and one.statistic is None and "at least 2 subjects" in one.note
    constant = paired_t_test([0.7, 0.8], [0.6, 0.7])
    assert constant.p_value is None and "identical" in constant.note
    assert constant.mean_difference == pytest.approx(0.1)
    with pytest.raises(ValueError, match="equal-length"):
        paired_t_test([1, 2], [1])
