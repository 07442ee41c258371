"""The Sweep data model: what it accepts, what it refuses, and its geometry."""

from __future__ import annotations

import dataclasses

import numpy as np
import pytest
from sweep_samples import sample_sweep

from resus.errors import ResusError
from resus.sweep.model import Sweep, SweepError
from sim.ultrasound.probe import LinearProbe


def test_valid_sweep_keeps_its_arrays_and_types():
    sweep = sample_sweep(n=5)
    assert len(sweep) == 5
    assert sweep.frames.dtype == np.uint8 and sweep.frame_shape == (24, 32)
    assert sweep.probe_to_base.dtype == np.float64 and sweep.probe_to_base.shape == (5, 4, 4)
    assert sweep.label_names == ("background", "artery", "vein")
    assert issubclass(SweepError, ResusError)


def test_created_defaults_to_now_in_iso_8601():
    sweep = sample_sweep(optional=False)
    fresh = Sweep(sweep.frames, sweep.probe_to_base, sweep.timestamps, sweep.image_to_probe)
    assert fresh.created[:4].isdigit() and "T" in fresh.created
    assert fresh.source == "sim" and fresh.subject == "" and fresh.labels is None


def test_pixel_geometry_matches_the_probe_model():
    probe = LinearProbe(cols=32, rows=24)
    sweep = sample_sweep(n=4, rows=24, cols=32)
    assert sweep.pixel_spacing == pytest.approx((probe.pixel_width, probe.pixel_height))
    points = probe.pixel_points()  # probe frame, (rows, cols, 3)
    rows, cols = np.mgrid[0:24, 0:32]
    for index in range(len(sweep)):
        pose = sweep.probe_to_base[index]
        expected = points @ pose[:3, :3].T + pose[:3, 3]
        np.testing.assert_allclose(sweep.pixel_to_world(index, cols, rows), expected, atol=1e-15)
    corners = sweep.frame_corners_world()
    assert corners.shape == (4, 4, 3)
    for index in range(len(sweep)):
        pose = sweep.probe_to_base[index]
        corner_points = points[[0, 0, 23, 23], [0, 31, 31, 0]]
        np.testing.assert_allclose(
            corners[index], corner_points @ pose[:3, :3].T + pose[:3, 3], atol=1e-15
        )


def _broken(**changes):
    fields = {f.name: getattr(sample_sweep(), f.name) for f in dataclasses.fields(Sweep)}
    fields = {name: np.copy(v) if isinstance(v, np.ndarray) else v for name, v in fields.items()}
    for name, change in changes.items():
        fields[name] = change(fields[name]) if callable(change) else change
    return fields


def _set(index, value):
    def change(array):
        array[index] = value
        return array

    return change


def _shear(poses):
    poses[3, 0, 1] += 0.03
    return poses


BAD_SWEEPS = {
    "float frames": (_broken(frames=lambda f: f.astype(float)), "frames must be uint8"),
    "2-D frames": (_broken(frames=lambda f: f[0]), "frames must have 3 dimensions"),
    "no frames": (
        _broken(
            frames=lambda f: f[:0],
            probe_to_base=lambda p: p[:0],
            timestamps=lambda t: t[:0],
            labels=None,
            wrench=None,
            joint_positions=None,
        ),
        "at least one frame",
    ),
    "pose count": (_broken(probe_to_base=lambda p: p[:-1]), "probe_to_base has 5 rows"),
    "pose shape": (_broken(probe_to_base=lambda p: p[:, :3]), "probe_to_base must have shape"),
    "NaN pose": (_broken(probe_to_base=_set((2, 0, 3), np.nan)), "probe_to_base[2][0][3] is nan"),
    "non-rigid pose": (
        _broken(probe_to_base=_shear),
        "probe_to_base[3] is not a rigid transform (error ",
    ),
    "time repeats": (_broken(timestamps=_set(4, 10.15)), "timestamps[4]"),
    "time backwards": (_broken(timestamps=lambda t: t[::-1].copy()), "timestamps[1]"),
    "infinite time": (_broken(timestamps=_set(0, np.inf)), "timestamps[0] is inf"),
    "label value": (_broken(labels=_set((1, 2, 3), 3)), "labels[1] holds value 3"),
    "label shape": (_broken(labels=lambda a: a[:, :-1]), "labels shape"),
    "float labels": (_broken(labels=lambda a: a.astype(np.int64)), "labels must be uint8"),
    "wrench NaN": (_broken(wrench=_set((5, 1), np.nan)), "wrench[5][1] is nan"),
    "wrench shape": (_broken(wrench=lambda w: w[:, :3]), "wrench must have shape (N, 6)"),
    "joint count": (_broken(joint_positions=lambda j: j[:2]), "joint_positions has 2 rows"),
    "singular calibration": (
        _broken(image_to_probe=_set((slice(None), 1), 0.0)),
        "image_to_probe",
    ),
    "NaN calibration": (_broken(image_to_probe=_set((0, 0), np.nan)), "image_to_probe[0][0]"),
    "source": (_broken(source="robot"), "source must be one of sim, real, plus"),
    "created": (_broken(created="yesterday"), "created must be an ISO 8601"),
    "label names": (_broken(label_names=("a", "a", "b")), "label_names must be distinct"),
}


@pytest.mark.parametrize("case", BAD_SWEEPS, ids=list(BAD_SWEEPS))
def test_bad_sweeps_are_refused_with_one_line_naming_the_problem(case):
    fields, message = BAD_SWEEPS[case]
    with pytest.raises(SweepError) as caught:
        Sweep(**fields)
    assert message in str(caught.value)
    assert "\n" not in str(caught.value)
