"""The realism statistics against independent computations on arrays with known answers, and
the readers of both sides (sweeps with labels, folders of PNGs with masks)."""

from __future__ import annotations

import dataclasses
import math
import re

import cv2
import numpy as np
import pytest
from scipy import ndimage
from scipy.spatial import cKDTree

from resus.errors import ResusError
from resus.experiments.realism import (
    MEDIAN,
    QUANTILES,
    RAYLEIGH_LOG_STD_DB,
    ImageSet,
    RealismSettings,
    compare,
    dark_tissue_share,
    ellipse_fit,
    full_width_half_maximum,
    imaged_region,
    measure,
    rayleigh_grey_std,
    read_image_folder,
    read_sweep_set,
    vessel_contrasts,
    vessel_regions,
)
from resus.sweep.io import write_sweep
from sim.labels import ARTERY, VEIN
from sim.phantom import Phantom, load_phantom, make_subject
from sim.ultrasound.scanner import scanner_preset
from sim.ultrasound.simulator import UltrasoundSimulator
from sim.ultrasound.skin_pose import probe_pose_on_skin


def one_image(image: np.ndarray, vessel: np.ndarray | None = None, **kwargs) -> ImageSet:
    vessel = np.zeros(image.shape, bool) if vessel is None else vessel
    return ImageSet("test", (image,), (vessel,), ("test.png",), **kwargs)


def disc(shape: tuple[int, int], centre: tuple[float, float], radius: float) -> np.ndarray:
    rows, cols = np.indices(shape)
    return (rows - centre[0]) ** 2 + (cols - centre[1]) ** 2 <= radius**2


def log_compressed_rayleigh(
    shape: tuple[int, int], dynamic_range_db: float, mean_grey: float, seed: int
) -> np.ndarray:
    """Fully developed speckle: Rayleigh amplitudes, 20 log10 at 255 / DR grey per dB."""
    amplitude = np.random.default_rng(seed).rayleigh(size=shape)
    decibels = 20.0 * np.log10(amplitude)
    grey = mean_grey + (decibels - decibels.mean()) * 255.0 / dynamic_range_db
    return np.clip(np.round(grey), 0, 255).astype(np.uint8)


def test_constant_tissue_and_lumen_give_the_exact_ratio_and_contrast() -> None:
    image = np.full((64, 64), 100, np.uint8)
    lumen = disc(image.shape, (32, 32), 10)
    image[lumen] = 25
    stats = measure(one_image(image, lumen))
    assert stats.tissue_mean == 100 and stats.lumen_mean == 25
    assert stats.lumen_tissue == pytest.approx(0.25)
    assert stats.contrast_db == pytest.approx(-12.0412, abs=1e-4)
    assert stats.cnr is None  # no noise: the contrast-to-noise ratio is not defined
    assert stats.speckle is None  # no window has any spread
    assert stats.mean == pytest.approx(image.mean())


def test_grey_figures_match_numpy_over_the_imaged_area() -> None:
    rng = np.random.default_rng(3)
    inner = rng.integers(1, 256, (50, 70)).astype(np.uint8)
    lumen = disc(inner.shape, (25, 20), 8)
    inner[lumen] //= 4
    image = np.zeros((80, 90), np.uint8)  # black padding on every side
    image[10:60, 5:75] = inner
    vessel = np.zeros(image.shape, bool)
    vessel[10:60, 5:75] = lumen
    stats = measure(one_image(image, vessel))
    pixels = inner.ravel()
    assert stats.pixels == inner.size
    assert stats.mean == pytest.approx(pixels.mean())
    for name, q in (("median", 50), ("p5", 5), ("p95", 95)):
        assert getattr(stats, name) == np.percentile(pixels, q, method="inverted_cdf"), name
    np.testing.assert_allclose(stats.histogram, np.bincount(pixels, minlength=256) / pixels.size)
    tissue, blood = inner[~lumen].astype(float), inner[lumen].astype(float)
    assert stats.tissue_mean == pytest.approx(tissue.mean())
    assert stats.lumen_mean == pytest.approx(blood.mean())
    expected_cnr = abs(tissue.mean() - blood.mean()) / math.hypot(tissue.std(), blood.std())
    assert stats.cnr == pytest.approx(expected_cnr)
    assert stats.contrast_db == pytest.approx(20 * math.log10(blood.mean() / tissue.mean()))


