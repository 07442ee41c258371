"""Scoring a model on labelled images: IoU and Dice by hand, `load_model(path).predict`, and
`evaluate_folder`'s metrics.json and overlays."""

import json

import numpy as np
import pytest
import torch
from PIL import Image
from tiny_models import tiny_checkpoint
from torch import nn

from resus.errors import ResusError
from resus.segmentation import load_ensemble, load_model
from resus.segmentation.checkpoint import save_checkpoint
from resus.segmentation.data import images_to_tensor, resize_images
from resus.segmentation.evaluate import (
    TRUTH_COLOUR,
    evaluate_folder,
    overlay,
    score_labels,
)
from resus.segmentation.folders import read_folders
from resus.segmentation.inference import class_argmax, class_scores, predict
from resus.segmentation.presets import QUICK
from resus.segmentation.trained_model import DEFAULT_ZOOMS, ModelEnsemble, zoomed_sizes
from sim.labels import ARTERY, VEIN, label_colour

torch.set_num_threads(1)  # one per pytest-xdist worker: more oversubscribes the 2 cores


def boxes(*corners: tuple[int, int, int, int, int]) -> np.ndarray:
    """A 4 x 4 label map with `value` in rows r0:r1, columns c0:c1 for each (r0, r1, c0, c1,
    value)."""
    labels = np.zeros((4, 4), np.uint8)
    for r0, r1, c0, c1, value in corners:
        labels[r0:r1, c0:c1] = value
    return labels


def test_iou_and_dice_match_a_hand_count() -> None:
    # image a: truth rows 0-1, prediction rows 1-2 (columns 0-1): intersection 2, union 6
    # image b: nothing in either: IoU 1, Dice 1 by definition
    # image c: truth 4 px "vessel" (label 1), prediction 2 of them called vein: I 2, U 4
    truth = [boxes((0, 2, 0, 2, 1)), boxes(), boxes((2, 4, 2, 4, 1))]
    predicted = [boxes((1, 3, 0, 2, 1)), boxes(), boxes((2, 3, 2, 4, VEIN))]
    evaluation = score_labels(["a", "b", "c"], predicted, truth, separates_classes=False)
    assert evaluation.classes == ("vessel",)
    a, b, c = (image["vessel"] for image in evaluation.per_image)
    assert (a.intersection, a.union, a.iou, a.dice) == (2, 6, pytest.approx(1 / 3), 0.5)
    assert (b.iou, b.dice) == (1.0, 1.0)
    assert (c.intersection, c.union, c.iou, c.dice) == (2, 4, 0.5, pytest.approx(2 / 3))
    pooled = evaluation.pooled()["vessel"]
    assert (pooled.intersection, pooled.union) == (4, 10)
    assert (pooled.iou, pooled.dice) == (pytest.approx(0.4), pytest.approx(8 / 14))
    mean = evaluation.per_image_mean()["vessel"]
    assert mean["iou"] == pytest.approx((1 / 3 + 1 + 0.5) / 3)
    assert mean["dice"] == pytest.approx((0.5 + 1 + 2 / 3) / 3)
    assert evaluation.both_empty() == {"vessel": 1}
    table = evaluation.to_dict()
    assert table["pooled"]["vessel"]["iou"] == pytest.approx(0.4)
    assert [row["name"] for row in table["per_image"]] == ["a", "b", "c"]


def strip(true: int, hit: int, extra: int) -> tuple[np.ndarray, np.ndarray]:
    """A 10 x 10 truth with `true` vessel pixels (row-major from the corner) and a prediction
    that finds the first `hit` of them and `extra` pixels from the far corner backwards."""
    truth, predicted = np.zeros(100, np.uint8), np.zeros(100, np.uint8)
    truth[:true] = 1
    predicted[:hit] = 1
    predicted[100 - extra :] = 1
    return predicted.reshape(10, 10), truth.reshape(10, 10)


