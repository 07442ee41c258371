"""Artery or vein by pressing, on synthetic compression sweeps with known answers: a vein whose
cross-section flattens linearly with the force until it shuts at 9 N, and an artery that stays
round and pulses at 72 beats/min, seen by a probe that presses at two stations and slides from
one to the other; then `resus vessels --classify compression` on such a sweep, and on a
simulated press of the deforming femoral phantom."""

import json
import re

import numpy as np
import pytest
from cli_runner import one_line_error, run_main

from resus.acquisition.backends.simulated import SimulatedProbeConfig
from resus.acquisition.patterns import CompressionPattern
from resus.acquisition.simulation import resolve_scene, simulate_sweep
from resus.errors import ResusError
from resus.sweep.io import read_sweep, write_sweep
from resus.sweep.model import Sweep
from resus.vessels.compression import (
    CompressionSettings,
    classify_by_compression,
    fit_hinge,
    spectrum_peak,
)
from resus.vessels.sections import SectionSettings
from sim.labels import ARTERY, VEIN
from sim.ultrasound.probe import LinearProbe

PIXEL = 0.2e-3
"""Pixel size (m) of the synthetic frames: 150 x 150 pixels, 30 mm wide and deep."""
SIZE = 150
DOWN = np.diag([1.0, -1.0, -1.0])
"""Probe orientation: its z (the beam) down, its x (the array) along the world x."""
SKIN = 0.1
"""World z of the skin (m)."""
HEART = 1.2
"""Heart rate (Hz): 72 beats/min."""
PULSE = 0.07
"""The artery's radius swings by this fraction."""
SHUT = 9.0
"""Force (N) at which the vein shuts: its minor axis is 5 mm * (1 - F / SHUT)."""
INDENTATION = 0.3e-3
"""How far (m) the probe sinks into the tissue per newton: the vessels move up the image."""
STATION = (1.0, 2.5, 1.0, 2.5, 1.0)
"""Seconds at light contact, rising, held, falling and at light contact again."""


def press_profile(times: np.ndarray, light: float, press: float) -> np.ndarray:
    """Force (N) at each time of one station's press, starting at 0 s."""
    knots = np.cumsum([0.0, *STATION])
    return np.interp(times, knots, [light, light, press, press, light, light])


def press_sweep(
    artery_x: float = -6e-3,
    vein_x: float = 7e-3,
    light: float = 2.0,
    press: float = 12.0,
    artery_label: int = ARTERY,
    vein_label: int = VEIN,
    seed: int = 0,
    rate: float = 20.0,
    pulse: float = PULSE,
    shut: float = SHUT,
) -> Sweep:
    """Two stations 10 mm apart along y, each pressed `light` -> `press` -> `light` N, with a
    1 s slide between them, `rate` frames/s; vessels along y at world x `artery_x` and
    `vein_x`, 15 and 16 mm under the skin, the artery's radius swinging by `pulse` at HEART,
    the vein shutting at `shut` N. Force with 0.05 N of noise (seeded)."""
    station = float(np.sum(STATION))
    times = np.arange(0.0, 2 * station + 1.0, 1.0 / rate)
    second = times - station - 1.0
    force = np.where(
        times < station, press_profile(times, light, press), press_profile(second, light, press)
    )
    along = 0.01 * np.clip(times - station, 0.0, 1.0)
    rows, cols = np.mgrid[0:SIZE, 0:SIZE]
    lateral, depth = (cols - SIZE / 2) * PIXEL, rows * PIXEL
    labels = np.zeros((len(times), SIZE, SIZE), dtype=np.uint8)
    poses = np.tile(np.eye(4), (len(times), 1, 1))
    for i, (t, f, y) in enumerate(zip(times, force, along, strict=True)):
        sunk = INDENTATION * f
        poses[i, :3, :3], poses[i, :3, 3] = DOWN, [0.0, y, SKIN - sunk]
        radius = 4e-3 * (1 + pulse * np.sin(2 * np.pi * HEART * t))
        artery = (lateral - artery_x) ** 2 + (depth - (15e-3 - sunk)) ** 2 <= radius**2
        labels[i][artery] = artery_label
        minor = 5e-3 * (1 - f / shut)
        if minor > 0:
            vein = ((lateral - vein_x) / 5e-3) ** 2 + ((depth - (16e-3 - sunk)) / minor) ** 2 <= 1
            labels[i][vein] = vein_label
    image_to_probe = np.array(
        [[PIXEL, 0, 0, -SIZE / 2 * PIXEL], [0, 0, 1, 0], [0, PIXEL, 0, 0], [0, 0, 0, 1.0]]
    )
    wrench = np.zeros((len(times), 6))
    noise = np.random.default_rng(seed).normal(0.0, 0.05, len(times))
    wrench[:, :3] = (force + noise)[:, None] * poses[:, :3, 2]
    return Sweep(
        frames=np.full_like(labels, 60), probe_to_base=poses, timestamps=times,
        image_to_probe=image_to_probe, labels=labels, wrench=wrench, source="real",
    )  # fmt: skip