def test_black_margins_are_stripped_but_dark_tissue_and_marks_are_not() -> None:
    image = np.zeros((100, 120), np.uint8)
    image[20:90, 15:110] = 2  # very dark tissue is still imaged
    image[30:40, 50:60] = 0  # and so is a black spot inside it
    image[95, 3] = image[5, 60] = 200  # a tick mark and a logo dot in the margins
    rows, cols = imaged_region(image)
    assert (rows, cols) == (slice(20, 90), slice(15, 110))
    assert measure(one_image(image)).pixels == 70 * 95
    assert imaged_region(np.zeros((8, 8), np.uint8)) == (slice(0, 0), slice(0, 0))


def test_depth_profile_is_the_tissue_mean_of_each_fifth_of_the_imaged_area() -> None:
    """Rows graded by depth under a black top margin; a lumen of its own grey in the fourth
    fifth is left out of that band's tissue mean."""
    inner = np.repeat(np.arange(100, 0, -1, dtype=np.uint8)[:, None] + 50, 40, axis=1)
    lumen = disc(inner.shape, (70, 20), 6)
    inner[lumen] = 10
    image = np.zeros((130, 40), np.uint8)
    image[30:] = inner
    vessel = np.zeros(image.shape, bool)
    vessel[30:] = lumen
    stats = measure(one_image(image, vessel))
    expected = [
        inner[k * 20 : (k + 1) * 20][~lumen[k * 20 : (k + 1) * 20]].mean() for k in range(5)
    ]
    np.testing.assert_allclose(stats.depth_profile, expected)
    assert stats.depth_profile[0] == pytest.approx(140.5)  # rows of grey 150 down to 131
    assert stats.depth_falloff == pytest.approx(expected[4] / expected[1])
    assert stats.depth_falloff < 1  # darker with depth


def test_per_image_depth_falloff_quantiles_differ_from_the_pooled_ratio() -> None:
    """A frame dark at depth and one evenly grey: per image 0.2 and 1, pooled over both
    (equal sizes) (20 + 100) / (100 + 100) = 0.6."""
    dark = np.full((50, 20), 100, np.uint8)
    dark[40:] = 20
    even = np.full((50, 20), 100, np.uint8)
    images = ImageSet("test", (dark, even), (np.zeros((50, 20), bool),) * 2, ("a", "b"))
    stats = measure(images)
    assert stats.depth_falloff == pytest.approx(0.6)
    assert stats.depth_falloff_quantiles == pytest.approx(np.quantile([0.2, 1.0], QUANTILES))


def test_an_all_black_set_is_refused() -> None:
    with pytest.raises(ResusError, match="no imaged tissue"):
        measure(one_image(np.zeros((32, 32), np.uint8)))


def test_the_rayleigh_constant_is_the_std_of_log_compressed_rayleigh_samples() -> None:
    samples = np.random.default_rng(0).rayleigh(size=1_000_000)
    assert np.std(20 * np.log10(samples)) == pytest.approx(RAYLEIGH_LOG_STD_DB, rel=0.005)
    assert round(RAYLEIGH_LOG_STD_DB, 2) == 5.57
    assert rayleigh_grey_std(50.0) == pytest.approx(5.5697 * 255 / 50, rel=1e-4)


def test_log_compressed_rayleigh_speckle_shows_the_analytic_grey_std() -> None:
    dynamic_range = 60.0
    image = log_compressed_rayleigh((512, 512), dynamic_range, 128.0, seed=1)
    stats = measure(one_image(image, dynamic_range_db=dynamic_range))
    speckle = stats.speckle
    assert speckle is not None and speckle.patches > 900  # most of the 1024 windows pass
    assert speckle.std == pytest.approx(rayleigh_grey_std(dynamic_range), rel=0.03)
    assert speckle.std_to_rayleigh == pytest.approx(1.0, rel=0.03)
    assert speckle.implied_dynamic_range_db == pytest.approx(dynamic_range, rel=0.03)
    assert speckle.snr_quantiles[2] == pytest.approx(128.0 / speckle.std, rel=0.05)
    assert measure(one_image(image)).speckle.rayleigh_std is None  # dynamic range unknown


