"""PLUS .igs.mha import and export: the real spine-phantom sweep lands where PLUS puts it,
and sweeps survive the round trip through the PLUS format."""

from __future__ import annotations

import re
from pathlib import Path

import numpy as np
import pytest
import SimpleITK as sitk
from shared_data import PLUS_CONFIG, PLUS_DATA, PLUS_SEQUENCE
from sweep_samples import sample_sweep

from resus.sweep.model import SweepError
from resus.sweep.plus import (
    export_plus_sequence,
    import_plus_sequence,
    read_plus_calibration,
    write_plus_calibration,
)

SEQUENCE = PLUS_SEQUENCE.name
CONFIG = PLUS_CONFIG.name


@pytest.fixture(scope="module")
def plus_data() -> Path:
    if not PLUS_SEQUENCE.is_file():
        pytest.skip(f"PLUS test data not found at {PLUS_DATA} (shared/ beside the repository)")
    return PLUS_DATA


@pytest.fixture(scope="module")
def spine(plus_data):
    return import_plus_sequence(plus_data / SEQUENCE, read_plus_calibration(plus_data / CONFIG))


def _header_matrices(path: Path, name: str) -> list[np.ndarray]:
    """Per-frame matrices parsed from the raw MetaImage header text, without SimpleITK."""
    text = path.read_bytes()[:200_000].decode("latin-1")
    found = re.findall(rf"Seq_Frame(\d{{4}})_{name} = ([^\n]+)", text)
    return [np.array(values.split(), float).reshape(4, 4) for _, values in sorted(found)]


def test_calibration_is_the_config_image_to_probe_in_metres(plus_data):
    calibration = read_plus_calibration(plus_data / CONFIG)
    assert calibration[0, 3] == pytest.approx(15.3978e-3) and calibration[2, 3] == pytest.approx(
        -8.63446e-3
    )
    assert calibration[1, 0] == pytest.approx(-0.0839128e-3)
    np.testing.assert_array_equal(calibration[3], [0, 0, 0, 1])
    assert np.linalg.norm(calibration[:3, 0]) == pytest.approx(0.0854e-3, rel=1e-3)


def test_spine_sequence_imports_in_the_reference_frame(plus_data, spine):
    assert len(spine) == 21 and spine.frame_shape == (616, 820)
    assert spine.source == "plus" and spine.subject == "SpinePhantomFreehand"
    frames = sitk.GetArrayFromImage(sitk.ReadImage(str(plus_data / SEQUENCE)))
    np.testing.assert_array_equal(spine.frames, frames)
    probe = _header_matrices(plus_data / SEQUENCE, "ProbeToTrackerTransform")
    reference = _header_matrices(plus_data / SEQUENCE, "ReferenceToTrackerTransform")
    for i in range(21):
        expected = np.linalg.inv(reference[i]) @ probe[i]
        np.testing.assert_allclose(spine.probe_to_base[i][:3, :3], expected[:3, :3], atol=1e-5)
        np.testing.assert_allclose(spine.probe_to_base[i][:3, 3] * 1e3, expected[:3, 3], atol=1e-4)
    assert spine.timestamps[0] == 215.102186


def test_frame_corners_give_plus_reference_volume_box(plus_data, spine):
    """PLUS sizes its output volume by the bounding box of every frame's corner pixels."""
    for name in (
        "VolumeReconstructorTestNNMEANvolumeRef.mha",
        "VolumeReconstructorTestLNMAXIvolumeRef.mha",
    ):
        volume = sitk.ReadImage(str(plus_data / name))
        corners = spine.frame_corners_world().reshape(-1, 3) * 1e3  # mm
        low, high = corners.min(axis=0), corners.max(axis=0)
        np.testing.assert_allclose(low, volume.GetOrigin(), atol=1e-3)
        spacing = np.array(volume.GetSpacing())
        assert tuple(np.round((high - low) / spacing).astype(int) + 1) == volume.GetSize()
    assert volume.GetSize() == (147, 106, 105)


def test_spine_round_trip_through_plus_export(tmp_path, spine):
    export_plus_sequence(spine, tmp_path / "spine.igs.mha")
    back = import_plus_sequence(tmp_path / "spine.igs.mha")
    np.testing.assert_array_equal(back.frames, spine.frames)
    np.testing.assert_array_equal(back.timestamps, spine.timestamps)
    np.testing.assert_allclose(back.probe_to_base, spine.probe_to_base, rtol=0, atol=1e-15)
    np.testing.assert_allclose(back.image_to_probe, spine.image_to_probe, rtol=1e-15, atol=0)


