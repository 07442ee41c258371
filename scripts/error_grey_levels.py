"""Where a segmentation model errs on real images, by grey level: the grey values of its true
positives, misses (false negatives), false alarms (false positives) and true negatives.

If the false alarms are much darker than the true lumens, the model has learnt "vessel =
black", a sign that the simulated lumens it trained on are darker than real ones; if the misses
look like the hits, what it misses is not their grey level but their context or shape.

    python scripts/error_grey_levels.py --real ../shared/data/real/usgra_seg \
        --model RUN/sim_only/checkpoint.pt [--model RUN/sim_only/member_1/checkpoint.pt ...]

Several `--model`s are scored as one ensemble. Black export margins (grey 0) are left out of
the true negatives. Last line: JSON {"tp", "fn", "fp", "tn"}, each {"pixels", "mean",
"median", "p10", "p90", "below_12"}.
"""

from __future__ import annotations

import argparse
import json
from pathlib import Path

import numpy as np


def grey_summary(values: np.ndarray) -> dict[str, float]:
    """Count, mean, median, 10th and 90th percentile, and the share darker than 12."""
    values = values.astype(np.float64)
    return {
        "pixels": int(values.size),
        "mean": round(float(values.mean()), 1),
        "median": float(np.median(values)),
        "p10": float(np.percentile(values, 10)),
        "p90": float(np.percentile(values, 90)),
        "below_12": round(float((values < 12).mean()), 3),
    }


def main() -> None:
    from resus.cli.evaluate import read_image_folders
    from resus.segmentation import load_ensemble

    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--real", type=Path, required=True, help="images/ and masks/ folder")
    parser.add_argument("--model", type=Path, action="append", required=True)
    args = parser.parse_args()
    real = read_image_folders(args.real / "images", args.real / "masks")
    predicted = load_ensemble(args.model, "cpu").predict(list(real.images), progress=True)
    parts: dict[str, list[np.ndarray]] = {"tp": [], "fn": [], "fp": [], "tn": []}
    for image, truth, labels in zip(real.images, real.labels, predicted, strict=True):
        vessel, called = truth > 0, labels > 0
        parts["tp"].append(image[vessel & called])
        parts["fn"].append(image[vessel & ~called])
        parts["fp"].append(image[~vessel & called])
        parts["tn"].append(image[~vessel & ~called & (image > 0)])
    summary = {name: grey_summary(np.concatenate(values)) for name, values in parts.items()}
    for name, row in summary.items():
        print(f"{name}: {row}")
    print(json.dumps(summary))


if __name__ == "__main__":
    main()