def test_speckle_windows_keep_away_from_vessels() -> None:
    image = log_compressed_rayleigh((256, 256), 60.0, 128.0, seed=2)
    vessel = disc(image.shape, (128, 128), 40)
    plain = measure(one_image(image)).speckle
    around = measure(one_image(image, vessel)).speckle
    # the 16 px tiles whose every pixel lies at least 8 px from every vessel pixel
    tree = cKDTree(np.argwhere(vessel))
    tiles = np.indices((16, 16)).reshape(2, -1).T * 16
    offsets = np.indices((16, 16)).reshape(2, -1).T
    free = sum(tree.query(corner + offsets)[0].min() >= 8 for corner in tiles)
    assert plain is not None and around is not None
    assert 0.9 * 256 <= plain.patches <= 256
    assert 0.9 * free <= around.patches <= free < 256


def test_clipped_and_inhomogeneous_windows_are_left_out() -> None:
    image = log_compressed_rayleigh((256, 256), 60.0, 100.0, seed=3)
    plain = measure(one_image(image)).speckle
    lined = image.copy()
    lined[::32] = lined[1::32] = 255  # a saturated line through every other row of windows
    stepped = image.copy()
    for left in range(16, 256, 32):  # an edge through the middle of every other column
        stepped[:, left + 8 : left + 16] += 60
    assert plain is not None and plain.patches > 0.9 * 256
    for changed in (lined, stepped):
        speckle = measure(one_image(changed)).speckle
        assert speckle is not None and speckle.patches < 0.55 * 256


def test_grain_of_blurred_white_noise_is_the_blur_width() -> None:
    """White noise blurred by a Gaussian of std s has a Gaussian autocorrelation of std
    s sqrt(2): its FWHM is 2 sqrt(2 ln 2) sqrt(2) s = 3.33 s. Removing each window's mean
    narrows it by about 4 % (`RealismSettings.grain_patch`), hence the tolerance."""
    sigma_rows, sigma_cols = 1.5, 2.0
    noise = np.random.default_rng(4).normal(size=(512, 512))
    field = ndimage.gaussian_filter(noise, (sigma_rows, sigma_cols))
    image = np.clip(np.round(128 + field * 20 / field.std()), 0, 255).astype(np.uint8)
    speckle = measure(one_image(image)).speckle
    factor = 2 * math.sqrt(2 * math.log(2)) * math.sqrt(2)
    assert speckle is not None and speckle.grain_patches > 150
    assert speckle.grain_axial == pytest.approx(factor * sigma_rows, rel=0.08)
    assert speckle.grain_lateral == pytest.approx(factor * sigma_cols, rel=0.08)


def test_grain_at_the_network_input_does_not_depend_on_the_export_size() -> None:
    """The same blurred speckle exported at 512 px and at 256 px: in their own pixels the
    larger export's grain is wider (twofold, less the windows' narrowing), resized to the
    network's input it is the same; and it keeps the blur's shape (1.5 times wider across
    the beam than along it)."""
    rng = np.random.default_rng(5)
    fields = [ndimage.gaussian_filter(rng.normal(size=(512, 512)), (3.0, 4.5)) for _ in range(6)]
    large = [np.clip(np.round(128 + f * 20 / f.std()), 0, 255).astype(np.uint8) for f in fields]
    small = [cv2.resize(image, (256, 256), interpolation=cv2.INTER_AREA) for image in large]
    grains = [
        measure(
            ImageSet(
                name,
                tuple(images),
                tuple(np.zeros_like(i, bool) for i in images),
                tuple(map(str, range(len(images)))),
            )
        ).speckle
        for name, images in (("large", large), ("small", small))
    ]
    assert all(g is not None and g.network_grain_patches > 150 for g in grains)
    big, half = grains
    assert big is not None and half is not None
    assert big.grain_axial > 1.5 * half.grain_axial
    assert big.network_grain_axial == pytest.approx(half.network_grain_axial, rel=0.05)
    assert big.network_grain_lateral == pytest.approx(half.network_grain_lateral, rel=0.05)
    assert big.network_grain_lateral / big.network_grain_axial == pytest.approx(1.5, rel=0.15)


def test_full_width_half_maximum_interpolates() -> None:
    assert full_width_half_maximum(np.array([1.0, 0.75, 0.25, 0.0])) == pytest.approx(3.0)
    assert full_width_half_maximum(np.array([1.0, 0.9, 0.8])) is None


def ellipse(
    shape: tuple[int, int],
    centre: tuple[float, float],
    semi_axes: tuple[float, float],
    angle: float,
) -> np.ndarray:
    """Pixels whose centres lie in the ellipse of `semi_axes` (along, across) turned by
    `angle` (radians) from the rows."""
    rows, cols = np.indices(shape) + 0.5 - np.array(centre)[:, None, None]
    along = rows * math.cos(angle) + cols * math.sin(angle)
    across = -rows * math.sin(angle) + cols * math.cos(angle)
    return (along / semi_axes[0]) ** 2 + (across / semi_axes[1]) ** 2 <= 1


