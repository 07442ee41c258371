"""`resus sweep export-ros` and `import-ros` through the command line's `main`: a sweep goes to
a ROS 2 MCAP bag and back, and a bad invocation is one line."""

from __future__ import annotations

import numpy as np
from cli_runner import one_line_error, run_main
from sweep_samples import sample_sweep

from resus.sweep.io import read_sweep, write_sweep


def test_export_then_import_through_the_command_line(monkeypatch, capsys, tmp_path):
    run = (monkeypatch, capsys)
    sweep = sample_sweep(n=5, rows=32, cols=48, seed=31)
    write_sweep(tmp_path / "scan.h5", sweep)
    status, out, err = run_main(
        *run, "sweep", "export-ros", tmp_path / "scan.h5", "--out", tmp_path / "scan.mcap"
    )
    assert status == 0, err
    assert "exported 5 frames" in out and "(/us/image, /tf, /tf_static, /us/wrench)" in out
    assert "not exported: labels, joint_positions" in out
    config = tmp_path / "scan_config.xml"
    assert config.is_file()
    status, out, err = run_main(
        *run, "sweep", "import-ros", tmp_path / "scan.mcap", "--image-topic", "/us/image",
        "--tf", "base", "probe", "--calibration", config, "--wrench-topic", "/us/wrench",
        "--out", tmp_path / "back.h5", "--subject", "pig-1",
    )  # fmt: skip
    assert status == 0, err
    assert out.startswith(f"imported 5 of 5 images from {tmp_path / 'scan.mcap'}")
    back = read_sweep(tmp_path / "back.h5")
    np.testing.assert_array_equal(back.frames, sweep.frames)
    np.testing.assert_allclose(back.probe_to_base, sweep.probe_to_base, rtol=0, atol=1e-9)
    np.testing.assert_allclose(back.wrench, sweep.wrench, rtol=0, atol=1e-12)
    assert back.subject == "pig-1" and back.source == "real"


def test_bad_invocations_are_one_line(monkeypatch, capsys, tmp_path):
    run = (monkeypatch, capsys)
    write_sweep(tmp_path / "scan.h5", sample_sweep(n=2))
    run_main(*run, "sweep", "export-ros", tmp_path / "scan.h5", "--out", tmp_path / "scan.mcap")
    calibration = tmp_path / "scan_config.xml"
    common = ["sweep", "import-ros", tmp_path / "scan.mcap", "--image-topic", "/us/image",
              "--calibration", calibration, "--out", tmp_path / "x.h5"]  # fmt: skip
    one_line_error(
        run_main(*run, *common), "give one pose source: --pose-topic TOPIC or --tf PARENT CHILD"
    )
    one_line_error(
        run_main(*run, *common, "--pose-topic", "/pose"),
        f"{tmp_path / 'scan.mcap'}: no pose topic '/pose' in the bag (topics: /tf ",
    )
    one_line_error(
        run_main(*run, *common, "--tf", "base", "tool0"),
        "tf has no chain from 'base' to 'tool0' (frames: base, probe, probe_image)",
    )
    one_line_error(
        run_main(
            *run, "sweep", "export-ros", tmp_path / "scan.h5", "--out", tmp_path / "no/b.mcap"
        ),
        "output folder does not exist",
    )
