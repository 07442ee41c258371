"""A test-only experiment preset, "tiny", small enough for a whole `experiment` run on 2 cores.

48 x 48 frames, 2 cm sweeps at 8 frames/s, three subjects, the smallest U-Net for one epoch,
two seeds: the same run the quick preset makes, in seconds instead of minutes.
"""

from __future__ import annotations

import dataclasses

from resus.acquisition.patterns import LinearPattern
from resus.experiments.data import ScanSettings
from resus.experiments.tables import ExperimentPreset
from resus.reslicing.reslice import ResliceSettings
from resus.segmentation.presets import QUICK, ModelConfig

TINY_SWEEP = LinearPattern(length=0.02, speed=0.01, frame_rate=8.0)
TINY = ExperimentPreset(
    name="tiny",
    training=dataclasses.replace(
        QUICK,
        model=ModelConfig(
            encoder_name="resnet18", encoder_depth=3, decoder_channels=(16, 8, 4), image_size=48
        ),
        max_epochs=1,
    ),
    scans=ScanSettings(
        cols=48,
        rows=48,
        sweep=TINY_SWEEP,
        spacing=1.0e-3,
        reslice=ResliceSettings(angles_deg=(-20.0, 0.0, 20.0), step=6, size=48),
    ),
    subjects=(0, 1, 2),
    phantom_scans=(TINY_SWEEP, dataclasses.replace(TINY_SWEEP, start=(0.003, -0.035))),
    repeats=2,
)