def test_synthetic_round_trip_with_a_companion_config(tmp_path):
    sweep = sample_sweep(n=5, optional=False)
    export_plus_sequence(sweep, tmp_path / "s.igs.mha")
    write_plus_calibration(sweep.image_to_probe, tmp_path / "s_config.xml")
    calibration = read_plus_calibration(tmp_path / "s_config.xml")
    np.testing.assert_allclose(calibration, sweep.image_to_probe, rtol=1e-15, atol=0)
    back = import_plus_sequence(tmp_path / "s.igs.mha", calibration)
    np.testing.assert_array_equal(back.frames, sweep.frames)
    np.testing.assert_array_equal(back.timestamps, sweep.timestamps)
    np.testing.assert_allclose(back.probe_to_base, sweep.probe_to_base, rtol=0, atol=1e-15)
    header = (tmp_path / "s.igs.mha").read_bytes()[:20_000].decode("latin-1")
    assert "Seq_Frame0004_ProbeToTrackerTransform = " in header  # millimetres, as PLUS has them
    assert _header_matrices(tmp_path / "s.igs.mha", "ProbeToTrackerTransform")[4][1, 3] == (
        pytest.approx(sweep.probe_to_base[4][1, 3] * 1e3)
    )


def _with_fields(tmp_path, changes: dict[str, str], name="edited.igs.mha") -> Path:
    export_plus_sequence(sample_sweep(n=5, optional=False), tmp_path / "s.igs.mha")
    image = sitk.ReadImage(str(tmp_path / "s.igs.mha"))
    for key, value in changes.items():
        image.SetMetaData(key, value)
    sitk.WriteImage(image, str(tmp_path / name), True)
    return tmp_path / name


def test_frames_without_ok_status_are_skipped_and_reported(tmp_path):
    path = _with_fields(
        tmp_path,
        {
            "Seq_Frame0001_ImageStatus": "INVALID",
            "Seq_Frame0003_ProbeToTrackerTransformStatus": "MISSING",
        },
    )
    skipped = []
    sweep = import_plus_sequence(path, on_skip=lambda i, why: skipped.append((i, why)))
    assert skipped == [(1, "ImageStatus INVALID"), (3, "ProbeToTrackerTransformStatus MISSING")]
    original = sample_sweep(n=5, optional=False)
    np.testing.assert_array_equal(sweep.frames, original.frames[[0, 2, 4]])
    np.testing.assert_array_equal(sweep.timestamps, original.timestamps[[0, 2, 4]])


def test_bad_plus_inputs_name_the_file_and_the_problem(tmp_path, plus_data):
    text = tmp_path / "notes.xml"
    text.write_text("this is not XML <")
    no_calibration = tmp_path / "empty.xml"
    no_calibration.write_text("<PlusConfiguration><CoordinateDefinitions/></PlusConfiguration>")
    cut = tmp_path / "cut.igs.mha"
    cut.write_bytes((plus_data / SEQUENCE).read_bytes()[:1_000_000])
    png = tmp_path / "picture.mha"
    png.write_bytes(b"\x89PNG\r\n\x1a\n" + bytes(200))
    sheared = " ".join(["1 0.1 0 0", "0 1 0 0", "0 0 1 0", "0 0 0 1"])
    cases = [
        (lambda: read_plus_calibration(tmp_path / "none.xml"), "none.xml: no such file"),
        (lambda: read_plus_calibration(text), "not a PLUS config XML"),
        (lambda: read_plus_calibration(no_calibration), 'no <Transform From="Image" To="Probe">'),
        (lambda: import_plus_sequence(tmp_path / "none.igs.mha"), "none.igs.mha: no such file"),
        (lambda: import_plus_sequence(cut), "cut.igs.mha: MetaImage is truncated"),
        (lambda: import_plus_sequence(png), "picture.mha: not a MetaImage"),
        (lambda: import_plus_sequence(text), "not a MetaImage"),
        (lambda: import_plus_sequence(plus_data / SEQUENCE), "has no ImageToProbeTransform"),
        (
            lambda: import_plus_sequence(
                _with_fields(tmp_path, {"UltrasoundImageOrientation": "UF"})
            ),
            "UltrasoundImageOrientation is UF",
        ),
        (
            lambda: import_plus_sequence(
                _with_fields(tmp_path, {"Seq_Frame0002_ProbeToTrackerTransform": sheared})
            ),
            "frame 2 ProbeToTrackerTransform and ReferenceToTrackerTransform is not a rigid",
        ),
        (
            lambda: export_plus_sequence(sample_sweep(), tmp_path / "s.nrrd"),
            "must end in .igs.mha",
        ),
    ]
    for action, message in cases:
        with pytest.raises(SweepError) as caught:
            action()
        assert message in str(caught.value) and "\n" not in str(caught.value), message