def test_a_pixel_rectangle_has_its_side_ratio_as_aspect_exactly() -> None:
    """n pixels in a row spread (n^2 - 1) / 12 about their centre, and each pixel's own square
    adds 1 / 12: n^2 / 12, so a w x h block's aspect is h / w exactly, a one-pixel line's too."""
    mask = np.zeros((100, 80), bool)
    mask[10:40, 20:26] = True  # 30 rows by 6 columns
    mask[70, 5:45] = True  # a one-pixel line, 40 long
    (block, block_area, block_depth), (line, _, line_depth) = vessel_regions(mask, 0.0)
    assert block == pytest.approx(5.0, rel=1e-12)
    assert line == pytest.approx(40.0, rel=1e-12)
    assert block_area == 180 / mask.size
    assert block_depth == pytest.approx(25.0 / 100) and line_depth == pytest.approx(70.5 / 100)


def test_a_turned_ellipse_has_its_axis_ratio_area_and_depth() -> None:
    mask = ellipse((200, 240), (80.0, 120.0), (45.0, 15.0), math.radians(30))
    ((aspect, area, depth),) = vessel_regions(mask, 0.0)
    assert aspect == pytest.approx(3.0, rel=0.01)
    assert area == pytest.approx(math.pi * 45 * 15 / mask.size, rel=0.01)
    assert depth == pytest.approx(80.0 / 200, abs=1e-3)


def whole_region(mask: np.ndarray) -> tuple[tuple[slice, slice], np.ndarray, np.ndarray]:
    """`mask` as one region (its box the whole image)."""
    return (slice(0, mask.shape[0]), slice(0, mask.shape[1])), *np.nonzero(mask)


def test_an_ellipse_fits_its_moment_ellipse_and_a_square_by_its_overlap_with_a_disc() -> None:
    """A turned ellipse overlaps its moment ellipse up to its pixels' edges. A square of side
    s has second moment s^2 / 12 along either axis, so its moment ellipse is the disc of
    radius s / sqrt(3), which pokes out of it in four caps of r^2 acos(d / r) - d sqrt(r^2 -
    d^2) each (r = s / sqrt(3), d = s / 2): IoU = (disc - caps) / (square + caps) = 0.827."""
    turned = ellipse((200, 240), (80.0, 120.0), (45.0, 15.0), math.radians(30))
    assert ellipse_fit(whole_region(turned)) > 0.98
    square = np.zeros((100, 100), bool)
    square[20:80, 20:80] = True
    r, d = 1.0 / math.sqrt(3.0), 0.5
    caps = 4.0 * (r * r * math.acos(d / r) - d * math.sqrt(r * r - d * d))
    expected = (math.pi * r * r - caps) / (1.0 + caps)
    assert ellipse_fit(whole_region(square)) == pytest.approx(expected, abs=0.005)


def test_vessel_shapes_count_regions_above_the_least_area_over_the_imaged_area() -> None:
    """Two vessels in one padded image (a circle and a 4:1 slit) and a speck too small to
    count; a second image shows none. Depth is a share of the imaged height, padding out."""
    first = np.zeros((120, 100), np.uint8)
    first[20:120] = 90  # 20 black rows above the imaged area
    vessel = np.zeros(first.shape, bool)
    vessel |= disc(first.shape, (50, 30), 10)
    vessel[90:94, 50:66] = True  # 4 x 16: aspect 4
    vessel[30, 90] = True  # a one-pixel speck: under 0.05 % of 10 000 pixels
    second = np.full((100, 100), 90, np.uint8)
    images = ImageSet(
        "test", (first, second), (vessel, np.zeros(second.shape, bool)), ("a.png", "b.png")
    )
    shapes = measure(images).vessel_shapes
    assert shapes is not None
    assert shapes.regions == 2 and shapes.showing_share == 0.5
    assert sorted(shapes.aspects) == [pytest.approx(1.0, abs=0.02), pytest.approx(4.0)]
    assert shapes.elongated_share == 0.5
    circle = vessel[20:].sum() - 64 - 1  # the disc's pixels, the slit and speck taken away
    assert max(shapes.area_quantiles) == pytest.approx(
        np.quantile([circle / 10_000, 64 / 10_000], 0.9)
    )
    assert min(shapes.depth_quantiles) == pytest.approx(
        np.quantile([(50 - 20 + 0.5) / 100, (92 - 20 + 0.5) / 100], 0.1), abs=0.002
    )
    assert measure(one_image(second)).vessel_shapes is None


