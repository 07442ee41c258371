"""Intersection over union for artery and vein.

IoU is pooled over all images of a set (one subject's test frames): intersections and unions
are summed first, then divided, so frames with tiny or no vessels do not dominate as they
would in a per-frame mean. When a class is absent from both prediction and truth the IoU is
1.0: predicting nothing where there is nothing is exactly right. The mean is over artery and
vein (background excluded).
"""

from __future__ import annotations

from dataclasses import asdict, dataclass

import numpy as np

from sim.labels import VESSEL_CLASSES

IOU_METRICS: tuple[str, ...] = (*VESSEL_CLASSES, "mean")
"""The scores of a `VesselIoU`, as `to_dict` names them: each vessel class, then their mean."""


def no_counts() -> np.ndarray:
    """Zero `intersection_and_union` counts, to sum a set's counts into."""
    return np.zeros((len(VESSEL_CLASSES), 2), dtype=np.int64)


def overlap_counts(in_predicted: np.ndarray, in_truth: np.ndarray) -> tuple[int, int]:
    """Pixels of one class in both masks (intersection) and in either (union)."""
    return (
        int(np.count_nonzero(in_predicted & in_truth)),
        int(np.count_nonzero(in_predicted | in_truth)),
    )


def iou_of(intersection: int, union: int) -> float:
    """Intersection over union; 1.0 for an empty union (the class in neither: exactly right)."""
    return 1.0 if union == 0 else intersection / union


def intersection_and_union(predicted: np.ndarray, truth: np.ndarray) -> np.ndarray:
    """(2, 2) int64 counts: row per vessel class (artery, vein), columns (intersection, union)."""
    predicted, truth = np.asarray(predicted), np.asarray(truth)
    if predicted.shape != truth.shape:
        raise ValueError(f"prediction shape {predicted.shape} != label shape {truth.shape}")
    counts = no_counts()
    for row, label in enumerate(VESSEL_CLASSES.values()):
        counts[row] = overlap_counts(predicted == label, truth == label)
    return counts


@dataclass(frozen=True)
class VesselIoU:
    """IoU of artery and vein, and their mean."""

    artery: float
    vein: float

    @property
    def mean(self) -> float:
        return (self.artery + self.vein) / 2

    @classmethod
    def from_counts(cls, counts: np.ndarray) -> VesselIoU:
        """From summed `intersection_and_union` counts; an empty union scores 1.0."""
        return cls(*(float(iou_of(intersection, union)) for intersection, union in counts))

    def to_dict(self) -> dict[str, float]:
        return {**asdict(self), "mean": self.mean}

    @classmethod
    def from_dict(cls, data: dict) -> VesselIoU:
        """Inverse of `to_dict` (the mean follows from the two)."""
        return cls(data["artery"], data["vein"])


def vessel_iou(predicted: np.ndarray, truth: np.ndarray) -> VesselIoU:
    """Pooled IoU of label maps of any (matching) shape."""
    return VesselIoU.from_counts(intersection_and_union(predicted, truth))
