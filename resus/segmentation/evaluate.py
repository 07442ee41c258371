"""Scoring a trained model on a folder of labelled images: IoU and Dice, overlays, metrics.json.

Classes. "vessel" is artery OR vein, in the truth and in the prediction alike, and is always
scored: it is the one class of masks that do not tell artery from vein, and a model that
finds a vessel but calls a vein an artery still found it. When the masks do tell them apart,
artery and vein are scored as well.

Pooled scores sum intersections and unions over every image before dividing (as
`resus.segmentation.metrics` does), so images with small vessels weigh by their pixels.
Per-image scores are each image's own; their mean weighs every image alike. An image whose
mask and prediction are both empty for a class scores IoU 1 and Dice 1 for it: predicting
nothing where there is nothing is exactly right (the same rule as the pooled IoU of an empty
union). Such images are counted in `both_empty`, so their share of a mean can be judged.

By vessel size. The pooled score hides where a model fails, so the images are also grouped by
their true vessel area as a share of the image (`VESSEL_SIZE_EDGES`), each group with its
pooled vessel IoU, the images where the model found none of the vessel, and its predicted over
true vessel area; the images without a vessel report the share of the image called vessel
(false positives and nothing else).

Overlays (`overlays/NAME.png`): the grey image with the prediction tinted in each class's
`sim.labels` colour (artery red, vein blue) and the true vessels' outline in yellow.
"""

from __future__ import annotations

import json
from collections.abc import Sequence
from dataclasses import dataclass
from itertools import pairwise
from pathlib import Path

import cv2
import numpy as np
from PIL import Image
from tqdm import tqdm

from resus.errors import ResusError
from resus.segmentation.folders import VESSEL, FolderImages
from resus.segmentation.metrics import intersection_and_union, iou_of, overlap_counts
from resus.segmentation.trained_model import Segmenter
from sim.labels import EXTRA_COLOURS, VESSEL_CLASSES, tint_labels

SCHEMA = "resus.evaluation/3"
PREDICTION_ALPHA = 0.45
"""Opacity of the predicted classes' tint in the overlays."""
TRUTH_COLOUR = EXTRA_COLOURS[1]
"""Colour of the true vessels' outline (yellow: apart from the classes' red and blue)."""
VESSEL_SIZE_EDGES = (0.015, 0.03, 0.06)
"""Edges of the true vessel area, as a share of the image, between the `by_vessel_size` groups:
a femoral or regional-anaesthesia export's vessels cover from under 1 % to over 10 % of it, and
the small ones are where models trained on simulation fail most (README Sim-to-real)."""


@dataclass(frozen=True)
class Overlap:
    """Pixels of one class in both prediction and truth (intersection) and in either (union)."""

    intersection: int
    union: int

    @property
    def iou(self) -> float:
        """Intersection over union; 1.0 when the class is in neither (`metrics.iou_of`)."""
        return iou_of(self.intersection, self.union)

    @property
    def dice(self) -> float:
        """2 |P and T| / (|P| + |T|) = 2 I / (I + U); 1.0 when the class is in neither."""
        return 1.0 if self.union == 0 else 2 * self.intersection / (self.intersection + self.union)

    def __add__(self, other: Overlap) -> Overlap:
        return Overlap(self.intersection + other.intersection, self.union + other.union)

    def to_dict(self) -> dict[str, float | int]:
        return {
            "iou": self.iou,
            "dice": self.dice,
            "intersection": self.intersection,
            "union": self.union,
        }


def scored_classes(separates_classes: bool) -> tuple[str, ...]:
    """The classes scored: always "vessel", then artery and vein when the masks tell them."""
    return (VESSEL, *VESSEL_CLASSES) if separates_classes else (VESSEL,)


def overlaps(
    predicted: np.ndarray, truth: np.ndarray, classes: Sequence[str]
) -> dict[str, Overlap]:
    """Overlap per class of one label map with its truth ("vessel": any label above 0; artery
    and vein counted by `metrics.intersection_and_union`)."""
    if predicted.shape != truth.shape:
        raise ResusError(f"prediction shape {predicted.shape} != label shape {truth.shape}")
    result = {VESSEL: Overlap(*overlap_counts(predicted > 0, truth > 0))}
    if len(classes) > 1:
        counts = intersection_and_union(predicted, truth)
        pairs = zip(VESSEL_CLASSES, counts, strict=True)
        result |= {name: Overlap(int(i), int(u)) for name, (i, u) in pairs}
    return {name: result[name] for name in classes}