def test_vessel_placement_is_the_centroid_off_the_middle_and_the_regions_cut() -> None:
    """Three images, each with 20 black columns beside an 80 px wide imaged area: a pair of
    vessels either side of its middle (centroid on it: 0), a block of columns 70-79 (its
    centroid at 75, 55 of 80 from the imaged edge: 0.1875 off) and a block of columns 80-89
    (0.3125 off: an outer quarter). The pixels weigh, not the regions: a large and a small
    vessel pull the centroid towards the large one. A region touching the imaged area's side
    or bottom is cut by the picture; one touching its top (the face) is not."""
    shape = (60, 100)

    def image_with(*blocks: tuple[int, int, int, int]) -> tuple[np.ndarray, np.ndarray]:
        image = np.zeros(shape, np.uint8)
        image[:, 20:] = 90
        vessel = np.zeros(shape, bool)
        for top, bottom, left, right in blocks:
            vessel[top:bottom, left:right] = True
        return image, vessel

    sets = [
        image_with((20, 30, 40, 50), (20, 30, 70, 80)),
        image_with((20, 30, 70, 80)),
        image_with((20, 30, 80, 90)),
    ]
    images = ImageSet("test", tuple(i for i, _ in sets), tuple(v for _, v in sets), ("a", "b", "c"))
    shapes = measure(images).vessel_shapes
    assert shapes is not None
    assert shapes.centroid_offset_quantiles[QUANTILES.index(0.5)] == pytest.approx(0.1875)
    assert min(shapes.centroid_offset_quantiles) == pytest.approx(
        np.quantile([0.0, 0.1875, 0.3125], QUANTILES[0])
    )
    assert shapes.off_side_share == pytest.approx(1 / 3)
    assert shapes.cut_share == 0.0  # the imaged area starts at column 20, not at 0
    image, vessel = image_with((10, 40, 30, 40), (20, 30, 80, 90))  # 300 px at 35, 100 at 85
    shapes = measure(one_image(image, vessel)).vessel_shapes
    assert shapes is not None
    expected = abs((300 * 15 + 100 * 65) / 400 / 80 - 0.5)  # columns from the imaged edge
    assert shapes.centroid_offset_quantiles == pytest.approx((expected,) * len(QUANTILES))
    # cut by the picture: a vessel at its right edge and one at its bottom; the face is no cut
    image, vessel = image_with((0, 10, 40, 50), (20, 30, 90, 100), (50, 60, 50, 60))
    shapes = measure(one_image(image, vessel)).vessel_shapes
    assert shapes is not None and shapes.cut_share == pytest.approx(2 / 3)


def test_vessel_contrasts_are_the_lumen_and_the_wall_over_the_ring_beyond_them() -> None:
    """Tissue at grey 50, a 40 x 60 lumen at 10, and a wall at 100 only above and below it
    (3 px, the band: 0.015 of 200 rows): the lumen reads 0.2; beside the lumen the band is
    tissue (1.0), above and below it the wall (2.0, less the four corner pixels whose normal is
    steep)."""
    shape = (200, 220)
    image = np.full(shape, 50, np.uint8)
    lumen = np.zeros(shape, bool)
    lumen[80:120, 80:140] = True
    image[lumen] = 10
    image[77:80, 80:140] = image[120:123, 80:140] = 100
    ((inside, beside, above_below, middle, *_),) = vessel_contrasts(image, lumen, 0.0, band=0.015)
    assert inside == pytest.approx(0.2) and beside == 1.0 and middle == 1.0
    assert above_below == pytest.approx((360 * 100 + 4 * 50) / 364 / 50)
    # a wall drawn all round reads bright beside the lumen too
    image[~lumen & (ndimage.distance_transform_edt(~lumen) <= 3)] = 100
    ((_, beside, *_),) = vessel_contrasts(image, lumen, 0.0, band=0.015)
    assert beside == 2.0
    shapes = measure(one_image(image, lumen)).vessel_shapes
    assert shapes is not None and shapes.wall_lateral_quantiles == (2.0,) * len(QUANTILES)
    assert shapes.lumen_quantiles == pytest.approx((0.2,) * len(QUANTILES))
    # only the interior counts: a lumen whose edge is bright still reads by its middle
    image[lumen & (ndimage.distance_transform_edt(lumen) <= 3)] = 50
    assert vessel_contrasts(image, lumen, 0.0, band=0.015)[0].lumen == pytest.approx(0.2)
    # a lumen across the whole image has nothing beside it: no figure there, not a guess
    across = np.zeros(shape, bool)
    across[90:110] = True
    plain = np.full(shape, 50, np.uint8)
    assert vessel_contrasts(plain, across, 0.0, band=0.015) == [
        (1.0, None, 1.0, None, None, 1.0, 1.0)
    ]
    # a lumen too thin for an interior gives no lumen figure
    thin = np.zeros(shape, bool)
    thin[100:104, 60:160] = True
    assert vessel_contrasts(plain, thin, 0.0, band=0.015)[0].lumen is None


