"""Layer boundaries that wave (`sim.phantom.layer_waves`): each boundary of the femoral
phantom lies where the closed form puts it, computed here from the waves' table; the layers
keep their order at the steepest waves allowed; no waves leave the flat layers bit for bit;
drawing the waves per subject moved nothing else."""

from __future__ import annotations

import dataclasses
import math

import numpy as np
import pytest
import yaml

from sim.phantom import Phantom, load_phantom
from sim.phantom.layer_waves import LayerWaves
from sim.phantom.loader import phantoms_dir, spec_from_mapping
from sim.phantom.spec import PhantomSpec
from sim.phantom.subjects import make_subject

STEP = 5.0e-6
"""Spacing (m) of the points sampled down each line."""


@pytest.fixture(scope="module")
def femoral() -> PhantomSpec:
    return load_phantom("femoral")


def expected_boundaries(spec: PhantomSpec, x: float, y: float) -> np.ndarray:
    """Depth of each layer boundary below the skin above (x, y), from the closed form."""
    waves = spec.layer_waves
    assert waves is not None
    amplitude, kx, ky, kz, phase = waves.waves().T
    bottoms = np.cumsum([layer.thickness for layer in spec.layers[:-1]])
    shifts = [
        min(1.0, bottom / waves.wave_taper_depth)
        * np.sum(amplitude * np.sin(kx * x + ky * y + kz * bottom + phase))
        for bottom in bottoms
    ]
    return bottoms + np.array(shifts)


def layer_profile(phantom: Phantom, x: float, y: float, deepest: float) -> np.ndarray:
    """The layer material down the vertical line at (x, y) of a block phantom (depth = -z),
    with every structure but the layers taken away."""
    depths = np.arange(0.0, deepest, STEP) + STEP / 2
    points = np.column_stack([np.full_like(depths, x), np.full_like(depths, y), -depths])
    return phantom.sample(points).material


def layers_only(spec: PhantomSpec, waves: LayerWaves | None) -> PhantomSpec:
    """`spec`'s layers and waves in a gel block, without vessels or other structures, so that
    every point is a layer's."""
    return dataclasses.replace(
        spec,
        body=dataclasses.replace(spec.body, kind="block", size=(0.2, 0.2, 0.08)),
        vessels=(),
        bones=(),
        nodes=(),
        hila=(),
        muscles=(),
        nerves=(),
        fascicles=(),
        layer_waves=waves,
    )


@pytest.mark.parametrize("subject", [None, 3])
def test_each_boundary_lies_where_the_waves_put_it(femoral, subject) -> None:
    spec = femoral if subject is None else make_subject(femoral, subject)
    spec = layers_only(spec, spec.layer_waves)
    phantom = Phantom(spec)
    moved = 0
    for x, y in [(-0.015, -0.03), (0.0, 0.0), (0.004, 0.021), (0.017, -0.044)]:
        expected = expected_boundaries(spec, x, y)
        profile = layer_profile(phantom, x, y, expected[-1] + 0.005)
        changes = np.flatnonzero(np.diff(profile)) + 1  # first sample of each next layer
        np.testing.assert_array_equal(profile[changes], np.arange(1, len(expected) + 1))
        measured = changes * STEP  # the boundary lies between samples changes-1 and changes
        np.testing.assert_allclose(measured, expected, atol=STEP)
        nominal = np.cumsum([layer.thickness for layer in spec.layers[:-1]])
        moved += int((np.abs(expected - nominal) > 2e-4).sum())
        assert np.abs(expected - nominal).max() <= spec.layer_waves.wave_amplitude
    assert moved >= 4  # the waves move boundaries, and visibly (0.2 mm is over a pixel's depth)


def test_the_skin_stays_flat_and_fasciae_keep_their_thickness(femoral) -> None:
    waves = femoral.layer_waves
    assert waves is not None and waves.wave_amplitude > 0
    spec = layers_only(femoral, waves)
    thickness = [layer.thickness for layer in spec.layers[:-1]]
    for x in np.linspace(-0.02, 0.02, 9):
        boundaries = expected_boundaries(spec, x, 0.01)
        skin_shift = boundaries[0] - thickness[0]
        assert abs(skin_shift) <= waves.wave_amplitude * thickness[0] / waves.wave_taper_depth
        for fascia in (2, 4):  # fascia lata and iliaca: 0.6 mm, within 0.1 mm wherever
            measured = boundaries[fascia] - boundaries[fascia - 1]
            assert measured == pytest.approx(thickness[fascia], abs=1e-4)


