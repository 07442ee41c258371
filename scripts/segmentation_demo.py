"""Leave-one-subject-out demo of the training regimes on synthetic subjects (quick preset).

Makes `--subjects` synthetic subjects (frames, plus oblique "reslices" of each), runs every
regime with leave-one-subject-out evaluation, and writes OUT/loso.json, OUT/loso.md and the
per-run checkpoints and training curves under OUT/REGIME/SUBJECT/. The ImageNet regime runs
only with `--weights`. The last line printed is one JSON object: mean IoU per regime.
"""

from __future__ import annotations

import argparse
import json
import time
from pathlib import Path

from resus.segmentation.loso import REGIMES, run_loso
from resus.segmentation.presets import get_preset
from resus.segmentation.synthetic import synthetic_subject


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--out", type=Path, default=Path("out/segmentation_demo"))
    parser.add_argument("--subjects", type=int, default=3)
    parser.add_argument("--frames", type=int, default=48, help="frames per subject")
    parser.add_argument("--reslices", type=int, default=24, help="reslices per subject")
    parser.add_argument("--preset", default="quick")
    parser.add_argument("--weights", type=Path, help="torchvision ResNet state dict (imagenet)")
    parser.add_argument("--device", default="auto")
    parser.add_argument("--seed", type=int, default=0)
    args = parser.parse_args()

    preset = get_preset(args.preset)
    size = preset.model.image_size
    names = [f"subject{i + 1}" for i in range(args.subjects)]
    frames = [synthetic_subject(n, args.frames, size, seed=i) for i, n in enumerate(names)]
    reslices = [
        synthetic_subject(n, args.reslices, size, seed=100 + i, oblique=True)
        for i, n in enumerate(names)
    ]
    start = time.perf_counter()
    result = run_loso(
        frames,
        reslices,
        REGIMES,
        preset,
        seed=args.seed,
        device=args.device,
        encoder_weights=args.weights,
        out_dir=args.out,
    )
    seconds = time.perf_counter() - start
    args.out.mkdir(parents=True, exist_ok=True)
    (args.out / "loso.json").write_text(json.dumps(result.to_dict(), indent=2) + "\n")
    (args.out / "loso.md").write_text(result.markdown() + "\n")
    print(result.markdown())
    regimes = result.to_dict()["regimes"]
    summary = {
        regime: entry["mean_over_subjects"]["mean"] if entry["status"] == "run" else "not run"
        for regime, entry in regimes.items()
    }
    print(json.dumps({"mean_iou": summary, "seconds": round(seconds, 1)}))


if __name__ == "__main__":
    main()
