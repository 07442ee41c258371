"""The README's Sim-to-real figures: the sweeps a simulation-only model trains on, beside the
real images.

The `quick` sim2real preset's 36 subjects of the in-vivo femoral phantom at seed 0, each under
its own random scanner preset, framed, pressed and tilted as `Sim2RealSettings` says, measured
with `resus realism` (32 frames a sweep); realism.json, realism.md and the figures land in
docs/realism/. Real images: tmkand/usgra-seg (CC BY 4.0).

    python scripts/realism_figures.py [--real ../shared/data/real/usgra_seg] [--out docs/realism]
"""

from __future__ import annotations

import argparse
import tempfile
from pathlib import Path

from resus.execution import make_executor
from resus.experiments.realism import read_image_folder, read_sweep_set, write_realism_report
from resus.experiments.sim2real import get_sim2real_preset, simulate_subjects

PRESET, SEED, FRAMES = "quick", 0, 32


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--real", type=Path, default=Path("../shared/data/real/usgra_seg"))
    parser.add_argument("--out", type=Path, default=Path("docs/realism"))
    args = parser.parse_args()
    with tempfile.TemporaryDirectory() as work, make_executor("local", 2) as engine:
        sweeps = simulate_subjects(Path(work), get_sim2real_preset(PRESET), SEED, engine)
        simulated = read_sweep_set(sweeps, FRAMES)
    sources = {
        "sweeps": f"the {PRESET!r} sim2real preset's training sweeps at seed {SEED}",
        "frames per sweep": FRAMES,
        "real": str(args.real),
    }
    comparison = write_realism_report(
        args.out, simulated, read_image_folder(args.real), sources=sources
    )
    print("\n".join(comparison.to_markdown()))


if __name__ == "__main__":
    main()