@pytest.fixture(scope="module")
def sweep() -> Sweep:
    return press_sweep()


def test_the_hinge_fit_and_the_spectrum_find_known_laws() -> None:
    forces = np.linspace(2.0, 12.0, 60)
    fit = fit_hinge(forces, 78.5e-6 * np.maximum(0.0, 1 - forces / 9.0))
    assert fit.full_area == pytest.approx(78.5e-6, rel=0.01)
    assert fit.shut_force == pytest.approx(9.0, rel=0.01)
    assert fit_hinge(forces, np.full(60, 50e-6)).shut_force == np.inf
    times = np.sort(np.random.default_rng(1).uniform(0.0, 8.0, 150))  # uneven frame times
    pulse = spectrum_peak(times, 0.3 * np.sin(2 * np.pi * 1.37 * times), (0.5, 4.0))
    assert pulse.frequency == pytest.approx(1.37, abs=0.01)
    assert pulse.amplitude == pytest.approx(0.3, rel=0.05) and pulse.prominence > 8
    noise = spectrum_peak(times, np.random.default_rng(2).normal(size=150), (0.5, 4.0))
    assert noise.prominence < 4  # a pulse stands out of its spectrum; noise does not


def test_the_collapsing_vessel_is_the_vein_and_the_pulsing_one_the_artery(sweep) -> None:
    result = classify_by_compression(sweep, sweep.labels)
    # One track per vessel, through the indentation (3.6 mm up the image at 12 N), the
    # vein's shut frames and the slide between stations.
    assert len(result.calls) == 2, [call.to_dict() for call in result.calls]
    artery, vein = sorted(result.calls, key=lambda call: call.centre[0])
    assert (artery.call, vein.call) == ("artery", "vein")
    assert artery.confidence > 0.95 and vein.confidence == 1.0
    # The vein: area pi 5 mm x 5 mm (1 - F / 9 N): shut from 9 N on.
    assert vein.fit.full_area == pytest.approx(np.pi * 25e-6, rel=0.02)
    assert vein.fit.shut_force == pytest.approx(SHUT, rel=0.03)
    assert vein.collapse_ratio == 0.0 and vein.roundness == 0.0
    # The artery: round, open (no area lost to the press), pulsing at 72 beats/min with an
    # area swing of about 2 x 7 %.
    assert artery.collapse_ratio > 0.95 and artery.roundness > 0.95
    assert artery.peak_frequency == pytest.approx(HEART, abs=0.02) and artery.pulsatile
    assert 0.08 < artery.pulsation < 0.16
    assert artery.to_dict()["heart_rate_bpm"] == pytest.approx(72.0, abs=1.5)
    # Both centres where the vessels run (x), 15-16 mm under the skin (z).
    assert artery.centre[0] == pytest.approx(-6e-3, abs=2e-4)
    assert vein.centre[0] == pytest.approx(7e-3, abs=2e-4)
    assert SKIN - artery.centre[2] == pytest.approx(15e-3, abs=5e-4)


def test_swapped_or_merged_labels_are_relabelled_by_the_press() -> None:
    swapped = press_sweep(artery_label=VEIN, vein_label=ARTERY)
    for merge in (False, True):
        settings = CompressionSettings(sections=SectionSettings(merge_classes=merge))
        labels = swapped.labels if not merge else (swapped.labels > 0).astype(np.uint8)
        result = classify_by_compression(swapped, labels, settings)
        artery, vein = sorted(result.calls, key=lambda call: call.centre[0])
        assert (artery.call, vein.call) == ("artery", "vein")
        assert artery.labelled == (VEIN if not merge else ARTERY)
        left, right = result.labels[:, :, :75], result.labels[:, :, 75:]
        assert set(np.unique(left)) == {0, ARTERY} and set(np.unique(right)) == {0, VEIN}


