"""Tissue texture (fat lobules, septa, perimysium) and the in-vivo femoral phantom."""

from __future__ import annotations

import dataclasses
import math

import numpy as np
import pytest
import yaml

from sim.phantom import Phantom
from sim.phantom.loader import load_phantom, phantoms_dir, spec_from_mapping
from sim.phantom.spec import Material
from sim.ultrasound.probe import LinearProbe
from sim.ultrasound.settings import UltrasoundSettings
from sim.ultrasound.simulator import UltrasoundSimulator

PROBE = LinearProbe(width=0.012, cols=96, rows=160, depth=0.03)
QUIET = UltrasoundSettings(electronic_noise_db=-80.0)
NEPER_DB = 20.0 / math.log(10.0)


def gel(**texture: float) -> Phantom:
    """The default gel block with its gel textured as given."""
    spec = load_phantom("default")
    layers = (dataclasses.replace(spec.layers[0], **texture),)
    return Phantom(dataclasses.replace(spec, layers=layers))


def looking_down(x: float) -> np.ndarray:
    return np.array([[1.0, 0, 0, x], [0, -1.0, 0, 0], [0, 0, -1.0, -0.0003], [0, 0, 0, 1.0]])


def gel_image(**texture: float) -> np.ndarray:
    simulator = UltrasoundSimulator(gel(**texture), PROBE, QUIET)
    return simulator.render(looking_down(0.035))[0][20:150].astype(np.float64)


def test_texture_variation_keeps_the_mean_power_and_spreads_the_log() -> None:
    """A log-normal amplitude factor exp(v Z - v^2) keeps E[power] and lowers the mean log
    power by 2 v^2 nepers: the mean grey falls by 2 v^2 x 8.686 dB, and the spread widens."""
    variation = 0.5
    plain, textured = gel_image(), gel_image(texture_variation=variation)
    grey_per_db = 255.0 / QUIET.dynamic_range_db
    expected = -2.0 * variation**2 * NEPER_DB / 2.0 * grey_per_db
    assert textured.mean() - plain.mean() == pytest.approx(expected, abs=0.25 * abs(expected))
    assert textured.std() > 1.1 * plain.std()


def test_ridges_draw_a_network_of_bright_lines() -> None:
    plain, ridged = gel_image(), gel_image(texture_ridges=2.0)
    bright = np.percentile(plain, 99)
    assert (plain > bright).mean() == pytest.approx(0.01, abs=0.002)
    assert (ridged > bright).mean() > 0.05
    assert abs(np.median(ridged) - np.median(plain)) < 0.35 * plain.std()  # lines, not a haze


def test_texture_is_fixed_in_the_phantom_and_leaves_labels_alone() -> None:
    textured = UltrasoundSimulator(gel(texture_variation=0.5, texture_ridges=1.0), PROBE, QUIET)
    plain = UltrasoundSimulator(gel(), PROBE, QUIET)
    pose = looking_down(0.0)
    first, labels = textured.render(pose)
    again, _ = textured.render(pose)
    np.testing.assert_array_equal(first, again)
    np.testing.assert_array_equal(labels, plain.render(pose)[1])


def test_materials_refuse_negative_texture() -> None:
    with pytest.raises(ValueError, match="'fat': texture_"):
        Material("fat", 0.3, 0.6, 1.38, texture_ridges=-1.0)


def test_the_loader_reads_texture_keys_and_refuses_a_bad_scale() -> None:
    spec = load_phantom("femoral")
    fat = spec.layers[1]
    assert fat.name == "subcutaneous fat" and fat.textured and fat.texture_ridges > 0
    assert spec.texture_scale == (0.006, 0.010, 0.0012)
    assert not spec.blood.textured
    data = yaml.safe_load((phantoms_dir() / "femoral.yaml").read_text())
    with pytest.raises(ValueError, match="texture_scale must be"):
        spec_from_mapping({**data, "texture_scale": [0.001, 0.002]})


def test_the_femoral_phantom_has_its_layers_in_order_under_the_skin() -> None:
    """Skin, fat, fascia lata, the femoral triangle, fascia iliaca, iliopsoas; the fasciae
    are thin and bright, the vessels lie between them."""
    spec = load_phantom("femoral")
    names = [layer.name for layer in spec.layers]
    assert names == [
        "skin",
        "subcutaneous fat",
        "fascia lata",
        "femoral triangle fat",
        "fascia iliaca",
        "iliopsoas",
    ]
    for fascia in (spec.layers[2], spec.layers[4]):
        assert fascia.thickness < 1e-3
        assert fascia.echogenicity > 3 * max(
            spec.layers[1].echogenicity, spec.layers[3].echogenicity
        )
    triangle_top = sum(layer.thickness for layer in spec.layers[:3])
    triangle_bottom = triangle_top + spec.layers[3].thickness
    assert triangle_top < spec.anatomy.artery_depth < triangle_bottom
