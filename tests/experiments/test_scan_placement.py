"""Where the experiments put each subject's sweep: centred on its vessels when asked, as a
sonographer places the probe over an in-vivo groin, and otherwise exactly where the settings
say."""

import dataclasses

import numpy as np
import pytest

from resus.acquisition.patterns import LinearPattern
from resus.acquisition.simulation import phantom_spec, resolve_scene
from resus.cli.experiment import experiment_preset
from resus.experiments.data import ScanSettings, placed_scan
from sim.labels import ARTERY, VEIN
from sim.phantom import Phantom

FEMORAL = ScanSettings(phantom="femoral", centre_on_vessels=True)


def vessel_columns(subject: int, y: float) -> dict[int, float]:
    """Lateral centroid (m) of each label's largest cross-section on the transverse plane
    `y`, read off the phantom's own labels on a 0.1 mm grid (independent of the centrelines
    the placement reads)."""
    from scipy import ndimage

    phantom = Phantom(phantom_spec(resolve_scene("default", "femoral", subject)))
    xs = np.arange(-0.05, 0.05, 1e-4)
    zs = np.arange(-0.06, 0.0, 1e-4)
    grid_x, grid_z = np.meshgrid(xs, zs)
    points = np.stack([grid_x.ravel(), np.full(grid_x.size, y), grid_z.ravel()], axis=1)
    labels = phantom.sample(points).label.reshape(grid_x.shape)
    centres = {}
    for label in (ARTERY, VEIN):
        parts, count = ndimage.label(labels == label)
        sizes = ndimage.sum(np.ones_like(parts), parts, range(1, count + 1))
        largest = parts == 1 + int(np.argmax(sizes))
        centres[label] = float(grid_x[largest].mean())
    return centres


@pytest.mark.parametrize("subject", [0, 1, 2, 3])
def test_a_centred_sweep_has_the_artery_and_vein_either_side_of_its_middle(subject):
    scan = placed_scan("s", subject, FEMORAL)
    x, y = scan.sweep.middle
    centres = vessel_columns(subject, float(y))
    assert min(centres.values()) < x < max(centres.values())
    assert x == pytest.approx(np.mean(list(centres.values())), abs=1.0e-3)
    assert scan.sweep.start[1] == FEMORAL.sweep.start[1]  # moved across only


def test_sweeps_of_one_subject_move_together_and_uncentred_ones_stay():
    aside = LinearPattern(start=(0.004, -0.035), length=0.07, tilt_deg=10.0)
    a = placed_scan("a", None, FEMORAL)
    b = placed_scan("b", None, FEMORAL, aside)
    assert b.sweep.start[0] - a.sweep.start[0] == pytest.approx(0.004)
    assert dataclasses.replace(b.sweep, start=aside.start) == aside
    plain = dataclasses.replace(FEMORAL, centre_on_vessels=False)
    assert placed_scan("p", 3, plain) == placed_scan("p", 3, plain, plain.sweep)
    assert placed_scan("p", 3, plain).sweep == plain.sweep


def test_the_phantom_and_scanner_flags_reach_the_scan_settings():
    preset = experiment_preset("quick", 2, "femoral", "vascular")
    scans = preset.scans
    assert (preset.repeats, scans.phantom, scans.scanner) == (2, "femoral", "vascular")
    assert scans.centre_on_vessels
    default = experiment_preset("quick", None)
    assert default.scans.phantom is None and not default.scans.centre_on_vessels


def test_reports_name_what_was_scanned_and_how():
    from resus.experiments.report import scanned_text

    femoral = experiment_preset("quick", None, "femoral", "vascular").to_dict()
    assert scanned_text(femoral) == (
        "the `femoral` phantom",
        ", imaged through the `vascular` preset, each sweep centred on its subject's artery "
        "and vein",
    )
    assert scanned_text(experiment_preset("quick", None).to_dict()) == ("the gel-block phantom", "")