def test_a_track_pressed_too_little_is_unknown_and_keeps_its_labels() -> None:
    light = press_sweep(press=3.0)
    result = classify_by_compression(light, light.labels)
    assert {call.call for call in result.calls} == {"unknown"}
    assert re.match(r"pressed over 1\.\d N only \(less than 3 N\)", result.calls[0].reason)
    np.testing.assert_array_equal(result.labels, light.labels)
    no_wrench = Sweep(light.frames, light.probe_to_base, light.timestamps, light.image_to_probe,
                      labels=light.labels)  # fmt: skip
    with pytest.raises(ResusError, match="needs the sweep's wrench"):
        classify_by_compression(no_wrench, light.labels)
    with pytest.raises(ResusError, match=r"CompressionSettings needs 0 < shut_ratio"):
        CompressionSettings(collapse_ratio=0.9)
    with pytest.raises(ResusError, match=r"SectionSettings\.max_gap must be positive, got 0"):
        SectionSettings(max_gap=0)


def test_without_a_pulse_the_open_vessel_is_the_artery_only_beside_a_collapsing_vein() -> None:
    still = press_sweep(pulse=0.0)
    artery, vein = sorted(classify_by_compression(still, still.labels).calls,
                          key=lambda call: call.centre[0])  # fmt: skip
    assert (artery.call, vein.call) == ("artery", "vein") and not artery.pulsatile
    assert artery.confidence == pytest.approx(0.5 + 0.5 * 2 / 3, abs=0.01)  # open, round
    rigid = press_sweep(pulse=0.0, shut=1e9)  # tissue that does not answer the probe
    calls = classify_by_compression(rigid, rigid.labels).calls
    assert [call.call for call in calls] == ["unknown", "unknown"]
    assert all(call.reason.endswith("neither it nor any vessel beside it collapses or pulses")
               for call in calls)  # fmt: skip


def test_an_open_vessel_without_a_pulse_beside_a_pulsing_artery_is_a_vein() -> None:
    """A vein the press does not shut (it shuts at 40 N here, ratio 0.75 at 12 N) is told from
    the artery by its missing pulse."""
    stiff = press_sweep(shut=40.0)
    artery, vein = sorted(classify_by_compression(stiff, stiff.labels).calls,
                          key=lambda call: call.centre[0])  # fmt: skip
    assert (artery.call, vein.call) == ("artery", "vein") and artery.pulsatile
    assert vein.collapse_ratio == pytest.approx(1 - 10 / 38, abs=0.02)  # 2 -> 12 N of 40 N
    assert vein.confidence == pytest.approx(0.5 + 0.25 * (0.8 - vein.collapse_ratio) / 0.3)
    assert vein.reason.endswith("beside one that pulses: a vein the press did not shut")


def test_vessels_command_classifies_by_compression_where_anatomy_misleads(
    tmp_path, monkeypatch, capsys
) -> None:
    """The artery lies medial of the vein here: the anatomy rule swaps them, the press does not."""
    path = tmp_path / "press.h5"
    write_sweep(path, press_sweep(artery_label=VEIN, vein_label=ARTERY, rate=10.0))
    common = ["vessels", path, "--labels-from-sweep", "--spacing", "0.6e-3"]
    status, stdout, err = run_main(monkeypatch, capsys, *common, "--classify", "compression",
                                   "--out", tmp_path / "press")  # fmt: skip
    assert status == 0, err
    assert "2 vessel tracks by compression: 1 artery, 1 vein, 0 unknown" in stdout
    written = json.loads((tmp_path / "press" / "vessels.json").read_text())
    calls = {track["call"]: track for track in written["compression"]["tracks"]}
    assert calls["vein"]["area_vs_force"]["shut_force_n"] == pytest.approx(SHUT, rel=0.03)
    assert calls["artery"]["heart_rate_bpm"] == pytest.approx(72.0, abs=1.5)
    assert calls["artery"]["centre_mm"][0] < calls["vein"]["centre_mm"][0]
    parts = {part["label"]: part for part in written["parts"]}
    assert parts["artery"]["centroid_mm"][0] < 0 < parts["vein"]["centroid_mm"][0]
    relabelled = read_sweep(tmp_path / "press" / written["compression"]["relabelled_sweep"])
    assert relabelled.labels is not None
    assert set(np.unique(relabelled.labels[:, :, 75:])) == {0, VEIN}
    # The anatomy rule calls the lateral vessel (+x on this right leg) the artery: wrong here.
    status, _, err = run_main(monkeypatch, capsys, *common, "--out", tmp_path / "anatomy")
    assert status == 0, err
    anatomy = json.loads((tmp_path / "anatomy" / "vessels.json").read_text())
    parts = {part["label"]: part for part in anatomy["parts"]}
    assert parts["artery"]["centroid_mm"][0] > 0 > parts["vein"]["centroid_mm"][0]


