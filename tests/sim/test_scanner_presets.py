"""Scanner presets: each knob moves the image the way the physics says."""

from __future__ import annotations

import dataclasses
import math
import re

import numpy as np
import pytest

from sim.labels import ARTERY, VEIN
from sim.phantom import Phantom
from sim.phantom.loader import load_phantom
from sim.ultrasound.probe import LinearProbe
from sim.ultrasound.scanner import (
    RANDOM_RANGES,
    TGC_ATTENUATION_RANGE,
    ScannerPreset,
    load_scanner_preset,
    named_presets,
    random_preset,
    scanner_preset,
    scanners_dir,
)
from sim.ultrasound.settings import UltrasoundSettings
from sim.ultrasound.simulator import UltrasoundSimulator

SMALL_PROBE = LinearProbe(width=0.012, cols=96, rows=192)
"""A narrow probe, so that a pose beside the vessels sees tissue only."""
PLAIN = ScannerPreset(
    name="plain",
    gain_db=26.0,
    dynamic_range_db=60.0,
    clutter_db=None,
    grey_gamma=1.0,
    speckle_smoothing=0.0,
    electronic_noise_db=-60.0,
    reverberation=0.0,
)
"""No clutter, identity grey map, negligible noise, no reverberation: the knobs under test act
alone."""


@pytest.fixture(scope="module")
def phantom() -> Phantom:
    return Phantom(load_phantom("default"))


def looking_down(x: float, y: float = 0.0) -> np.ndarray:
    """Probe pose in the phantom frame: face on the gel at (x, y), imaging straight down,
    the array along x."""
    return np.array(
        [[1.0, 0, 0, x], [0, -1.0, 0, y], [0, 0, -1.0, -0.0003], [0, 0, 0, 1.0]], dtype=np.float64
    )


def render(
    phantom: Phantom,
    preset: ScannerPreset,
    x: float = 0.035,
    probe: LinearProbe = SMALL_PROBE,
    base: UltrasoundSettings | None = None,
) -> tuple[np.ndarray, np.ndarray]:
    simulator = UltrasoundSimulator(phantom, preset.probe(probe), preset.settings(base))
    image, labels = simulator.render(looking_down(x))
    return image.astype(np.float64), labels


def grey_slope(image: np.ndarray, depth: float, rows: slice) -> float:
    """Least-squares slope (grey levels per cm) of the row means over `rows` of an image of
    `depth` (m) imaged in `SMALL_PROBE.rows` rows."""
    depth_cm = (np.arange(SMALL_PROBE.rows) + 0.5) * depth / SMALL_PROBE.rows * 100
    return float(np.polyfit(depth_cm[rows], image[rows].mean(axis=1), 1)[0])


def correlation_width(image: np.ndarray, axis: int) -> float:
    """Full width (pixels) at half maximum of the image's mean autocorrelation along `axis`,
    interpolated between lags."""
    centred = image - image.mean(axis=axis, keepdims=True)
    spectrum = np.abs(np.fft.rfft(centred, n=2 * image.shape[axis], axis=axis)) ** 2
    correlation = np.fft.irfft(spectrum, axis=axis).mean(axis=1 - axis)
    correlation = correlation / correlation[0]
    below = int(np.argmax(correlation < 0.5))
    fraction = (correlation[below - 1] - 0.5) / (correlation[below - 1] - correlation[below])
    return 2.0 * (below - 1 + fraction)


def test_higher_frequency_gives_finer_speckle(phantom) -> None:
    """Lateral width ~ wavelength x F-number and pulse length ~ 1 / bandwidth: doubling the
    frequency halves the speckle grain both ways. Rows of 0.05 mm and a 0.05 mm scatterer
    lattice, so that neither bounds the grain."""
    fine = dataclasses.replace(PLAIN, depth=0.01, focal_depth=0.005)
    lattice = UltrasoundSettings(scatterer_spacing=0.05e-3)
    low = dataclasses.replace(fine, centre_frequency=6.0e6)
    high = dataclasses.replace(fine, centre_frequency=12.0e6)
    low_image = render(phantom, low, base=lattice)[0][40:160]
    high_image = render(phantom, high, base=lattice)[0][40:160]
    for axis in (0, 1):  # axial, lateral
        assert correlation_width(high_image, axis) < 0.6 * correlation_width(low_image, axis)
    assert high.lateral_resolution == pytest.approx(low.lateral_resolution / 2)