def test_scores_by_vessel_size_match_a_hand_count() -> None:
    """No vessel (5 px called vessel), 1 % missed, 2 % found exactly, and 10 % and 20 % found
    in part or whole: groups none, < 1.5 %, 1.5-3 %, >= 6 % (3-6 % is empty, left out)."""
    cases = {"n": (0, 0, 5), "s": (1, 0, 0), "m": (2, 2, 0), "l": (10, 5, 5), "xl": (20, 20, 0)}
    predicted, truth = zip(*(strip(*case) for case in cases.values()), strict=True)
    evaluation = score_labels(list(cases), predicted, truth, separates_classes=False)
    groups = {group.label: group for group in evaluation.by_vessel_size()}
    assert list(groups) == ["none", "< 1.5%", "1.5%-3.0%", ">= 6.0%"]
    assert (groups["none"].images, groups["none"].predicted_share) == (1, 0.05)
    assert (groups["< 1.5%"].vessel.iou, groups["< 1.5%"].missed) == (0.0, 1)
    assert (groups["1.5%-3.0%"].vessel.iou, groups["1.5%-3.0%"].missed) == (1.0, 0)
    large = groups[">= 6.0%"]
    assert (large.images, large.vessel.intersection, large.vessel.union) == (2, 25, 35)
    assert large.predicted_share == 1.0  # 10 + 20 predicted for 10 + 20 true
    table = evaluation.to_dict()
    assert [row["label"] for row in table["by_vessel_size"]] == list(groups)
    assert [row["true_vessel_share"] for row in table["per_image"]] == [0, 0.01, 0.02, 0.1, 0.2]
    assert evaluation.summary()[-1] == (
        "vessel by true area: none (1 images): 5.0% called vessel; < 1.5% (1): IoU 0.000, "
        "1 missed; 1.5%-3.0% (1): IoU 1.000, 0 missed; >= 6.0% (2): IoU 0.714, 0 missed"
    )


def test_artery_and_vein_are_scored_apart_when_the_masks_tell_them() -> None:
    # truth: artery top-left 2x2, vein bottom-right 2x2
    # prediction: artery top-left 2x2 right, vein called artery in its top row
    truth = [boxes((0, 2, 0, 2, ARTERY), (2, 4, 2, 4, VEIN))]
    predicted = [boxes((0, 2, 0, 2, ARTERY), (2, 3, 2, 4, ARTERY))]
    evaluation = score_labels(["x"], predicted, truth, separates_classes=True)
    assert evaluation.classes == ("vessel", "artery", "vein")
    pooled = evaluation.pooled()
    assert (pooled["artery"].intersection, pooled["artery"].union) == (4, 6)
    assert (pooled["vein"].intersection, pooled["vein"].union) == (0, 4)
    assert (pooled["vessel"].intersection, pooled["vessel"].union) == (6, 8)
    assert (pooled["vein"].iou, pooled["vein"].dice) == (0.0, 0.0)
    assert evaluation.both_empty() == {"vessel": 0, "artery": 0, "vein": 0}


def test_load_model_predicts_arrays_single_images_and_lists(tmp_path) -> None:
    network = tiny_checkpoint(tmp_path / "model.pt")
    model = load_model(tmp_path / "model.pt", device="cpu")
    assert model.image_size == QUICK.model.image_size and model.device.type == "cpu"
    rng = np.random.default_rng(0)
    stack = rng.integers(0, 256, (3, 40, 52), dtype=np.uint8)
    labels = model.predict(stack)
    assert labels.shape == stack.shape and labels.dtype == np.uint8 and labels.max() <= VEIN
    expected = predict(network, stack, image_size=64, input_sizes=model.input_sizes)
    np.testing.assert_array_equal(labels, expected)
    np.testing.assert_array_equal(model.predict(stack[1]), labels[1])
    mixed = [stack[0], rng.integers(0, 256, (30, 30), dtype=np.uint8), stack[2]]
    listed = model.predict(mixed)
    assert [label.shape for label in listed] == [(40, 52), (30, 30), (40, 52)]
    np.testing.assert_array_equal(listed[2], labels[2])
    with pytest.raises(ResusError, match=r"image 1: expected an \(H, W\) uint8 image"):
        model.predict([stack[0], stack[1].astype(np.float32)])
    with pytest.raises(ResusError, match="checkpoint not found"):
        load_model(tmp_path / "none.pt")