def test_vessels_command_refuses_what_compression_cannot_use(tmp_path, monkeypatch, capsys):
    sweep = press_sweep()
    path = tmp_path / "no_wrench.h5"
    write_sweep(path, Sweep(sweep.frames, sweep.probe_to_base, sweep.timestamps,
                            sweep.image_to_probe, labels=sweep.labels, source="real"))  # fmt: skip
    common = ["vessels", path, "--labels-from-sweep", "--out", tmp_path / "o"]
    one_line_error(run_main(monkeypatch, capsys, *common, "--classify", "compression"),
                   "--classify compression needs the force of every frame", str(path))  # fmt: skip
    one_line_error(run_main(monkeypatch, capsys, *common, "--classify", "pressure"),
                   "--classify must be one of anatomy, compression")  # fmt: skip
    one_line_error(run_main(monkeypatch, capsys, *common, "--merge-classes"),
                   "--merge-classes applies to --classify compression only")  # fmt: skip


def test_a_simulated_press_of_the_femoral_phantom_is_told_apart(tmp_path, monkeypatch, capsys):
    """End to end on the deforming femoral phantom: the compression plan scanned in simulation
    (the vein flattens with the probe's stress, the artery pulses at 72 beats/min), then
    `resus vessels --classify compression` on the sweep's own labels."""
    scene = resolve_scene("default", "femoral", None)
    path = tmp_path / "press.h5"
    pattern = CompressionPattern(stations=2, station_spacing=0.01, frame_rate=10.0)
    probe = SimulatedProbeConfig(probe=LinearProbe(cols=96, rows=96, depth=0.04), frame_rate=10.0)
    simulate_sweep(path, scene, pattern, probe=probe, progress=False)
    status, _, err = run_main(monkeypatch, capsys, "vessels", path, "--labels-from-sweep",
                              "--classify", "compression", "--spacing", "0.5e-3",
                              "--out", tmp_path / "map")  # fmt: skip
    assert status == 0, err
    written = json.loads((tmp_path / "map" / "vessels.json").read_text())
    tracks = [t for t in written["compression"]["tracks"] if t["call"] != "unknown"]
    # Every vessel seen through the press is called what the phantom made it.
    assert tracks and all(t["call"] == t["labelled"] for t in tracks), tracks
    artery = max((t for t in tracks if t["call"] == "artery"), key=lambda t: t["frames"])
    vein = max((t for t in tracks if t["call"] == "vein"), key=lambda t: t["frames"])
    # The femoral vein: under half its light-contact area at the press (measured 0.03); the
    # artery: its area within its pulsation (ratio 0.96), pulsing at the phantom's 72/min.
    assert vein["area_vs_force"]["collapse_ratio"] < 0.5 and vein["confidence"] > 0.9
    assert artery["area_vs_force"]["collapse_ratio"] > 0.9
    assert artery["heart_rate_bpm"] == pytest.approx(72.0, abs=3.0)
    assert written["scores"]["vein"]["dice"] > 0.5, written["scores"]


@pytest.mark.parametrize(
    ("changes", "message"),
    [
        ({"min_frames": 2}, r"CompressionSettings\.min_frames must be at least 3, got 2$"),
        ({"min_force_span": 0.0}, r"CompressionSettings\.min_force_span must be positive, got 0"),
        ({"trend_window": -1.0}, r"CompressionSettings\.trend_window must be positive, got -1"),
        ({"min_prominence": 0.0}, r"CompressionSettings\.min_prominence must be positive"),
        ({"round_ratio": 1.5}, r"CompressionSettings\.round_ratio must lie in \(0, 1\], got 1\.5"),
        ({"heart_band": (1.7, 1.0)}, r"CompressionSettings\.heart_band must be \(low, high\) Hz"),
        ({"spectrum_band": (0.0, 4.0)}, r"CompressionSettings\.spectrum_band must be \(low, hi"),
        ({"shut_ratio": 0.0}, r"CompressionSettings needs 0 < shut_ratio < collapse_ratio"),
    ],
)
def test_every_refused_compression_setting_is_named(changes: dict, message: str) -> None:
    with pytest.raises(ResusError, match=rf"^{message}"):
        CompressionSettings(**changes)