def test_higher_frequency_attenuates_more_with_depth(phantom) -> None:
    """With the TGC off, grey falls with depth at 2 x alpha x f dB per cm (round trip) times
    the grey levels per dB: twice as steep at twice the frequency."""
    slopes = []
    for frequency in (5.0e6, 10.0e6):
        preset = dataclasses.replace(
            PLAIN,
            centre_frequency=frequency,
            gain_db=50.0,
            dynamic_range_db=80.0,
            tgc_attenuation=0.0,
        )
        image = render(phantom, preset)[0]
        slopes.append(grey_slope(image, preset.depth, slice(20, 150)))  # clear of face, floor
        gel_attenuation = phantom.spec.layers[0].attenuation_db_cm_mhz
        expected = -2.0 * gel_attenuation * frequency / 1e6 * 255.0 / 80.0
        assert slopes[-1] == pytest.approx(expected, rel=0.15)
    assert slopes[1] == pytest.approx(2.0 * slopes[0], rel=0.15)


@pytest.mark.parametrize("compensated_share", [0.0, 0.5, 1.0])
def test_tgc_undoes_the_attenuation_it_is_set_for(phantom, compensated_share: float) -> None:
    """A TGC set for attenuation a over tissue that attenuates alpha leaves grey falling at
    2 (alpha - a) f dB per cm: flat when it compensates all of it, half as steep for half."""
    preset = dataclasses.replace(PLAIN, gain_db=50.0, dynamic_range_db=80.0)
    gel_attenuation = phantom.spec.layers[0].attenuation_db_cm_mhz
    compensated = dataclasses.replace(preset, tgc_attenuation=compensated_share * gel_attenuation)
    image = render(phantom, compensated)[0]
    slope = grey_slope(image, preset.depth, slice(20, 150))  # clear of the face and the floor
    uncompensated = -2.0 * gel_attenuation * preset.centre_frequency / 1e6 * 255.0 / 80.0
    expected = (1 - compensated_share) * uncompensated
    assert slope == pytest.approx(expected, abs=0.1 * abs(uncompensated))


def test_the_layers_attenuation_below_the_skin_is_summed_layer_by_layer() -> None:
    """Skin 1.5 mm at 1.0, fat 7 mm at 0.6, then iliopsoas at 1.0 dB/cm/MHz (the nominal
    `femoral` stack's first layers, counted by hand)."""
    spec = load_phantom("femoral")
    depths = np.array([0.0, 0.001, 0.005, 0.0085])
    expected = [0.0, 0.1, 0.15 + 0.35 * 0.6, 0.15 + 0.7 * 0.6]
    np.testing.assert_allclose(spec.attenuation_below_skin(depths), expected, atol=1e-12)
    total = sum(layer.thickness * layer.attenuation_db_cm_mhz for layer in spec.layers[:-1])
    below = spec.attenuation_below_skin(np.array([0.06]))[0]
    stack = sum(layer.thickness for layer in spec.layers[:-1])
    assert below == pytest.approx(
        100 * total + (0.06 - stack) * 100 * spec.layers[-1].attenuation_db_cm_mhz
    )


def test_the_default_tgc_keeps_layers_of_different_attenuation_evenly_bright(phantom) -> None:
    """Two layers of one echogenicity, the deeper attenuating four times as much: the default
    TGC undoes each over its own depths, so the grey stays level through both, where a TGC
    set for the deep layer alone brightens the upper one with depth."""
    gel = phantom.spec.layers[0]
    upper = dataclasses.replace(gel, name="upper", attenuation_db_cm_mhz=0.25, thickness=0.012)
    lower = dataclasses.replace(gel, name="lower", attenuation_db_cm_mhz=1.0)
    layered = Phantom(dataclasses.replace(phantom.spec, layers=(upper, lower)))
    preset = dataclasses.replace(PLAIN, gain_db=40.0, dynamic_range_db=80.0, depth=0.024)
    slopes = {}
    for name, tgc in (("layers", None), ("deep layer", 1.0)):
        image = render(layered, dataclasses.replace(preset, tgc_attenuation=tgc))[0]
        for rows in (slice(15, 90), slice(110, 185)):  # inside each layer, clear of the face
            slopes[name, rows.start] = grey_slope(image, preset.depth, rows)
    per_db_cm = 2 * preset.centre_frequency / 1e6 * 255.0 / 80.0  # grey per cm per dB/cm/MHz
    for rows in (15, 110):
        assert abs(slopes["layers", rows]) < 0.1 * per_db_cm * 0.75
    assert slopes["deep layer", 15] == pytest.approx(0.75 * per_db_cm, rel=0.15)
    assert abs(slopes["deep layer", 110]) < 0.1 * per_db_cm * 0.75