def test_an_ensemble_labels_by_its_members_mean_class_probabilities(tmp_path) -> None:
    # member a: logits (0, 2, 0) everywhere, softmax (0.106, 0.787, 0.106): artery
    # member b: logits (0, 0, 3) everywhere, softmax (0.045, 0.045, 0.909): vein
    # mean (0.076, 0.416, 0.508): vein, the surer member wins
    tiny_checkpoint(tmp_path / "a.pt", logits=(0.0, 2.0, 0.0))
    tiny_checkpoint(tmp_path / "b.pt", logits=(0.0, 0.0, 3.0))
    images = np.random.default_rng(1).integers(0, 256, (2, 30, 40), dtype=np.uint8)
    a, b = (load_model(tmp_path / f"{name}.pt", "cpu").predict(images) for name in "ab")
    assert (a == ARTERY).all() and (b == VEIN).all()
    ensemble = load_ensemble([tmp_path / "a.pt", tmp_path / "b.pt"], "cpu")
    assert (ensemble.predict(images) == VEIN).all()
    assert ensemble.checkpoints == (tmp_path / "a.pt", tmp_path / "b.pt")
    listed = ensemble.predict([images[0], images[1][:20]])
    assert [label.shape for label in listed] == [(30, 40), (20, 40)]
    tiny_checkpoint(tmp_path / "wide.pt", size=96)
    with pytest.raises(ResusError, match=r"must share one input size, got sizes \[64, 96\]"):
        load_ensemble([tmp_path / "a.pt", tmp_path / "wide.pt"], "cpu")


def test_mirror_averages_the_probabilities_of_an_image_and_its_mirror_flipped_back() -> None:
    torch.manual_seed(0)
    members = [nn.Conv2d(1, 3, 5, padding=2).eval() for _ in range(2)]  # random kernels: not
    inputs = torch.rand(2, 1, 16, 20)  # mirror-symmetric, so an image and its mirror differ

    def probabilities(member: nn.Module, x: torch.Tensor) -> torch.Tensor:
        return torch.softmax(member(x), dim=1)

    one = (
        probabilities(members[0], inputs) + probabilities(members[0], inputs.flip(3)).flip(3)
    ) / 2
    assert torch.allclose(class_scores(members[:1], inputs, mirror=True), one, atol=1e-6)
    assert not torch.allclose(one, probabilities(members[0], inputs), atol=1e-3)
    both = sum(probabilities(m, inputs) + probabilities(m, inputs.flip(3)).flip(3) for m in members)
    assert torch.allclose(class_scores(members, inputs, mirror=True), both / 4, atol=1e-6)
    # so a mirrored image gets the mirrored labels, bit for bit
    images = np.random.default_rng(2).integers(0, 256, (3, 16, 16), dtype=np.uint8)
    labels = predict(members[0], images, image_size=16, mirror=True)
    mirrored = predict(members[0], images[:, :, ::-1].copy(), image_size=16, mirror=True)
    np.testing.assert_array_equal(mirrored, labels[:, :, ::-1])
    assert not np.array_equal(labels, predict(members[0], images, image_size=16))


def test_a_model_mirrors_when_it_learnt_with_horizontal_flips(tmp_path) -> None:
    network = tiny_checkpoint(tmp_path / "plain.pt")
    for name, augment, flip_p in (("flips", True, 0.5), ("upright", True, 0.0), ("us", False, 0.5)):
        config = {"model": QUICK.model.to_dict(), "augment": augment}
        config["preset"] = {"augmentation": {"horizontal_flip_p": flip_p}}
        save_checkpoint(tmp_path / f"{name}.pt", network, config)
    assert load_model(tmp_path / "flips.pt", "cpu").mirror
    assert not load_model(tmp_path / "upright.pt", "cpu").mirror
    assert not load_model(tmp_path / "us.pt", "cpu").mirror
    assert not load_model(tmp_path / "plain.pt", "cpu").mirror  # no training record at all
    assert load_model(tmp_path / "plain.pt", "cpu", mirror=True).mirror
    assert not load_model(tmp_path / "flips.pt", "cpu", mirror=False).mirror
    paths = [tmp_path / "flips.pt", tmp_path / "us.pt"]
    assert not load_ensemble(paths, "cpu").mirror  # only when every member learnt both sides
    assert load_ensemble(paths[:1] * 2, "cpu").mirror


def test_zoomed_sizes_are_multiples_of_the_stride_around_the_trained_size() -> None:
    assert zoomed_sizes(128, 16, DEFAULT_ZOOMS) == (96, 128, 160)
    assert zoomed_sizes(64, 8, DEFAULT_ZOOMS) == (48, 64, 80)
    assert zoomed_sizes(128, 16, (1.0, 0.99, 0.05)) == (128, 16)  # repeats dropped, >= stride
    for bad in ((), (0.0, 1.0), (-1.0,)):
        with pytest.raises(ResusError, match=r"Segmenter\.zooms must be positive"):
            zoomed_sizes(128, 16, bad)