def test_the_tissue_round_a_lumen_is_read_against_its_own_rows() -> None:
    """Tissue whose grey rises with depth (row r at 20 + r / 4) round a lumen at grey 10: the
    ring 1-4 bands out (3-12 px) reads 1 beside, above and below the lumen, however bright its
    rows are. A halo 1.5 times as bright within 12 px of the lumen reads 1.5, less what it adds
    to its own rows' mean (at most 3 %: 84 halo pixels in a row of 2000)."""
    shape = (200, 2000)
    rows = (20 + np.arange(shape[0]) / 4)[:, None]
    lumen = np.zeros(shape, bool)
    lumen[80:120, 960:1020] = True
    image = np.where(lumen, 10, np.broadcast_to(rows, shape)).astype(np.uint8)
    ((*_, beside, above, below),) = vessel_contrasts(image, lumen, 0.0, band=0.015)
    assert beside == above == below == pytest.approx(1.0, abs=0.01)
    halo = ~lumen & (ndimage.distance_transform_edt(~lumen) <= 12)
    image = np.where(halo, 1.5 * rows, image).astype(np.uint8)
    ((*_, beside, above, below),) = vessel_contrasts(image, lumen, 0.0, band=0.015)
    for figure in (beside, above, below):
        assert 1.45 < figure <= 1.5 + 0.01
    shapes = measure(one_image(image, lumen)).vessel_shapes
    assert shapes is not None and shapes.round_beside_quantiles is not None
    assert shapes.round_beside_quantiles[MEDIAN] == pytest.approx(beside)


def test_a_lumen_dark_down_its_middle_reads_below_one() -> None:
    """A 40 x 60 lumen at grey 20 whose middle third of columns (100-119) is at 10: the
    interior (more than 3 px inside the edge, columns 84-135) reads 10 over 20 there; moved
    against the image's side, the region gives no figure."""
    shape = (200, 220)
    image = np.full(shape, 50, np.uint8)
    lumen = np.zeros(shape, bool)
    lumen[80:120, 80:140] = True
    image[lumen] = 20
    image[80:120, 100:120] = 10
    assert vessel_contrasts(image, lumen, 0.0, band=0.015)[0].lumen_middle == pytest.approx(0.5)
    shapes = measure(one_image(image, lumen)).vessel_shapes
    assert shapes is not None
    assert shapes.lumen_middle_quantiles == pytest.approx((0.5,) * len(QUANTILES))
    at_side = np.roll(lumen, -80, axis=1)
    assert vessel_contrasts(image, at_side, 0.0, band=0.015)[0].lumen_middle is None


def test_dark_tissue_is_the_share_at_the_vessels_depth_as_dark_as_their_lumens() -> None:
    """Tissue at grey 100, a lumen at 30 (rows 80-119, columns 140-179) and a muscle at 5 (not
    0, which would be a margin) down columns 0-59. A band is 3 px of the 200 rows; the tissue
    counted lies in rows 80-119 more than 12 px from the lumen (columns 0-127 and 192-199: 40 x
    136 pixels). Smoothed over a band, the lumen's interior reads 30 and the muscle's edge
    moves by less than a band: 57 to 60 of its columns count, in all 40 rows. A dark band above
    the vessel's rows is not at its depth and changes nothing; without the muscle nothing is
    that dark."""
    shape = (200, 200)
    lumen = np.zeros(shape, bool)
    lumen[80:120, 140:180] = True
    plain = np.where(lumen, 30, 100).astype(np.uint8)
    muscle = plain.copy()
    muscle[:, :60] = 5
    share = dark_tissue_share(muscle, lumen, 0.0, band=0.015)
    assert share is not None and 57 * 40 / (40 * 136) <= share <= 60 * 40 / (40 * 136)
    above = muscle.copy()
    above[:40] = 5
    assert dark_tissue_share(above, lumen, 0.0, band=0.015) == pytest.approx(share)
    assert dark_tissue_share(plain, lumen, 0.0, band=0.015) == 0.0
    shapes = measure(one_image(muscle, lumen)).vessel_shapes
    assert shapes is not None and shapes.dark_tissue_quantiles == pytest.approx(
        (share,) * len(QUANTILES)
    )
    # a lumen too thin for an interior gives no figure
    thin = np.zeros(shape, bool)
    thin[100:104, 140:180] = True
    assert dark_tissue_share(muscle, thin, 0.0, band=0.015) is None


