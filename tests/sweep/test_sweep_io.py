"""The sweep file: exact round trips, the schema, streaming, refusing bad files, and a
writer killed with SIGKILL mid-sweep leaving every flushed frame readable."""

from __future__ import annotations

import dataclasses
import signal
import subprocess
import sys
import textwrap

import h5py
import numpy as np
import pytest
from sweep_samples import sample_sweep

from resus.sweep.io import SCHEMA, SweepReader, SweepWriter, read_sweep, write_sweep
from resus.sweep.model import SweepError, SweepFrame

ARRAYS = (
    "frames",
    "probe_to_base",
    "timestamps",
    "image_to_probe",
    "labels",
    "wrench",
    "joint_positions",
)
METADATA = ("label_names", "source", "subject", "created", "provenance")


@pytest.mark.parametrize("optional", [True, False])
def test_round_trip_preserves_every_array_exactly(tmp_path, optional):
    sweep = sample_sweep(n=7, optional=optional)
    write_sweep(tmp_path / "s.h5", sweep)
    back = read_sweep(tmp_path / "s.h5")
    for name in ARRAYS:
        original, restored = getattr(sweep, name), getattr(back, name)
        if original is None:
            assert restored is None, name
        else:
            assert restored.dtype == original.dtype and np.array_equal(restored, original), name
    for name in METADATA:
        assert getattr(back, name) == getattr(sweep, name), name


def test_provenance_round_trips_and_older_files_read_without_it(tmp_path):
    made = {"phantom": "femoral", "subject": 3, "seed": 5, "scanner": None}
    sweep = dataclasses.replace(sample_sweep(n=2), provenance=made)
    write_sweep(tmp_path / "s.h5", sweep)
    assert read_sweep(tmp_path / "s.h5").provenance == made
    with h5py.File(tmp_path / "s.h5", "a") as file:
        del file.attrs["provenance"]  # as written before provenance existed
    assert read_sweep(tmp_path / "s.h5").provenance == {}
    with pytest.raises(SweepError, match="provenance must hold only JSON values"):
        dataclasses.replace(sweep, provenance={"when": object()})


def test_file_layout_is_the_documented_schema(tmp_path):
    sweep = sample_sweep(n=3, rows=8, cols=10)
    write_sweep(tmp_path / "s.h5", sweep)
    with h5py.File(tmp_path / "s.h5", "r") as file:
        shapes = {name: (file[name].shape, file[name].dtype) for name in file}
        assert shapes == {
            "frames": ((3, 8, 10), np.uint8),
            "labels": ((3, 8, 10), np.uint8),
            "probe_to_base": ((3, 4, 4), np.float64),
            "timestamps": ((3,), np.float64),
            "wrench": ((3, 6), np.float64),
            "joint_positions": ((3, 6), np.float64),
        }
        assert set(file.attrs) == {"schema", "image_to_probe", *METADATA}
        assert file.attrs["schema"] == SCHEMA == "resus.sweep/1"
        assert list(file.attrs["label_names"]) == ["background", "artery", "vein"]
        assert file.attrs["image_to_probe"].shape == (4, 4)
        assert file.attrs["source"] == "sim" and file.attrs["subject"] == "phantom-7"


def test_reader_streams_frames_one_at_a_time(tmp_path):
    sweep = sample_sweep(n=9)
    write_sweep(tmp_path / "s.h5", sweep)
    with SweepReader(tmp_path / "s.h5") as reader:
        assert len(reader) == 9 and reader.frame_shape == (24, 32) and reader.has_labels
        assert reader.subject == "phantom-7" and reader.source == "sim"
        np.testing.assert_array_equal(reader.probe_to_base, sweep.probe_to_base)
        frame = reader.frame(4)
        np.testing.assert_array_equal(frame.image, sweep.frames[4])
        np.testing.assert_array_equal(frame.label, sweep.labels[4])
        np.testing.assert_array_equal(frame.wrench, sweep.wrench[4])
        assert frame.timestamp == sweep.timestamps[4]
        assert [f.index for f in reader.iter_frames()] == list(range(9))
        for f in reader.iter_frames():
            np.testing.assert_array_equal(f.image, sweep.frames[f.index])
        with pytest.raises(SweepError, match=r"frame 9 out of range"):
            reader.frame(9)