def test_the_layers_keep_their_order_at_the_steepest_waves_allowed(femoral) -> None:
    """At the largest amplitude the check allows, every line down the phantom still meets the
    layers one after another."""
    thin = dataclasses.replace(  # fasciae of 0.2 mm: the hardest case for the order
        femoral,
        layers=tuple(
            dataclasses.replace(layer, thickness=2e-4) if layer.thickness < 1e-3 else layer
            for layer in femoral.layers
        ),
    )
    taper, depth_length = 0.008, 0.040
    steepest = 0.99 / (1 / taper + 2 * math.pi / depth_length)
    for seed in range(4):
        waves = LayerWaves(
            wave_amplitude=steepest,
            wave_length=0.008,
            wave_depth_length=depth_length,
            wave_taper_depth=taper,
            wave_seed=seed,
        )
        phantom = Phantom(layers_only(thin, waves))
        for x in np.linspace(-0.03, 0.03, 7):
            profile = layer_profile(phantom, x, 0.013 * seed, 0.04)
            assert (np.diff(profile) >= 0).all()
            assert set(profile) == set(range(len(thin.layers)))


def test_without_waves_the_layers_are_flat_bit_for_bit(femoral) -> None:
    rng = np.random.default_rng(5)
    points = rng.uniform([-0.03, -0.06, -0.05], [0.03, 0.06, 0.0], (50_000, 3))
    flat = Phantom(dataclasses.replace(femoral, layer_waves=None)).sample(points)
    still = Phantom(dataclasses.replace(femoral, layer_waves=LayerWaves())).sample(points)
    np.testing.assert_array_equal(flat.material, still.material)
    bottoms = np.cumsum([layer.thickness for layer in femoral.layers[:-1]])
    is_layer = (flat.material >= 0) & (flat.material < len(femoral.layers))
    in_layer = np.searchsorted(bottoms, flat.depth[is_layer], side="left")
    np.testing.assert_array_equal(flat.material[is_layer], in_layer)
    waved = Phantom(femoral).sample(points)
    changed = (waved.material != flat.material).mean()
    assert 0.01 < changed < 0.2  # near the boundaries only
    np.testing.assert_array_equal(waved.label, flat.label)  # the vessels did not move


def test_drawing_the_waves_moved_nothing_else(femoral) -> None:
    """The waves' quantities come from a generator of their own: a phantom without their
    ranges gives the same subjects, with the nominal waves."""
    keys = LayerWaves.keys()
    ranges = {k: v for k, v in femoral.variation.ranges.items() if k not in keys}
    without = dataclasses.replace(
        femoral, variation=dataclasses.replace(femoral.variation, ranges=ranges)
    )
    drawn = set()
    for k in range(4):
        subject, other = make_subject(femoral, k), make_subject(without, k)
        assert other.vessels == subject.vessels and other.nerves == subject.nerves
        assert other.layers == subject.layers and other.mechanics == subject.mechanics
        assert other.layer_waves == femoral.layer_waves
        waves = subject.layer_waves
        assert waves is not None
        for key in ("wave_amplitude", "wave_length", "wave_seed"):
            low, high = femoral.variation.ranges[key]
            assert low <= getattr(waves, key) <= high
        drawn.add(waves.wave_seed)
    assert len(drawn) == 4


def test_waves_steep_enough_to_cross_layers_are_refused_naming_the_settings(femoral) -> None:
    with pytest.raises(ValueError, match=r"layer_waves: wave_amplitude 0\.005 is too large"):
        LayerWaves(wave_amplitude=0.005, wave_taper_depth=0.008, wave_depth_length=0.04)
    with pytest.raises(ValueError, match=r"layer_waves\.wave_length must be positive, got 0"):
        LayerWaves(wave_amplitude=0.001, wave_length=0.0)
    with pytest.raises(ValueError, match=r"layer_waves\.wave_amplitude must be >= 0, got -0\.001"):
        LayerWaves(wave_amplitude=-0.001)
    data = yaml.safe_load((phantoms_dir() / "femoral.yaml").read_text())
    with pytest.raises(ValueError, match="layer_waves: unknown key"):
        spec_from_mapping({**data, "layer_waves": {"wave_height": 0.001}})