def test_more_gain_is_brighter_by_the_grey_levels_per_db(phantom) -> None:
    dim = render(phantom, dataclasses.replace(PLAIN, gain_db=20.0))[0]
    bright = render(phantom, dataclasses.replace(PLAIN, gain_db=26.0))[0]
    shown = (dim > 0) & (dim < 255) & (bright < 255)
    step = (bright[shown] - dim[shown]).mean()
    assert step == pytest.approx(6.0 * 255.0 / PLAIN.dynamic_range_db, abs=0.6)


def test_tgc_sliders_raise_the_image_by_their_offset(phantom) -> None:
    flat = render(phantom, PLAIN)[0]
    raised = render(phantom, dataclasses.replace(PLAIN, tgc_sliders_db=(4.0,) * 8))[0]
    shown = (flat > 0) & (raised < 255)
    assert (raised[shown] - flat[shown]).mean() == pytest.approx(
        4.0 * 255.0 / PLAIN.dynamic_range_db, abs=0.6
    )


def test_lower_dynamic_range_gives_more_contrast(phantom) -> None:
    """Log compression maps dB onto grey levels at 255 / DR each: speckle's 5.57 dB spread
    shows wider on a narrower range."""
    wide = render(phantom, dataclasses.replace(PLAIN, dynamic_range_db=72.0, gain_db=36.0))[0]
    narrow = render(phantom, dataclasses.replace(PLAIN, dynamic_range_db=48.0, gain_db=24.0))[0]
    ratio = narrow[40:150].std() / wide[40:150].std()
    assert ratio == pytest.approx(72.0 / 48.0, rel=0.1)


def test_grey_gamma_darkens_mid_greys_and_keeps_the_ends(phantom) -> None:
    linear = render(phantom, PLAIN)[0]
    curved = render(phantom, dataclasses.replace(PLAIN, grey_gamma=1.5))[0]
    expected = np.round(255.0 * (linear / 255.0) ** 1.5)
    np.testing.assert_allclose(curved, expected, atol=1.0)
    assert curved.mean() < linear.mean()


def test_speckle_reduction_coarsens_the_grain_and_keeps_the_mean(phantom) -> None:
    """A Gaussian display filter of sigma s widens the grain's autocorrelation (it convolves
    with a Gaussian of sigma sqrt(2) s), lowers the spread and keeps the mean."""
    sharp = render(phantom, PLAIN)[0][40:150]
    sigma = 0.2e-3
    smooth = render(phantom, dataclasses.replace(PLAIN, speckle_smoothing=sigma))[0][40:150]
    pixel = SMALL_PROBE.width / SMALL_PROBE.cols
    assert correlation_width(smooth, 1) > correlation_width(sharp, 1) + sigma / pixel
    assert smooth.std() < 0.8 * sharp.std()
    assert smooth.mean() == pytest.approx(sharp.mean(), abs=1.0)


def test_speckle_reduction_across_the_beam_only_keeps_the_axial_grain(phantom) -> None:
    """`speckle_smoothing_axial=0` smooths across the beam as much as before and not along
    it: the lateral grain widens as with the isotropic filter, the axial one stays about the
    unsmoothed image's (within 10 %: averaging across the beam takes out some of the
    receiver's noise, which is uncorrelated from row to row), and the isotropic filter's is
    wider."""
    sharp = render(phantom, PLAIN)[0][40:150]
    sigma = 0.2e-3
    isotropic = dataclasses.replace(PLAIN, speckle_smoothing=sigma)
    both = render(phantom, isotropic)[0][40:150]
    across = render(phantom, dataclasses.replace(isotropic, speckle_smoothing_axial=0.0))[0][40:150]
    pixel = SMALL_PROBE.width / SMALL_PROBE.cols
    assert correlation_width(across, 1) > correlation_width(sharp, 1) + sigma / pixel
    assert correlation_width(across, 1) == pytest.approx(correlation_width(both, 1), rel=0.1)
    assert correlation_width(across, 0) == pytest.approx(correlation_width(sharp, 0), rel=0.1)
    assert correlation_width(both, 0) > 1.2 * correlation_width(across, 0)
    with pytest.raises(ValueError, match="speckle_smoothing_axial must be non-negative"):
        dataclasses.replace(isotropic, speckle_smoothing_axial=-1e-4).settings()