def test_writer_checks_each_frame_and_keeps_the_good_ones(tmp_path):
    sweep = sample_sweep(n=4)
    path = tmp_path / "s.h5"
    with SweepWriter(path, (24, 32), sweep.image_to_probe, with_labels=True) as writer:

        def labelled(i: int) -> SweepFrame:  # the file keeps labels, no wrench or joints
            return sweep.frame(i)._replace(wrench=None, joint_positions=None)

        for i in range(2):
            writer.append(labelled(i))
        sheared = sweep.probe_to_base[2].copy()
        sheared[0, 1] += 0.05
        bad_frames = [
            ((sweep.frames[2], sheared, 11.0), "probe_to_base[2] is not a rigid transform"),
            ((sweep.frames[2], sweep.probe_to_base[2], 10.0), "timestamps[2]"),
            ((sweep.frames[2][:, :5], sweep.probe_to_base[2], 11.0), "frame 2 has shape (24, 5)"),
            ((sweep.frames[2].astype(float), sweep.probe_to_base[2], 11.0), "must be uint8"),
        ]
        for (frame, pose, time), message in bad_frames:
            with pytest.raises(SweepError) as caught:
                writer.append(SweepFrame(2, frame, pose, time, sweep.labels[2]))
            assert message in str(caught.value) and str(path) in str(caught.value)
        with pytest.raises(SweepError, match="labels missing, but the file has labels"):
            writer.append(SweepFrame(2, sweep.frames[2], sweep.probe_to_base[2], 11.0))
        with pytest.raises(SweepError, match="wrench given, but the file has no wrench"):
            writer.append(
                SweepFrame(
                    2, sweep.frames[2], sweep.probe_to_base[2], 11.0, sweep.labels[2], np.zeros(6)
                )
            )
        seven = np.full((24, 32), 7, np.uint8)
        with pytest.raises(SweepError, match=r"labels\[2\] holds value 7"):
            writer.append(SweepFrame(2, sweep.frames[2], sweep.probe_to_base[2], 11.0, seven))
        with pytest.raises(SweepError, match="frame 3 arrived where frame 2 was due"):
            writer.append(labelled(3))
        assert len(writer) == 2
    with pytest.raises(SweepError, match="writer is closed"):
        writer.append(SweepFrame(2, sweep.frames[2], sweep.probe_to_base[2], 11.0, sweep.labels[2]))
    back = read_sweep(path)
    assert len(back) == 2
    np.testing.assert_array_equal(back.frames, sweep.frames[:2])


def test_writer_refuses_a_folder_that_does_not_exist(tmp_path):
    with pytest.raises(SweepError, match=r"nowhere.*creating the sweep file failed"):
        SweepWriter(tmp_path / "nowhere" / "s.h5", (4, 4), np.eye(4))


# ---- files that are not good sweeps --------------------------------------------------------


def _edit(path, edit):
    with h5py.File(path, "r+") as file:
        edit(file)


def _set_dataset(name, index, value):
    def edit(file):
        data = file[name][...]
        data[index] = value
        del file[name]
        file[name] = data

    return edit


def _replace_dataset(name, data):
    def edit(file):
        del file[name]
        file[name] = data

    return edit


def _delete(name):
    def edit(file):
        del file[name]

    return edit


def _set_attribute(name, value):
    def edit(file):
        file.attrs[name] = value

    return edit


def _no_frames(file: h5py.File) -> None:
    """Every dataset with a row per frame emptied: a sweep that recorded nothing."""
    count = len(file["timestamps"])
    for name in [name for name, item in file.items() if item.ndim and len(item) == count]:
        _replace_dataset(name, file[name][:0])(file)


SHEAR = np.array([[1.0, 0.2, 0, 0], [0, 1, 0, 0], [0, 0, 1, 0], [0, 0, 0, 1]])
BAD_FILES = {
    "NaN pose": (_set_dataset("probe_to_base", (3, 1, 3), np.nan), "probe_to_base[3][1][3] is nan"),
    "non-rigid pose": (
        _set_dataset("probe_to_base", 2, SHEAR),
        "probe_to_base[2] is not a rigid transform",
    ),
    "mismatched shapes": (
        _replace_dataset("probe_to_base", np.repeat(np.eye(4)[None], 3, 0)),
        "mismatched shapes: probe_to_base has 3 rows but timestamps has 6",
    ),
    "frame size vs labels": (
        _replace_dataset("labels", np.zeros((6, 24, 30), np.uint8)),
        "labels must be (N, H, W) uint8 like frames",
    ),
    "time backwards": (_set_dataset("timestamps", 3, 0.0), "timestamps[3]"),
    "wrong schema": (_set_attribute("schema", "resus.volume/1"), "schema is 'resus.volume/1'"),
    "no schema": (lambda f: f.attrs.__delitem__("schema"), "not a resus sweep"),
    "missing frames": (_delete("frames"), "missing dataset 'frames'"),
    "missing calibration": (lambda f: f.attrs.__delitem__("image_to_probe"), "image_to_probe"),
    "singular calibration": (
        _set_attribute("image_to_probe", np.diag([1.0, 0, 1, 1])),
        "image_to_probe is not invertible",
    ),
    "bad source": (_set_attribute("source", "moon"), "source must be one of"),
    "float frames": (
        _replace_dataset("frames", np.zeros((6, 24, 32), np.float32)),
        "frames must be (N, H, W) uint8, got (6, 24, 32) float32",
    ),
    "provenance not JSON": (
        _set_attribute("provenance", "{not json"),
        "attribute 'provenance' is not JSON",
    ),
    "no frames": (_no_frames, "the sweep holds no frames"),
}


@pytest.fixture
def good_file(tmp_path):
    path = tmp_path / "sweep.h5"
    write_sweep(path, sample_sweep(n=6))
    return path


