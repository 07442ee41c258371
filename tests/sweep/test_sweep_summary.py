"""`summarize_sweep`: a sweep file's numbers against independent computations."""

from __future__ import annotations

import numpy as np
from sweep_samples import STEP, sample_sweep

from resus.sweep.io import write_sweep
from resus.sweep.summary import summarize_sweep
from sim.ultrasound.probe import LinearProbe


def test_geometry_motion_and_contents_of_a_rotating_sweep(tmp_path) -> None:
    sweep = sample_sweep(n=7, rows=24, cols=32, rotate=True)
    path = tmp_path / "rotating.h5"
    write_sweep(path, sweep)
    summary = summarize_sweep(path)
    probe = LinearProbe(cols=32, rows=24)
    assert (summary.frames, summary.rows, summary.cols) == (7, 24, 32)
    np.testing.assert_allclose(summary.pixel_spacing, (probe.width / 32, probe.depth / 24))
    assert summary.duration == sweep.timestamps[-1] - sweep.timestamps[0]
    assert np.isclose(summary.path_length, 6 * STEP)  # the origins step 1 mm along y
    # the image centre, (col, row) = ((32 - 1) / 2, (24 - 1) / 2), through each pose by hand
    centre = sweep.image_to_probe @ np.array([15.5, 11.5, 0.0, 1.0])
    world = np.einsum("nij,j->ni", sweep.probe_to_base, centre)[:, :3]
    steps = np.linalg.norm(world[1:] - world[:-1], axis=1)
    np.testing.assert_allclose(summary.frame_spacing, (steps.mean(), steps.min(), steps.max()))
    assert steps.max() > steps.min() + 1e-3  # rotations move the centre unevenly
    assert summary.label_names == ("background", "artery", "vein")
    assert summary.has_wrench and summary.has_joint_positions
    assert (summary.source, summary.subject) == ("sim", "phantom-7")


def test_one_plain_frame_has_no_frame_spacing_and_no_optional_data(tmp_path) -> None:
    path = tmp_path / "one.h5"
    write_sweep(path, sample_sweep(n=1, optional=False))
    summary = summarize_sweep(path)
    assert (summary.frames, summary.duration, summary.path_length) == (1, 0.0, 0.0)
    assert summary.frame_spacing is None and summary.label_names is None
    fields = dict(summary.lines())
    assert fields["frame spacing"] == "n/a (one frame)"
    assert fields["optional data"] == "none"