def test_a_wall_that_scatters_like_tissue_shows_above_and_below_the_lumen_not_beside_it() -> None:
    """A wall whose own scatter is the connective tissue's (echogenicity 0.4 in the femoral
    phantom) shows only by its specular echo, where the beam meets it square: above and below
    the lumen, as real walls do in usgra-seg (median beside 0.94, above and below 1.21). At
    1.0 (the femoral phantom's default) it is a ring all round, bright beside the lumen too.
    Three subjects' frames at the `vascular` preset, their artery and vein drawn 16-19 mm apart
    so that the tissue beside each wall is tissue, not the other vessel's wall (side by side,
    as the femoral subjects are drawn, the ring beside reaches the neighbour: 1.36 at 0.4)."""
    vascular = scanner_preset("vascular")
    femoral = load_phantom("femoral")
    ranges = {**femoral.variation.ranges, "artery_vein_spacing": (0.016, 0.019)}
    apart = dataclasses.replace(
        femoral, variation=dataclasses.replace(femoral.variation, ranges=ranges)
    )

    def walls(wall_echogenicity: float) -> tuple[float, float]:
        beside, above_below = [], []
        for subject in range(3):
            spec = make_subject(apart, subject)
            spec = dataclasses.replace(
                spec, wall=dataclasses.replace(spec.wall, echogenicity=wall_echogenicity)
            )
            phantom = Phantom(spec)
            simulator = UltrasoundSimulator(phantom, vascular.probe(), vascular.settings())
            pose = probe_pose_on_skin(phantom, spec.anatomy.centre_offset, -0.03)
            image, labels = simulator.render(pose)
            for _, side, axial, *_ in vessel_contrasts(image, labels > 0, 0.0005, 0.015):
                beside += [] if side is None else [side]
                above_below += [] if axial is None else [axial]
        return float(np.median(beside)), float(np.median(above_below))

    beside, above_below = walls(0.4)
    assert beside < 1.2 and above_below > beside + 0.2  # 0.92, 1.54
    assert walls(1.0)[0] > beside + 0.4  # a bright ring all round: 1.50


def test_settings_are_checked() -> None:
    with pytest.raises(ResusError, match=r"RealismSettings\.patch"):
        RealismSettings(patch=7)
    with pytest.raises(ResusError, match=r"RealismSettings\.blank_fraction"):
        RealismSettings(blank_fraction=0)
    with pytest.raises(ResusError, match=r"RealismSettings\.homogeneity"):
        RealismSettings(homogeneity=-1)
    with pytest.raises(ResusError, match=r"RealismSettings\.min_vessel_area"):
        RealismSettings(min_vessel_area=1)
    with pytest.raises(ResusError, match=r"RealismSettings\.wall_band must be in \(0, 0\.25\)"):
        RealismSettings(wall_band=0)


