"""Artery or vein: the anatomy rule against pressing, on subjects where anatomy holds and where
it misleads.

Each subject (femoral 0-5, and femoral-transposed 0-1, whose artery lies medial to the vein) is
scanned with a two-station compression press (`CompressionPattern`, 10 frames/s) by the
simulated UR3e; its vessels are then mapped from the sweep's true labels with artery and vein
merged, once classed by the anatomy rule (`resus vessels --classify anatomy`: the lateral trunk
is the artery) and once by the press (`--classify compression --merge-classes`), and each map
is scored against the phantom. A rule calls a subject right when both its artery and its vein
overlap the phantom's (Dice above 0.5); swapped classes score near 0.

    python scripts/compare_artery_vein_rules.py [--out /tmp/rules]

Last line: JSON {"subjects": [{"phantom", "subject", "anatomy": {"artery", "vein"},
"compression": {...}}], "anatomy_right", "compression_right"} (Dice per vessel).
"""

from __future__ import annotations

import argparse
import json
import subprocess
import sys
from pathlib import Path

from tqdm import tqdm

from resus.acquisition.patterns import CompressionPattern
from resus.acquisition.simulation import resolve_scene, simulate_sweep

SUBJECTS = [("femoral", k) for k in range(6)] + [("femoral-transposed", k) for k in range(2)]
RULES = {"anatomy": ["--classify", "anatomy"], "compression": ["--classify", "compression"]}
RIGHT = 0.5
"""Dice above which a vessel counts as called right."""


def mapped_dice(sweep: Path, out: Path, flags: list[str]) -> dict[str, float]:
    """Artery and vein Dice of `resus vessels SWEEP --labels-from-sweep FLAGS` (classes merged
    for compression)."""
    merge = ["--merge-classes"] if "compression" in flags else []
    command = [sys.executable, "-m", "resus", "vessels", str(sweep), "--labels-from-sweep"]
    done = subprocess.run(
        [*command, *flags, *merge, "--out", str(out)], capture_output=True, text=True
    )
    if done.returncode != 0:
        raise SystemExit(f"resus vessels failed on {sweep}: {done.stderr.strip()}")
    scores = json.loads((out / "vessels.json").read_text())["scores"]
    return {vessel: round(float(scores[vessel]["dice"]), 3) for vessel in ("artery", "vein")}


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--out", type=Path, default=Path("/tmp/rules"))
    args = parser.parse_args()
    args.out.mkdir(parents=True, exist_ok=True)
    rows = []
    for phantom, subject in tqdm(SUBJECTS, desc="subjects", unit="subject"):
        scene = resolve_scene("default", phantom, subject)
        sweep = args.out / f"{phantom}_{subject}.h5"
        if not sweep.is_file():
            press = CompressionPattern(stations=2, frame_rate=10.0)
            simulate_sweep(sweep, scene, press, progress=False)
        row: dict[str, object] = {"phantom": phantom, "subject": subject}
        for rule, flags in RULES.items():
            row[rule] = mapped_dice(sweep, args.out / f"{phantom}_{subject}_{rule}", flags)
        rows.append(row)
        tqdm.write(json.dumps(row))
    right = {
        rule: sum(all(d > RIGHT for d in row[rule].values()) for row in rows)  # type: ignore[union-attr]
        for rule in RULES
    }
    print(
        json.dumps(
            {
                "subjects": rows,
                "anatomy_right": right["anatomy"],
                "compression_right": right["compression"],
            }
        )
    )


if __name__ == "__main__":
    main()