@pytest.mark.parametrize("case", BAD_FILES, ids=list(BAD_FILES))
def test_bad_sweep_files_are_refused_naming_file_and_problem(good_file, case):
    edit, message = BAD_FILES[case]
    _edit(good_file, edit)
    with pytest.raises(SweepError) as caught:
        read_sweep(good_file)
    text = str(caught.value)
    assert text.startswith(f"{good_file}: ") and message in text and "\n" not in text


def test_label_values_beyond_the_names_are_refused_when_read(good_file):
    _edit(good_file, _set_dataset("labels", (4, 0, 0), 9))
    with SweepReader(good_file) as reader:
        reader.frame(3)
        with pytest.raises(SweepError, match=r"labels\[4\] holds value 9"):
            reader.frame(4)
    with pytest.raises(SweepError, match=r"labels\[4\] holds value 9"):
        read_sweep(good_file)


def test_files_that_are_not_sweeps_are_refused(tmp_path, good_file):
    text = tmp_path / "notes.txt"
    text.write_text("not a sweep\n")
    png = tmp_path / "picture.h5"
    png.write_bytes(b"\x89PNG\r\n\x1a\n" + bytes(100))
    half = tmp_path / "half.h5"
    data = good_file.read_bytes()
    half.write_bytes(data[: len(data) // 2])
    damaged = tmp_path / "damaged.h5"
    damaged.write_bytes(data[:2000] + bytes(400) + data[2400:])  # its metadata overwritten
    other = tmp_path / "other.h5"
    with h5py.File(other, "w") as file:
        file["x"] = np.arange(3)
    cases = {
        tmp_path / "missing.h5": "no such file",
        tmp_path: "is a directory",
        text: "not an HDF5 file",
        png: "not an HDF5 file",
        half: "HDF5 file is truncated",
        damaged: "(incorrect metadata checksum",
        other: "not a resus sweep",
    }
    for path, message in cases.items():
        with pytest.raises(SweepError) as caught:
            SweepReader(path)
        assert str(caught.value).startswith(f"{path}: ") and message in str(caught.value), path


# ---- crash safety ---------------------------------------------------------------------------

WRITER = textwrap.dedent(
    """
    import sys
    import numpy as np
    from resus.sweep.io import SweepWriter
    from resus.sweep.model import SweepFrame
    from sim.transforms import make_pose

    calibration = np.diag([1e-4, 1e-4, 1e-4, 1.0])
    with SweepWriter(sys.argv[1], (96, 128), calibration, with_labels=True,
                     with_wrench=True, subject="killed") as writer:
        for i in range(100000):
            image = np.random.default_rng(i).integers(0, 256, (96, 128), dtype=np.uint8)
            pose = make_pose(np.eye(3), (i * 1e-3, 0.0, 0.0))
            writer.append(SweepFrame(i, image, pose, 0.01 * i, label=(image % 3).astype(np.uint8),
                                     wrench=np.full(6, float(i))))
            print(i + 1, flush=True)
    """
)


@pytest.mark.parametrize("kill_after", [1, 13, 60])
def test_writer_killed_mid_sweep_leaves_every_flushed_frame(tmp_path, kill_after):
    path = tmp_path / "killed.h5"
    writer = subprocess.Popen(
        [sys.executable, "-c", WRITER, str(path)], stdout=subprocess.PIPE, text=True
    )
    try:
        flushed = 0
        while flushed < kill_after:
            line = writer.stdout.readline()
            assert line, "the writer stopped before it was killed"
            flushed = int(line)
        writer.send_signal(signal.SIGKILL)  # it keeps appending until the signal lands
    finally:
        writer.kill()
        writer.wait()
    assert writer.returncode == -signal.SIGKILL
    with SweepReader(path) as reader:
        assert len(reader) >= flushed  # every frame it reported is there ...
        assert reader.subject == "killed"
        for frame in reader.iter_frames():  # ... intact, with all its data
            i = frame.index
            image = np.random.default_rng(i).integers(0, 256, (96, 128), dtype=np.uint8)
            np.testing.assert_array_equal(frame.image, image)
            np.testing.assert_array_equal(frame.label, image % 3)
            np.testing.assert_array_equal(frame.wrench, np.full(6, float(i)))
            assert frame.timestamp == 0.01 * i and frame.probe_to_base[0, 3] == i * 1e-3
    assert len(read_sweep(path)) == len(reader)


def test_a_reader_opens_the_file_while_the_writer_still_runs(tmp_path):
    path = tmp_path / "live.h5"
    writer = subprocess.Popen(
        [sys.executable, "-c", WRITER, str(path)], stdout=subprocess.PIPE, text=True
    )
    try:
        while int(writer.stdout.readline() or 0) < 20:
            pass
        with SweepReader(path) as live:
            assert len(live) >= 20
            np.testing.assert_array_equal(live.frame(19).wrench, np.full(6, 19.0))
    finally:
        writer.kill()
        writer.wait()
