"""`resus demo` at its smallest size: every artefact exists and is valid, and the report's
numbers are the ones in summary.json beside it."""

from __future__ import annotations

import json
import re
from pathlib import Path

import pytest
import trimesh
from cli_runner import resus
from matplotlib.image import imread
from rerun_readback import Recording

from resus.experiments.demo_report import number
from resus.reconstruction.io import read_volume
from resus.segmentation.checkpoint import load_checkpoint
from resus.sweep.io import read_sweep

pytestmark = pytest.mark.slow  # the demo and experiments run whole pipelines

SMALLEST = ("--subjects", "0,1", "--image-size", "48", "--sweep-length", "0.012", "--epochs", "1")


@pytest.fixture(scope="module")
def demo(tmp_path_factory) -> tuple[Path, str]:
    out = tmp_path_factory.mktemp("demo") / "out"
    done = resus("demo", "--out", out, *SMALLEST, timeout=600)
    assert done.returncode == 0, done.stdout + done.stderr
    return out, done.stdout


def test_demo_prints_where_everything_is(demo) -> None:
    out, stdout = demo
    for where in (out / "report.md", f"rerun {out / 'demo.rrd'}", out / "data"):
        assert str(where) in stdout


def test_every_file_the_summary_lists_exists_and_is_valid(demo) -> None:
    out, _ = demo
    files = json.loads((out / "summary.json").read_text())["files"]
    for name in [*files["pictures"], *files["curves"], *files["vessel_pictures"]]:
        picture = imread(out / name)
        assert picture.ndim == 3 and min(picture.shape[:2]) > 100, name
    for name in files["checkpoints"]:
        _, config = load_checkpoint(out / name)
        assert config["model"]["image_size"] == 64
    for name in files["meshes"]:
        mesh = trimesh.load(out / name, force="mesh")
        assert len(mesh.faces) > 100, name
    for name in files["volumes"]:
        volume, grid, _ = read_volume(out / name)
        assert volume.shape == grid.shape and volume.any(), name
    for name in files["sweeps"]:
        sweep = read_sweep(out / name)
        assert sweep.frames.shape[1:] == (48, 48) and sweep.labels is not None


def test_recording_holds_the_scan_volume_maps_and_curves(demo) -> None:
    out, _ = demo
    summary = json.loads((out / "summary.json").read_text())
    recording = Recording(out / "demo.rrd")
    test_frames = summary["frames"]["test"]
    assert len(recording.temporal["/frame/image"]) == test_frames
    assert len(recording.temporal["/frame/prediction"]) == test_frames
    assert "/world/volume/slices/i" in recording.static
    assert "/world/phantom/vein" in recording.static
    assert "/world/vessel_map/ground_truth/vein" in recording.static
    assert recording.temporal["/training/train_loss"]
    assert recording.blueprints


def test_report_numbers_come_from_summary_json(demo) -> None:
    out, _ = demo
    summary = json.loads((out / "summary.json").read_text())
    report = (out / "report.md").read_text()
    for iou in summary["iou"].values():
        for value in (iou["artery"], iou["vein"], iou["mean"]):
            assert number(value) in report
    for result in summary["vessels"].values():
        for score in result["scores"].values():
            assert number(score["dice"]) in report
            assert number(score["mean_surface_distance_mm"]) in report
    assert number(summary["total_seconds"], 1) in report
    for target in re.findall(r"\]\(([^)]+)\)", report):
        assert (out / target).is_file(), target


def test_ground_truth_map_of_the_held_out_sweep_is_close_to_the_phantom(demo) -> None:
    out, _ = demo
    scores = json.loads((out / "summary.json").read_text())["vessels"]["ground_truth"]["scores"]
    for vessel in ("artery", "vein"):
        assert scores[vessel]["dice"] > 0.8
        assert scores[vessel]["mean_surface_distance_mm"] < 0.5


def test_demo_refuses_bad_settings_in_one_line(tmp_path: Path) -> None:
    for args, fragment in (
        (("--subjects", "3"), "--subjects"),
        (("--subjects", "0,x"), "--subjects"),
        (("--epochs", "0"), "--epochs"),
    ):
        done = resus("demo", "--out", tmp_path / "o", *args, timeout=60)
        assert done.returncode == 2 and fragment in done.stderr, done.stderr
        assert "Traceback" not in done.stderr and len(done.stderr.strip().splitlines()) == 1
    (tmp_path / "file").write_text("x")
    done = resus("demo", "--out", tmp_path / "file", *SMALLEST, timeout=60)
    assert done.returncode == 2 and "not a folder" in done.stderr
    assert "Traceback" not in done.stderr