def test_zooming_averages_the_probabilities_of_each_input_size(tmp_path) -> None:
    """`predict` with several input sizes labels by the sum of each size's class
    probabilities resized to the image, computed here by hand; one size is the plain path."""
    network = tiny_checkpoint(tmp_path / "tiny.pt")
    images = np.random.default_rng(4).integers(0, 256, (3, 30, 44), dtype=np.uint8)
    sizes = (48, 64, 80)
    total = torch.zeros(())
    for size in sizes:
        inputs = images_to_tensor(resize_images(images, size))
        with torch.no_grad():
            probabilities = torch.softmax(network(inputs), dim=1)
        total = total + nn.functional.interpolate(probabilities, size=(30, 44), mode="bilinear")
    expected = class_argmax(total).numpy()
    zoomed = predict(network, images, image_size=64, input_sizes=sizes)
    np.testing.assert_array_equal(zoomed, expected)
    plain = predict(network, images, image_size=64)
    np.testing.assert_array_equal(predict(network, images, image_size=64, input_sizes=[64]), plain)
    assert not np.array_equal(zoomed, plain)  # an untrained network answers each size apart
    model = load_model(tmp_path / "tiny.pt", "cpu")
    assert model.zooms == DEFAULT_ZOOMS and model.input_sizes == sizes  # QUICK: stride 8
    np.testing.assert_array_equal(model.predict(images), zoomed)
    single = load_model(tmp_path / "tiny.pt", "cpu", zooms=(1.0,))
    np.testing.assert_array_equal(single.predict(images), plain)
    with pytest.raises(ResusError, match="must share one set of zooms"):
        ModelEnsemble([model, single])


def test_overlay_tints_the_prediction_and_outlines_the_truth() -> None:
    image = np.full((16, 16), 100, np.uint8)
    truth = np.zeros((16, 16), np.uint8)
    truth[4:12, 4:12] = 1
    predicted = np.zeros_like(truth)
    predicted[0:3, 0:3] = ARTERY
    rgb = overlay(image, truth, predicted)
    assert rgb.shape == (16, 16, 3) and rgb.dtype == np.uint8
    assert tuple(rgb[4, 8]) == TRUTH_COLOUR and tuple(rgb[8, 8]) == (100, 100, 100)
    red = np.array(label_colour(ARTERY))
    assert np.argmax(rgb[1, 1]) == 0 and np.all(rgb[1, 1] != 100)
    assert np.abs(rgb[1, 1].astype(int) - red).sum() < np.abs(100 - red).sum()


def test_evaluate_folder_writes_metrics_and_overlays(tmp_path) -> None:
    images, masks = tmp_path / "images", tmp_path / "masks"
    images.mkdir(), masks.mkdir()
    vessel_pixels = 0
    for name, shape, rows in (("a", (24, 32), 6), ("b", (20, 20), 0), ("c", (24, 32), 3)):
        Image.fromarray(np.full(shape, 90, np.uint8)).save(images / f"{name}.png")
        mask = np.zeros(shape, np.uint8)
        mask[:rows, :10] = 255
        vessel_pixels += rows * 10
        Image.fromarray(mask).save(masks / f"{name}.png")
    tiny_checkpoint(tmp_path / "model.pt", label=ARTERY)  # calls every pixel artery
    model = load_model(tmp_path / "model.pt", device="cpu")
    out = tmp_path / "out"
    evaluation = evaluate_folder(model, read_folders(images, masks), out, progress=False)
    all_pixels = 2 * 24 * 32 + 20 * 20
    metrics = json.loads((out / "metrics.json").read_text())
    assert metrics["classes"] == ["vessel"] and metrics["images"] == 3
    assert metrics["pooled"]["vessel"]["intersection"] == vessel_pixels
    assert metrics["pooled"]["vessel"]["union"] == all_pixels
    assert metrics["pooled"]["vessel"]["iou"] == pytest.approx(vessel_pixels / all_pixels)
    assert evaluation.pooled()["vessel"].iou == pytest.approx(vessel_pixels / all_pixels)
    assert metrics["per_image"][1] == {
        "name": "b",
        "true_vessel_share": 0.0,
        "vessel": {"iou": 0.0, "dice": 0.0, "intersection": 0, "union": 400},
    }
    none = metrics["by_vessel_size"][0]  # image b: every pixel called artery, none is vessel
    assert (none["label"], none["images"], none["predicted_share"]) == ("none", 1, 1.0)
    assert metrics["checkpoints"] == [str(tmp_path / "model.pt")] and metrics["device"] == "cpu"
    for name, shape in (("a", (24, 32)), ("b", (20, 20)), ("c", (24, 32))):
        with Image.open(out / "overlays" / f"{name}.png") as written:
            assert written.mode == "RGB" and written.size == (shape[1], shape[0])