def test_clutter_fills_lumens_and_barely_changes_tissue(phantom) -> None:
    """Side lobes see the tissue beside a lumen: the lumen brightens by much, the tissue by
    about 10 log10(1 + 10^(clutter/10)) dB."""
    probe = LinearProbe(cols=128, rows=128)
    clean, labels = render(phantom, PLAIN, x=0.0, probe=probe)
    cluttered, _ = render(phantom, dataclasses.replace(PLAIN, clutter_db=-10.0), 0.0, probe)
    lumen = np.isin(labels, (ARTERY, VEIN))
    tissue = (labels == 0) & (clean > 0)
    assert lumen.sum() > 200
    assert cluttered[lumen].mean() - clean[lumen].mean() > 15.0
    tissue_step = (cluttered[tissue] - clean[tissue]).mean()
    expected = 10.0 * math.log10(1.0 + 0.1) * 255.0 / PLAIN.dynamic_range_db
    assert tissue_step == pytest.approx(expected, abs=1.5)


def test_reverberation_ghosts_the_first_interface_at_twice_its_depth_and_nothing_above() -> None:
    """Over the femoral phantom's skin, the skin-fat interface of each column (found from the
    tissue samples, independently of the echo model) comes back once more from twice its
    depth below the face: the image is unchanged above that ghost and brighter in it."""
    phantom = Phantom(load_phantom("femoral"))
    probe = PLAIN.probe(LinearProbe(width=0.012, cols=48, rows=256))
    x = -0.03
    pose = looking_down(x)
    pose[2, 3] = float(phantom.skin_height(np.array([x]), np.array([0.0]))[0]) - 0.0003
    images = {}
    for reverberation in (0.0, 0.45):
        preset = dataclasses.replace(PLAIN, reverberation=reverberation)
        simulator = UltrasoundSimulator(phantom, probe, preset.settings())
        images[reverberation] = simulator.render(pose)[0].astype(np.float64)
    change = images[0.45] - images[0.0]
    half_pulse = simulator._pulse.shape[0] // 2
    centres = (np.arange(probe.rows) + 0.5) * probe.pixel_height
    brighter = []
    for col, element_x in enumerate(simulator._element_x):
        column = np.stack([np.full(probe.rows, x + element_x), np.zeros(probe.rows)], axis=1)
        points = np.column_stack([column, pose[2, 3] - centres])
        material = phantom.sample(points).material
        interface = int(np.argmax(np.diff(material) != 0)) + 1  # skin to fat
        ghost = 2 * interface
        assert not change[: ghost - half_pulse - 1, col].any(), col
        brighter.append(change[ghost - half_pulse : ghost + half_pulse + 2, col].mean())
    assert np.mean(brighter) > 3.0


def test_random_presets_are_seeded_and_within_their_ranges() -> None:
    assert random_preset(3) == random_preset(3)
    assert random_preset(3) != random_preset(4)
    for seed in range(20):
        preset = random_preset(seed)
        low, high = RANDOM_RANGES["centre_frequency"]
        assert low <= preset.centre_frequency <= high
        assert preset.focal_depth < preset.depth
        assert len(preset.tgc_sliders_db) == 8
        assert preset.tgc_attenuation is not None
        assert TGC_ATTENUATION_RANGE[0] <= preset.tgc_attenuation <= TGC_ATTENUATION_RANGE[1]
        assert preset.settings().tgc_attenuation == preset.tgc_attenuation
        assert preset.speckle_smoothing_axial == 0.0  # across the beam only
        assert 0.0 <= preset.speckle_smoothing <= RANDOM_RANGES["speckle_smoothing"][1]
    assert scanner_preset("random-3") == random_preset(3)
    assert scanner_preset("vascular") is scanner_preset("vascular")


def test_a_preset_sets_the_probe_depth_and_so_the_pixel_spacing() -> None:
    preset = scanner_preset("vascular-deep")
    probe = preset.probe(LinearProbe(rows=256))
    assert probe.pixel_height == pytest.approx(preset.depth / 256)
    assert probe.centre_frequency == preset.centre_frequency