@dataclass(frozen=True)
class SizeGroup:
    """The images whose true vessel area falls in one `VESSEL_SIZE_EDGES` interval."""

    label: str
    """The interval as a share of the image ("none", "< 1.5 %", "1.5-3 %", ...)."""
    images: int
    vessel: Overlap
    """Vessel overlap pooled over the group."""
    missed: int
    """Images with a vessel of which the model found no pixel."""
    predicted_share: float
    """Predicted vessel area over the true one (for "none": over the image's area)."""

    def to_dict(self) -> dict[str, object]:
        return {
            "label": self.label,
            "images": self.images,
            "vessel": self.vessel.to_dict(),
            "missed": self.missed,
            "predicted_share": self.predicted_share,
        }


@dataclass(frozen=True)
class Evaluation:
    """Per-image overlaps of a model's labels with the truth, and the scores made of them."""

    classes: tuple[str, ...]
    names: tuple[str, ...]
    per_image: tuple[dict[str, Overlap], ...]
    true_pixels: tuple[int, ...]
    """Each image's true vessel pixels."""
    image_pixels: tuple[int, ...]
    """Each image's pixels."""

    def pooled(self) -> dict[str, Overlap]:
        """Overlap per class summed over every image."""
        total = dict.fromkeys(self.classes, Overlap(0, 0))
        for image in self.per_image:
            total = {name: total[name] + image[name] for name in self.classes}
        return total

    def per_image_mean(self) -> dict[str, dict[str, float]]:
        """Mean over images of each image's IoU and Dice, per class."""
        return {
            name: {
                metric: float(np.mean([getattr(image[name], metric) for image in self.per_image]))
                for metric in ("iou", "dice")
            }
            for name in self.classes
        }

    def both_empty(self) -> dict[str, int]:
        """Images whose mask and prediction both lack the class (scored 1), per class."""
        return {
            name: sum(image[name].union == 0 for image in self.per_image) for name in self.classes
        }

    def by_vessel_size(self) -> tuple[SizeGroup, ...]:
        """The images grouped by true vessel area (module docstring); empty groups left out."""
        shares = np.array(self.true_pixels) / np.array(self.image_pixels)
        edges = (0.0, *VESSEL_SIZE_EDGES, np.inf)
        bounds = [("none", shares == 0)] + [
            (_size_label(low, high), (shares > 0) & (shares >= low) & (shares < high))
            for low, high in pairwise(edges)
        ]
        groups = []
        for label, chosen in bounds:
            if not chosen.any():
                continue
            index = np.flatnonzero(chosen)
            group_overlaps = [self.per_image[i][VESSEL] for i in index]
            vessel = sum(group_overlaps, Overlap(0, 0))
            truth = sum(self.true_pixels[i] for i in index)
            predicted = vessel.union + vessel.intersection - truth
            whole = truth if truth else sum(self.image_pixels[i] for i in index)
            groups.append(
                SizeGroup(
                    label=label,
                    images=len(index),
                    vessel=vessel,
                    missed=sum(o.intersection == 0 for o in group_overlaps) if truth else 0,
                    predicted_share=predicted / whole,
                )
            )
        return tuple(groups)

    def to_dict(self) -> dict:
        """JSON-able form: pooled and mean scores, the groups by vessel size, every image's."""
        return {
            "classes": list(self.classes),
            "images": len(self.names),
            "pooled": {name: overlap.to_dict() for name, overlap in self.pooled().items()},
            "per_image_mean": self.per_image_mean(),
            "both_empty": self.both_empty(),
            "empty_rule": "a class absent from both mask and prediction scores IoU 1 and Dice 1",
            "by_vessel_size": [group.to_dict() for group in self.by_vessel_size()],
            "per_image": [
                {
                    "name": name,
                    "true_vessel_share": truth / pixels,
                    **{c: overlap.to_dict() for c, overlap in image.items()},
                }
                for name, image, truth, pixels in zip(
                    self.names, self.per_image, self.true_pixels, self.image_pixels, strict=True
                )
            ],
        }

    def summary(self) -> list[str]:
        """One line per class: pooled and per-image mean IoU and Dice."""
        pooled, mean, empty = self.pooled(), self.per_image_mean(), self.both_empty()
        return [
            f"{name}: pooled IoU {pooled[name].iou:.3f}, Dice {pooled[name].dice:.3f}; "
            f"per-image mean IoU {mean[name]['iou']:.3f}, Dice {mean[name]['dice']:.3f} "
            f"({len(self.names)} images, {empty[name]} with none in mask and prediction)"
            for name in self.classes
        ] + [self._size_line()]

    def _size_line(self) -> str:
        """One line of the vessel scores by true vessel area."""
        parts = []
        for group in self.by_vessel_size():
            if group.label == "none":
                parts.append(
                    f"none ({group.images} images): {group.predicted_share:.1%} called vessel"
                )
            else:
                parts.append(
                    f"{group.label} ({group.images}): IoU {group.vessel.iou:.3f}, "
                    f"{group.missed} missed"
                )
        return "vessel by true area: " + "; ".join(parts)


