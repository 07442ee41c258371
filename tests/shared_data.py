"""Where the project's shared test data lies (`../shared/data` beside the checkout), and markers
that skip a test cleanly when a clone has no such folder."""

from __future__ import annotations

from pathlib import Path

import pytest

SHARED_DATA = Path(__file__).resolve().parents[1].parent / "shared" / "data"
PLUS_DATA = SHARED_DATA / "plus"
PLUS_SEQUENCE = PLUS_DATA / "SpinePhantomFreehand.igs.mha"
PLUS_CONFIG = PLUS_DATA / "Config_VolumeReconstruction_SpinePhantom_NN_MEAN.xml"
REAL_DATA = SHARED_DATA / "real" / "usgra_seg"

requires_plus_data = pytest.mark.skipif(
    not PLUS_SEQUENCE.is_file(), reason=f"PLUS test data not found at {PLUS_DATA}"
)
requires_real_data = pytest.mark.skipif(
    not (REAL_DATA / "images").is_dir(), reason=f"real images not found at {REAL_DATA}"
)
