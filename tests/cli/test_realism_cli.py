"""`resus realism` end to end on a few simulated frames and three generated real-like PNGs, and
its one-line errors."""

from __future__ import annotations

import json
from pathlib import Path

import cv2
import numpy as np
import pytest
from cli_runner import one_line_error, run_main

from resus.sweep.io import write_sweep
from resus.sweep.model import Sweep
from sim.phantom import Phantom
from sim.ultrasound.probe import LinearProbe
from sim.ultrasound.simulator import UltrasoundSimulator
from sim.ultrasound.skin_pose import probe_pose_on_skin

PROBE = LinearProbe(cols=96, rows=96, depth=0.04)


@pytest.fixture(scope="module")
def sweep_path(tmp_path_factory, default_phantom: Phantom) -> Path:
    """Four frames of the default phantom, 1 cm apart along the vessels, with labels."""
    simulator = UltrasoundSimulator(default_phantom, PROBE)
    poses = [probe_pose_on_skin(default_phantom, 0.0, y) for y in (-0.03, -0.02, -0.01, 0.0)]
    frames, labels = zip(*(simulator.render(pose) for pose in poses), strict=True)
    path = tmp_path_factory.mktemp("realism_cli") / "sweep.h5"
    write_sweep(
        path,
        Sweep(
            frames=np.stack(frames),
            probe_to_base=np.stack(poses),
            timestamps=np.arange(len(poses)) / 30.0,
            image_to_probe=PROBE.image_to_probe(),
            labels=np.stack(labels),
        ),
    )
    return path


def real_like(seed: int, shape: tuple[int, int]) -> tuple[np.ndarray, np.ndarray]:
    """A dark speckled image with an anechoic disc and black padding below, and its mask."""
    rng = np.random.default_rng(seed)
    rows, cols = shape
    grey = 40 + 20 * np.log10(rng.rayleigh(size=shape)) * 255 / 70
    disc = (np.indices(shape)[0] - rows / 3) ** 2 + (np.indices(shape)[1] - cols / 2) ** 2
    lumen = disc <= (rows / 8) ** 2
    grey[lumen] *= 0.6
    grey[int(rows * 0.8) :] = 0
    mask = np.where(lumen, 255, 0).astype(np.uint8)
    mask[int(rows * 0.8) :] = 0
    return np.clip(grey, 1, 255).astype(np.uint8) * (grey > 0), mask


@pytest.fixture
def real_folder(tmp_path: Path) -> Path:
    """Three real-like image/mask pairs: two grey, one RGB, of two sizes."""
    root = tmp_path / "real"
    (root / "images").mkdir(parents=True)
    (root / "masks").mkdir()
    for index, shape in enumerate([(120, 100), (120, 100), (90, 140)]):
        image, mask = real_like(index, shape)
        if index == 2:
            image = np.repeat(image[:, :, None], 3, axis=2)
        cv2.imwrite(str(root / "images" / f"{index:04d}.png"), image)
        cv2.imwrite(str(root / "masks" / f"{index:04d}.png"), mask)
    return root


def test_writes_the_table_and_figures(monkeypatch, capsys, sweep_path, real_folder, tmp_path):
    out = tmp_path / "out"
    status, stdout, err = run_main(monkeypatch, capsys, "realism", "--sweep", sweep_path,
                                   "--sweep", sweep_path, "--real", real_folder, "--out", out,
                                   "--frames", "3")  # fmt: skip
    assert status == 0, err
    summary = json.loads((out / "realism.json").read_text())
    assert summary["simulated"]["images"] == 6  # three frames of each --sweep
    assert summary["real"]["images"] == 3
    assert summary["real"]["pixels"] == 2 * 96 * 100 + 72 * 140  # the black padding left out
    table = {row["figure"]: row for row in summary["table"]}
    simulated, real = table["lumen/tissue"]["simulated"], table["lumen/tissue"]["real"]
    assert simulated < 0.5  # anechoic simulated lumens
    assert real == pytest.approx(0.6, abs=0.1)  # the generated lumens are 0.6 of the tissue
    assert summary["simulated"]["speckle"]["rayleigh_std"] > 0
    assert summary["real"]["speckle"]["rayleigh_std"] is None
    assert table["vessel regions"]["real"] == 3  # one disc in each real-like image
    assert table["vessel aspect, median"]["real"] == pytest.approx(1.0, abs=0.03)
    report = (out / "realism.md").read_text()
    assert "tmkand/usgra-seg (CC BY 4.0)" in report
    assert f"| lumen/tissue | {simulated:.3f} | {real:.3f} |" in report
    assert f"| lumen/tissue | {simulated:.3f} | {real:.3f} |" in stdout
    for name in ("sim_vs_real.png", "histograms.png"):
        picture = cv2.imread(str(out / name))
        assert picture is not None and picture.shape[0] > 300, name


def test_bad_input_is_one_line(monkeypatch, capsys, sweep_path, real_folder, tmp_path) -> None:
    def refused(*args: object, fragments: tuple[str, ...], out: Path = tmp_path / "o") -> None:
        outcome = run_main(monkeypatch, capsys, "realism", *args, "--out", out)
        one_line_error(outcome, *fragments)

    refused("--sweep", sweep_path, "--real", tmp_path / "none",
            fragments=("--real", "none: no such folder"))  # fmt: skip
    refused("--sweep", tmp_path / "missing.h5", "--real", real_folder,
            fragments=("--sweep", "missing.h5: no such file"))  # fmt: skip
    unlabelled = tmp_path / "unlabelled.h5"
    write_sweep(unlabelled, Sweep(frames=np.ones((2, 8, 8), np.uint8),
                                  probe_to_base=np.repeat(np.eye(4)[None], 2, axis=0),
                                  timestamps=np.array([0.0, 0.1]),
                                  image_to_probe=PROBE.image_to_probe()))  # fmt: skip
    refused("--sweep", sweep_path, "--sweep", unlabelled, "--real", real_folder,
            fragments=("--sweep", "unlabelled.h5: the sweep has no labels"))  # fmt: skip
    (tmp_path / "file").write_text("")
    refused("--sweep", sweep_path, "--real", real_folder, out=tmp_path / "file" / "o",
            fragments=("file/o: cannot write the report there",))  # fmt: skip
    (real_folder / "masks" / "0001.png").unlink()
    refused("--sweep", sweep_path, "--real", real_folder,
            fragments=("--real", "images/0001.png: has no mask"))  # fmt: skip
    assert not (tmp_path / "o").exists()