def _size_label(low: float, high: float) -> str:
    """A `by_vessel_size` interval of the image's share as a label ("< 1.5%", "1.5%-3.0%",
    ">= 6.0%")."""
    if low == 0:
        return f"< {high:.1%}"
    return f">= {low:.1%}" if high == np.inf else f"{low:.1%}-{high:.1%}"


def score_labels(
    names: Sequence[str],
    predicted: Sequence[np.ndarray],
    truth: Sequence[np.ndarray],
    separates_classes: bool,
) -> Evaluation:
    """The `Evaluation` of predicted label maps against the true ones, image by image."""
    classes = scored_classes(separates_classes)
    per_image = tuple(overlaps(p, t, classes) for p, t in zip(predicted, truth, strict=True))
    true_pixels = tuple(int((labels > 0).sum()) for labels in truth)
    return Evaluation(
        classes, tuple(names), per_image, true_pixels, tuple(labels.size for labels in truth)
    )


def overlay(image: np.ndarray, truth: np.ndarray, predicted: np.ndarray) -> np.ndarray:
    """(H, W, 3) uint8 RGB: `image` with `predicted` tinted by class and the outline of the
    true vessels drawn over it (lines about 1/256 of the image's size thick)."""
    rgb = tint_labels(image, predicted, PREDICTION_ALPHA)
    contours, _ = cv2.findContours(
        (truth > 0).astype(np.uint8), cv2.RETR_LIST, cv2.CHAIN_APPROX_NONE
    )
    thickness = max(1, round(min(image.shape) / 256))
    return cv2.drawContours(np.ascontiguousarray(rgb), contours, -1, TRUTH_COLOUR, thickness)


def evaluate_folder(
    model: Segmenter, data: FolderImages, out_dir: Path, *, progress: bool = True
) -> Evaluation:
    """Segment every image of `data`, score it, and write `out_dir/metrics.json` and
    `out_dir/overlays/NAME.png`."""
    overlay_dir = Path(out_dir) / "overlays"
    try:
        overlay_dir.mkdir(parents=True, exist_ok=True)
    except OSError as error:
        raise ResusError(f"cannot create the output folder ({error.strerror})", out_dir) from None
    predicted: list[np.ndarray] = []
    with tqdm(total=len(data), desc="evaluate", unit="image", disable=not progress) as bar:
        for start in range(0, len(data), model.batch_size):  # batched: far faster on a CPU
            batch = slice(start, start + model.batch_size)
            labels = model.predict(list(data.images[batch]))
            for name, image, truth, label in zip(
                data.names[batch], data.images[batch], data.labels[batch], labels, strict=True
            ):
                Image.fromarray(overlay(image, truth, label)).save(
                    overlay_dir / f"{name}.png",
                    compress_level=1,  # 3x faster than the default, a fifth larger
                )
            predicted += labels
            bar.update(len(labels))
    evaluation = score_labels(data.names, predicted, data.labels, data.separates_classes)
    metrics = {
        "schema": SCHEMA,
        "checkpoints": [str(path) for path in model.checkpoints],
        "image_folder": str(data.image_folder),
        "mask_folder": str(data.mask_folder),
        "device": str(model.device),
        "image_size": model.image_size,
        "mirror": model.mirror,
        "input_sizes": list(model.input_sizes),
        **evaluation.to_dict(),
    }
    (Path(out_dir) / "metrics.json").write_text(json.dumps(metrics, indent=2) + "\n")
    return evaluation
