"""The README's figure of a simulation-only model on real images: eight overlays, evenly spaced
through the evaluation's `overlays/` folder (no picking), with the real set's credit.

    python scripts/sim_only_figure.py RUN/sim_only/evaluation OUT.png [--title TEXT]

RUN is a `resus experiment sim2real` (or `scripts/sim_only_score.py` seed) output folder.
"""

from __future__ import annotations

import argparse
from pathlib import Path

import matplotlib

matplotlib.use("Agg")
import matplotlib.pyplot as plt
from PIL import Image

CREDIT = "real: tmkand/usgra-seg (CC BY 4.0)"
SHOWN = 8


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("evaluation", type=Path, help="an evaluation folder with overlays/")
    parser.add_argument("out", type=Path)
    parser.add_argument("--title", default="trained on simulation only, on real images")
    args = parser.parse_args()
    overlays = sorted((args.evaluation / "overlays").glob("*.png"))
    if len(overlays) < SHOWN:
        raise SystemExit(f"error: {args.evaluation / 'overlays'} holds {len(overlays)} overlays")
    chosen = overlays[:: len(overlays) // SHOWN][:SHOWN]
    figure, axes = plt.subplots(2, SHOWN // 2, figsize=(14, 7))
    for axis, path in zip(axes.flat, chosen, strict=True):
        axis.imshow(Image.open(path))
        axis.set_title(f"real {path.stem}", fontsize=9)
        axis.axis("off")
    figure.suptitle(
        f"{args.title}: prediction tinted (artery red, vein blue), truth outlined", fontsize=11
    )
    figure.text(0.5, 0.01, CREDIT, ha="center", fontsize=9)
    figure.tight_layout(rect=(0, 0.03, 1, 0.95))
    args.out.parent.mkdir(parents=True, exist_ok=True)
    figure.savefig(args.out, dpi=70)
    print(args.out)


if __name__ == "__main__":
    main()
