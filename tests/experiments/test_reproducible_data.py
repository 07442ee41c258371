"""The same inputs make the same files: a scan's sweep, volumes and reslices prepared in two
processes with 1 and 2 numba threads, allocations shifted, in folders of other names, are
byte-identical once SOURCE_DATE_EPOCH fixes the creation times; without it, only those differ."""

from __future__ import annotations

import os
import subprocess
import sys
from pathlib import Path

import h5py
import pytest

from resus.errors import ResusError
from resus.sweep.timestamps import SOURCE_DATE_EPOCH, now_iso

pytestmark = pytest.mark.slow  # two processes simulate, reconstruct and reslice a scan

PREPARE = """
import sys
import numpy as np
from pathlib import Path
from resus.acquisition.patterns import LinearPattern
from resus.experiments.data import ScanSettings, prepare_subjects
from resus.reslicing.reslice import ResliceSettings

shift = np.zeros(int(sys.argv[2]), dtype=np.uint8)  # moves the alignment of later allocations
settings = ScanSettings(
    cols=96,
    rows=96,
    sweep=LinearPattern(length=0.012, speed=0.01, frame_rate=8.0),
    spacing=1.0e-3,
    reslice=ResliceSettings(angles_deg=(0.0, 20.0), step=6, size=32),
)
prepare_subjects(Path(sys.argv[1]), [1], settings, jobs=1, progress=False)
"""
EPOCH = "1764633600"  # 2025-12-02T00:00:00+00:00


def prepare(folder: Path, threads: int, shift: int, epoch: str | None) -> subprocess.Popen:
    environment = {**os.environ, "NUMBA_NUM_THREADS": str(threads)}
    environment.pop(SOURCE_DATE_EPOCH, None)
    if epoch is not None:
        environment[SOURCE_DATE_EPOCH] = epoch
    return subprocess.Popen([sys.executable, "-c", PREPARE, str(folder), str(shift)],
                            env=environment)  # fmt: skip


def files(folder: Path) -> dict[str, bytes]:
    return {str(p.relative_to(folder)): p.read_bytes() for p in folder.rglob("*") if p.is_file()}


def test_two_processes_with_other_threads_write_byte_identical_files(tmp_path):
    runs = [
        prepare(tmp_path / "one", 1, 0, EPOCH),
        prepare(tmp_path / "two", 2, 4099, EPOCH),
        prepare(tmp_path / "clock", 2, 0, None),
    ]
    assert [run.wait(timeout=600) for run in runs] == [0, 0, 0]
    one, two = files(tmp_path / "one"), files(tmp_path / "two")
    names = {"subject_01/" + n for n in ("sweep.h5", "volume.nrrd", "labels.nrrd", "reslices.h5")}
    assert names <= set(one) and set(one) == set(two)
    assert [name for name in one if one[name] != two[name]] == []
    with h5py.File(tmp_path / "one" / "subject_01" / "sweep.h5") as sweep:
        assert sweep.attrs["created"] == "2025-12-02T00:00:00+00:00"
    with h5py.File(tmp_path / "one" / "subject_01" / "reslices.h5") as reslices:
        assert reslices.attrs["source_volume"] == "volume.nrrd"  # not the folder's own name
    assert b"# on 2025-12-02 00:00:00(GMT).\n" in one["subject_01/volume.nrrd"][:200]

    # on the clock: the same arrays, the files differ in their creation times alone
    clock = files(tmp_path / "clock")
    with h5py.File(tmp_path / "clock" / "subject_01" / "sweep.h5") as sweep:
        assert sweep.attrs["created"] != "2025-12-02T00:00:00+00:00"
        with h5py.File(tmp_path / "one" / "subject_01" / "sweep.h5") as fixed:
            for name in ("frames", "labels", "probe_to_base", "timestamps"):
                assert (sweep[name][...] == fixed[name][...]).all(), name
    assert clock["subject_01/labels.nrrd"] != one["subject_01/labels.nrrd"]  # its time comment
    assert clock["subject_01/labels.nrrd"][200:] == one["subject_01/labels.nrrd"][200:]


def test_source_date_epoch_is_now_and_a_bad_one_is_one_error(monkeypatch):
    monkeypatch.setenv(SOURCE_DATE_EPOCH, "0")
    assert now_iso() == "1970-01-01T00:00:00+00:00"
    monkeypatch.setenv(SOURCE_DATE_EPOCH, "yesterday")
    with pytest.raises(ResusError, match="SOURCE_DATE_EPOCH must be whole seconds since 1970, "
                                         "got 'yesterday'"):  # fmt: skip
        now_iso()
