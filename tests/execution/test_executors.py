"""The executor interface and the local engine: order, cores, errors, names; resumable units.

Nothing here starts Ray (`test_ray_engine.py` does, once): the Ray engine's checks that need
no cluster (names, address forms, an address where nothing answers) are here.
"""

from __future__ import annotations

import hashlib
import json
import os
import re
from pathlib import Path

import pytest
from cli_runner import free_port
from executor_units import CountedSquare, abort_scan, count_and_square, granted, refuse

from resus.acquisition.scanner import ScanAborted, ScanResult
from resus.errors import ResusError
from resus.execution import (
    LocalExecutor,
    RayExecutor,
    Resources,
    UnitRecord,
    file_digest,
    make_executor,
    run_pending,
)
from resus.execution.executor import available_cores


def die(_: object) -> None:
    """A unit whose worker process dies under it."""
    os._exit(3)


def test_local_executor_keeps_order_in_and_out_of_process():
    items = [-3, 1, -2, 5]
    for jobs in (1, 2):
        assert LocalExecutor(jobs).map(abs, items, "t", "x", progress=False) == [3, 1, 2, 5]
    assert LocalExecutor(2).map(abs, [], "t", "x", progress=False) == []


def test_units_share_the_local_cores_by_their_resources():
    local = LocalExecutor(4)
    assert local.workers(10) == 4 and local.workers(3) == 3 and local.workers(1) == 1
    assert local.workers(10, Resources(cpus=2)) == 2 and local.workers(10, Resources(cpus=8)) == 1
    # a worker gets an equal share of the machine's cores (at least one); this process keeps all
    share = max(1, available_cores() // 2)
    assert LocalExecutor(2).map(granted, [0, 1], "t", "x", progress=False) == [share, share]
    assert LocalExecutor(1).map(granted, [0, 1], "t", "x", progress=False) == [None, None]


def test_a_unit_error_reaches_the_caller_as_raised():
    with pytest.raises(ResusError, match=r"^item -2 is negative$"):
        LocalExecutor(2).map(refuse, [1, -2, 3], "t", "x", progress=False)


def test_an_aborted_scan_in_a_worker_keeps_its_reason_and_result():
    """A ScanAborted raised in a spawned worker crosses back whole (pickled from its reason
    and result), not as a broken pool reported as a dead worker."""
    with pytest.raises(ScanAborted, match=r"^scan stopped: no stable contact in unit \d; ") as info:
        LocalExecutor(2).map(abort_scan, [0, 1], "scans", "scan", progress=False)
    unit = int(info.value.reason.rsplit(" ", 1)[1])
    assert info.value.result == ScanResult(Path("s.h5"), unit, 0.5)


def test_a_dead_local_worker_is_one_line_that_says_how_to_resume():
    with pytest.raises(ResusError, match=r"scans: a worker process died .* run again to resume"):
        LocalExecutor(2).map(die, [0, 1], "scans", "scan", progress=False)


def test_names_resources_and_addresses_are_checked():
    with pytest.raises(ResusError, match=r"^unknown executor 'foo', expected local or ray$"):
        make_executor("foo")
    with pytest.raises(ResusError, match=r"only the ray executor takes an address"):
        make_executor("local", address="auto")
    with pytest.raises(ResusError, match=r"executor jobs must be at least 1"):
        make_executor("local", 0)
    with pytest.raises(ResusError, match=r"Resources\.cpus must be at least 1"):
        Resources(cpus=0)
    with pytest.raises(ResusError, match=r"Resources\.gpus must be a fraction"):
        Resources(gpus=1.5)
    assert Resources(gpus=2).gpus == 2 and Resources(gpus=0.25).gpus == 0.25
    for address in ("head", "http://head:10001", "ray://head", "head:port"):
        with pytest.raises(ResusError, match=r"must be auto, ray://HOST:PORT or HOST:PORT"):
            make_executor("ray", address=address)
    with pytest.raises(ResusError, match=r"port must be in 1\.\.65535"):
        RayExecutor(2, "127.0.0.1:70000")
    port = free_port()
    for address in (f"127.0.0.1:{port}", f"ray://127.0.0.1:{port}"):
        unreachable = re.escape(f"cannot reach a Ray cluster at '{address}'")
        with pytest.raises(ResusError, match=unreachable):
            make_executor("ray", address=address)
    # a Ray of its own starts only when a unit needs it: making one costs nothing
    assert make_executor("ray", 2).describe() == "ray, on this machine (2 CPUs, 127.0.0.1)"


def test_a_record_counts_only_with_its_settings_and_its_outputs(tmp_path):
    output = tmp_path / "out.txt"
    record = UnitRecord(tmp_path / "done" / "unit.json", {"size": (1, 2)}, (output,))
    assert not record.done()
    record.finish({"frames": 3})
    assert not record.done()  # its output is missing
    output.write_text("x")
    assert record.done() and record.result() == {"frames": 3}
    assert json.loads(record.path.read_text())["key"] == {"size": [1, 2]}
    assert not UnitRecord(record.path, {"size": (1, 3)}, (output,)).done()
    assert list(record.path.parent.iterdir()) == [record.path]  # no temporary file left


def test_a_file_digest_is_its_content_and_follows_a_replacement(tmp_path):
    path = tmp_path / "weights.pth"
    path.write_bytes(b"first weights")
    assert file_digest(path) == hashlib.sha256(b"first weights").hexdigest()[:16]
    path.write_bytes(b"other weights, same name")
    assert file_digest(path) == hashlib.sha256(b"other weights, same name").hexdigest()[:16]


def runs_of(folder: Path, item: int) -> int:
    path = folder / f"ran_{item}"
    return len(path.read_text().splitlines()) if path.exists() else 0


def test_a_resumed_run_recomputes_nothing_that_finished(tmp_path):
    (tmp_path / "fail").touch()
    units = [CountedSquare(k, tmp_path) for k in range(4)]
    with pytest.raises(ResusError, match=r"unit 2 failed"):
        run_pending(LocalExecutor(1), count_and_square, units, "t", "x", progress=False)
    assert [runs_of(tmp_path, k) for k in range(4)] == [1, 1, 0, 0]  # in order, in this process
    finished = {k: units[k].record().path.stat().st_mtime_ns for k in (0, 1)}
    (tmp_path / "fail").unlink()
    results = run_pending(LocalExecutor(2), count_and_square, units, "t", "x", progress=False)
    assert results == [0, 1, 4, 9]
    assert [runs_of(tmp_path, k) for k in range(4)] == [1, 1, 1, 1]
    assert {k: units[k].record().path.stat().st_mtime_ns for k in (0, 1)} == finished
    assert run_pending(LocalExecutor(2), count_and_square, units, "t", "x") == [0, 1, 4, 9]
    assert [runs_of(tmp_path, k) for k in range(4)] == [1, 1, 1, 1]