def test_comparison_table_starts_with_the_issue_figures() -> None:
    image = log_compressed_rayleigh((64, 64), 50.0, 120.0, seed=5)
    vessel = disc(image.shape, (32, 32), 8)
    comparison = compare(one_image(image, vessel), one_image(image // 3, vessel))
    labels = [label for label, _, _ in comparison.table()]
    assert labels[:5] == ["mean grey", "median grey", "tissue mean", "lumen mean", "lumen/tissue"]
    table = {label: (sim, real) for label, sim, real in comparison.table()}
    assert table["mean grey"] == (comparison.simulated.mean, comparison.real.mean)
    summary = comparison.to_dict()
    assert "tmkand/usgra-seg" in summary["credit"]
    assert len(summary["simulated"]["histogram"]) == 256
    assert "| lumen/tissue |" in "\n".join(comparison.to_markdown())


def write_png(path, image: np.ndarray) -> None:
    path.parent.mkdir(parents=True, exist_ok=True)
    assert cv2.imwrite(str(path), image)


def test_image_folder_reads_grey_and_colour_pngs_with_masks(tmp_path) -> None:
    grey = np.full((40, 50), 60, np.uint8)
    colour = np.zeros((30, 20, 3), np.uint8)
    colour[..., 1] = 90  # BGR, as OpenCV writes: pure green
    mask = np.zeros((40, 50), np.uint8)
    mask[5:10, 5:10] = 255
    write_png(tmp_path / "images" / "0000.png", grey)
    write_png(tmp_path / "images" / "0001.png", colour)
    write_png(tmp_path / "masks" / "0000.png", mask)
    write_png(tmp_path / "masks" / "0001.png", np.zeros((30, 20), np.uint8))
    images = read_image_folder(tmp_path)
    assert images.sources == ("0000", "0001") and images.dynamic_range_db is None
    assert images.images[1].shape == (30, 20)
    assert images.images[1][0, 0] == round(0.587 * 90)  # the luma of green
    assert images.vessels[0].sum() == 25 and not images.vessels[1].any()


@pytest.mark.parametrize(
    ("damage", "message"),
    [
        ("no folder", "no such folder"),
        ("no masks folder", "masks: no such folder"),
        ("no mask", "images/0001.png: has no mask"),
        ("mask size", "0001.png: 9x8, but its image"),
        ("16-bit", "is a I;16 image; expected 8-bit grey, RGB or palette"),
        ("not a png", "not a readable image"),
        ("empty", "images: "),
    ],
)
def test_image_folder_errors_name_the_file(tmp_path, damage: str, message: str) -> None:
    root = tmp_path / "real"
    for name in ("0000.png", "0001.png"):
        write_png(root / "images" / name, np.full((8, 10), 50, np.uint8))
        write_png(root / "masks" / name, np.zeros((8, 10), np.uint8))
    if damage == "no folder":
        root = tmp_path / "nowhere"
    elif damage == "no masks folder":
        for path in (root / "masks").iterdir():
            path.unlink()
        (root / "masks").rmdir()
    elif damage == "no mask":
        (root / "masks" / "0001.png").unlink()
    elif damage == "mask size":
        write_png(root / "masks" / "0001.png", np.zeros((8, 9), np.uint8))
    elif damage == "16-bit":
        write_png(root / "images" / "0001.png", np.full((8, 10), 5000, np.uint16))
    elif damage == "not a png":
        (root / "images" / "0001.png").write_text("not an image")
    elif damage == "empty":
        for path in (root / "images").iterdir():
            path.unlink()
    with pytest.raises(ResusError, match=re.escape(message)):
        read_image_folder(root)


def test_sweep_sets_take_the_dynamic_range_their_provenance_records(tmp_path) -> None:
    import dataclasses

    from sweep_samples import sample_sweep

    for name, range_db in (("a.h5", 60.0), ("b.h5", 60.0), ("c.h5", 48.0)):
        sweep = dataclasses.replace(sample_sweep(n=2), provenance={"dynamic_range_db": range_db})
        write_sweep(tmp_path / name, sweep)
    assert read_sweep_set([tmp_path / "a.h5", tmp_path / "b.h5"]).dynamic_range_db == 60.0
    assert read_sweep_set([tmp_path / "a.h5", tmp_path / "c.h5"]).dynamic_range_db is None


def test_sweep_set_reads_evenly_spaced_frames_and_artery_and_vein(tmp_path) -> None:
    from sweep_samples import sample_sweep

    sweep = sample_sweep(n=9, rows=24, cols=32)
    write_sweep(tmp_path / "s.h5", sweep)
    images = read_sweep_set([tmp_path / "s.h5"], frames=3)
    assert images.sources == ("s.h5 #0", "s.h5 #4", "s.h5 #8")
    assert images.dynamic_range_db == 50.0  # the simulator's default display
    np.testing.assert_array_equal(images.images[1], sweep.frames[4])
    assert sweep.labels is not None
    np.testing.assert_array_equal(images.vessels[2], np.isin(sweep.labels[8], (ARTERY, VEIN)))
    unlabelled = sample_sweep(n=3, optional=False)
    write_sweep(tmp_path / "u.h5", unlabelled)
    with pytest.raises(ResusError, match=r"u\.h5: the sweep has no labels"):
        read_sweep_set([tmp_path / "u.h5"])