def test_a_preset_at_another_depth_keeps_its_focus_fraction_and_everything_else() -> None:
    preset = scanner_preset("vascular-deep")
    framed = preset.at_depth(0.045)
    assert (framed.depth, framed.name) == (0.045, "vascular-deep@45.0mm")
    assert framed.focal_depth == pytest.approx(0.045 * preset.focal_depth / preset.depth)
    unchanged = {"name", "depth", "focal_depth"}
    for field in dataclasses.fields(preset):
        if field.name not in unchanged:
            assert getattr(framed, field.name) == getattr(preset, field.name), field.name


@pytest.mark.parametrize(
    ("name", "message"),
    [("vascullar", "unknown scanner preset 'vascullar'"), ("random-x", "unknown scanner preset")],
)
def test_unknown_presets_are_refused_by_name(name: str, message: str) -> None:
    with pytest.raises(ValueError, match=message):
        scanner_preset(name)


def test_the_named_presets_are_files_and_a_file_is_a_preset(tmp_path) -> None:
    assert sorted(named_presets()) == sorted(p.stem for p in scanners_dir().glob("*.yaml"))
    assert scanner_preset("vascular") == ScannerPreset()  # the defaults, by name
    assert scanner_preset("vascular-compound") == ScannerPreset(
        name="vascular-compound", compound_frames=3, compound_angle=0.17
    )
    path = tmp_path / "my-machine.yaml"
    path.write_text(
        "centre_frequency: 12e6\n"  # PyYAML reads this as text; still a number here
        "depth: 0.035\nfocal_depth: 0.018\ncompound_frames: 3\ncompound_angle: 0.2\n"
        "tgc_sliders_db: [0, 1, 2, 3]\nclutter_db: null\nlost_coupling: [0.1, 0]\n"
    )
    preset = scanner_preset(str(path))
    assert preset == ScannerPreset(
        name="my-machine",
        centre_frequency=12.0e6,
        depth=0.035,
        focal_depth=0.018,
        compound_frames=3,
        compound_angle=0.2,
        tgc_sliders_db=(0.0, 1.0, 2.0, 3.0),
        clutter_db=None,
        lost_coupling=(0.1, 0.0),
    )
    assert scanner_preset(path) == preset == load_scanner_preset(path)


@pytest.mark.parametrize(
    ("text", "message"),
    [
        ("gain: 30\n", "unknown knob(s) gain; known: centre_frequency, depth,"),
        ("name: mine\n", "unknown knob(s) name"),
        ("gain_db: loud\n", "gain_db: expected a finite number, got 'loud'"),
        ("gain_db: .nan\n", "expected a finite number, got nan"),
        ("gain_db: null\n", "expected a finite number, got None"),
        ("compound_frames: 2.5\n", "compound_frames: expected a whole number, got 2.5"),
        ("tgc_sliders_db: 3\n", "tgc_sliders_db: expected a list of numbers, got 3"),
        ("centre_frequency: 50.0e+6\n", "centre_frequency must be 2-20 MHz, got 50 MHz"),
        ("- 1\n", "a scanner preset file holds a mapping of keys, got a list"),
        ("just words\n", "a scanner preset file holds a mapping of keys, got a str"),
        ("gain_db: [unclosed\n", "not valid YAML"),
    ],
)
def test_a_bad_preset_file_is_one_error_naming_the_file(tmp_path, text: str, message: str):
    path = tmp_path / "bad.yaml"
    path.write_text(text)
    with pytest.raises(ValueError, match=f"^{re.escape(str(path))}: .*{re.escape(message)}"):
        scanner_preset(str(path))


def test_a_missing_preset_file_is_named(tmp_path) -> None:
    with pytest.raises(ValueError, match=r"nowhere\.yaml: scanner preset file not found"):
        scanner_preset(str(tmp_path / "nowhere.yaml"))


def test_bad_presets_are_refused() -> None:
    with pytest.raises(ValueError, match="centre_frequency must be 2-20 MHz"):
        ScannerPreset(centre_frequency=50e6)
    with pytest.raises(ValueError, match="focal_depth"):
        ScannerPreset(depth=0.03, focal_depth=0.04)


@pytest.mark.parametrize(
    ("changes", "message"),
    [
        ({"reverberation": 1.0}, r"reverberation must be in \[0, 1\), got 1.0"),
        ({"reverberation": -0.1}, r"reverberation must be in \[0, 1\), got -0.1"),
        ({"grey_gamma": 0.0}, "grey_gamma must be positive, got 0.0"),
    ],
)
def test_settings_refuse_values_without_a_physical_meaning(changes: dict, message: str) -> None:
    with pytest.raises(ValueError, match=message):
        UltrasoundSettings(**changes)
