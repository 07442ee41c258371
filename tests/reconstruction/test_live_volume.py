"""The live volume compiles the compounding kernel before the scan, not on its first frame."""

from __future__ import annotations

import subprocess
import sys

PROGRAM = """
import numpy as np, rerun as rr
from resus.reconstruction import kernels
from resus.reconstruction.grid import aabb_grid
from resus.reconstruction.live import LiveVolume
assert not kernels.insert_frame.signatures, "compiled before the test began"
grid = aabb_grid(0.002, bounds=(np.array([-0.02, -0.02, -0.03]), np.array([0.02, 0.02, 0.0])))
volume = LiveVolume(rr.RecordingStream("resus-test"), grid, np.eye(4), n_classes=3, every=4)
print(len(kernels.insert_frame.signatures), volume.reconstructor.n_frames, volume.logged)
"""


def test_making_a_live_volume_compiles_the_kernel_and_records_nothing() -> None:
    """A cold numba cache costs seconds on the kernel's first call; in the scanner's control
    loop that stalls the scan while the robot moves on (on a fresh install a 12 mm emulator
    sweep once recorded 3.4 mm of travel, the likely cause). So the constructor compiles it on a
    throwaway frame: a fresh interpreter has the kernel compiled after it, and the volume
    itself holds no frame."""
    run = subprocess.run(
        [sys.executable, "-c", PROGRAM], capture_output=True, text=True, timeout=300
    )
    assert run.returncode == 0, run.stderr
    signatures, frames, logged = map(int, run.stdout.split())
    assert signatures >= 1 and frames == 0 and logged == 0
