"""Score the simulator by its simulation-only model: vessel IoU on real images, over seeds.

Runs `resus experiment sim2real`'s first half only (the subjects' sweeps and the
simulation-only training, `label_counts=(0,)`, one split) for each seed, at the `quick`
training preset (64 px) unless told otherwise, and reports the pooled vessel IoU per seed with
its mean and standard deviation: the figure a simulator change has to move beyond the seed
noise (one seed moves it by 0.05-0.1). It scores single models (`ensemble=1`, whatever the
preset's) unless told `--set ensemble=N`; an ensemble's members are the runs at seeds s, s+1,
..., each also scored alone.

    python scripts/sim_only_score.py --real ../shared/data/real/usgra_seg --seeds 0,1,2 \
        [--preset quick] [--training quick] [--out /tmp/sim_only] [--set zoom_p=0.0]

`--set NAME=VALUE` overrides a `Sim2RealSettings` field (VALUE as JSON). Last line: JSON
{"seeds", "iou", "dice", "precision", "recall", "mean_iou", "sd_iou", "members", "preset",
"training", "overrides"}; "members" maps each member's seed to its own IoU.
"""

from __future__ import annotations

import argparse
import dataclasses
import json
from pathlib import Path

import numpy as np


def main() -> None:
    from resus.cli.evaluate import read_image_folders
    from resus.execution import make_executor
    from resus.experiments.sim2real import get_sim2real_preset, run_sim2real

    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--real", type=Path, required=True, help="images/ and masks/ folder")
    parser.add_argument("--seeds", default="0,1,2")
    parser.add_argument("--preset", default="quick")
    parser.add_argument("--training", default="quick")
    parser.add_argument("--out", type=Path, default=Path("sim_only_score"))
    parser.add_argument("--set", action="append", default=[], metavar="NAME=VALUE")
    args = parser.parse_args()
    overrides = {}
    for item in args.set:
        name, _, value = item.partition("=")
        overrides[name] = json.loads(value)
    settings = dataclasses.replace(
        get_sim2real_preset(args.preset),
        training=args.training,
        label_counts=(0,),
        splits=1,
        **{"ensemble": 1, **overrides},
    )
    real = read_image_folders(args.real / "images", args.real / "masks")
    true_pixels = int(sum((mask > 0).sum() for mask in real.labels))
    seeds = [int(seed) for seed in args.seeds.split(",")]
    scores: dict[str, list[float]] = {"iou": [], "dice": [], "precision": [], "recall": []}
    members: dict[int, float] = {}
    with make_executor("local", 2) as engine:
        for seed in seeds:
            result = run_sim2real(
                settings, real, args.out / f"seed_{seed}", seed=seed, executor=engine
            )
            sim_only = result.to_dict()["sim_only"]
            vessel = sim_only["pooled"]["vessel"]
            members |= {
                m["seed"]: round(m["pooled"]["vessel"]["iou"], 4) for m in sim_only["members"]
            }
            overlap, union = vessel["intersection"], vessel["union"]
            predicted = union - true_pixels + overlap
            scores["iou"].append(vessel["iou"])
            scores["dice"].append(vessel["dice"])
            scores["precision"].append(overlap / predicted if predicted else 0.0)
            scores["recall"].append(overlap / true_pixels)
            print(f"seed {seed}: vessel IoU {vessel['iou']:.3f}")
    iou = np.array(scores["iou"])
    print(
        json.dumps(
            {
                "seeds": seeds,
                **{name: [round(v, 4) for v in values] for name, values in scores.items()},
                "mean_iou": round(float(iou.mean()), 4),
                "sd_iou": round(float(iou.std(ddof=1)) if len(iou) > 1 else 0.0, 4),
                "members": members,
                "preset": args.preset,
                "training": args.training,
                "overrides": overrides,
            }
        )
    )


if __name__ == "__main__":
    main()
