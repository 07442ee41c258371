"""The U-Net, its ImageNet encoder from a local file, checkpoints and device choice."""

import dataclasses

import numpy as np
import pytest
import torch
import torchvision

from resus.errors import ResusError
from resus.segmentation.checkpoint import load_checkpoint, save_checkpoint
from resus.segmentation.inference import class_argmax, predict
from resus.segmentation.loso import run_loso, unavailable_reason
from resus.segmentation.model import build_model, resolve_device
from resus.segmentation.presets import QUICK, ModelConfig, get_preset
from resus.segmentation.synthetic import synthetic_subject

torch.set_num_threads(1)  # one per pytest-xdist worker: more oversubscribes the 2 cores


def test_imagenet_encoder_loads_a_torchvision_state_dict(tmp_path) -> None:
    torch.manual_seed(0)
    resnet = torchvision.models.resnet18()
    path = tmp_path / "resnet18.pth"
    torch.save(resnet.state_dict(), path)
    model = build_model(QUICK.model, encoder_weights=path)
    conv1 = model.encoder.conv1.weight.detach()
    assert conv1.shape == (64, 1, 7, 7)  # colour filters folded into one grey channel
    torch.testing.assert_close(conv1, resnet.conv1.weight.detach().sum(1, keepdim=True))
    torch.testing.assert_close(model.encoder.layer2[0].conv1.weight, resnet.layer2[0].conv1.weight)
    logits = model(torch.zeros(2, 1, 64, 64))
    assert logits.shape == (2, 3, 64, 64)


def test_imagenet_weights_errors_name_the_file(tmp_path) -> None:
    missing = tmp_path / "missing.pth"
    with pytest.raises(ResusError, match=r"missing\.pth: weights file not found"):
        build_model(QUICK.model, encoder_weights=missing)
    garbage = tmp_path / "garbage.pth"
    garbage.write_bytes(b"not a torch file")
    with pytest.raises(ResusError, match=r"garbage\.pth: not a readable torch weights file"):
        build_model(QUICK.model, encoder_weights=garbage)
    wrong = tmp_path / "resnet34.pth"
    torch.save(torchvision.models.resnet34().state_dict(), wrong)
    with pytest.raises(ResusError, match=r"not a torchvision resnet18 state dict: .*unexpected"):
        build_model(QUICK.model, encoder_weights=wrong)
    not_tensors = tmp_path / "dict.pth"
    torch.save({"conv1.weight": [1, 2]}, not_tensors)
    with pytest.raises(ResusError, match="state dict of tensors"):
        build_model(QUICK.model, encoder_weights=not_tensors)


def test_imagenet_regime_without_weights_is_not_run() -> None:
    subjects = [synthetic_subject(name, 6, seed=i) for i, name in enumerate("ab")]
    assert "weights" in unavailable_reason("imagenet", [], None)
    result = run_loso(subjects, [], ["imagenet"], QUICK, progress=False)
    assert result.iou == {} and result.comparisons == {}
    assert result.to_dict()["regimes"]["imagenet"]["status"] == "not run"
    with pytest.raises(ResusError, match="unknown regime 'pretrained'"):
        unavailable_reason("pretrained", [], None)


def test_checkpoint_round_trip_gives_identical_predictions(tmp_path) -> None:
    torch.manual_seed(1)
    model = build_model(QUICK.model).eval()
    path = tmp_path / "model.pt"
    save_checkpoint(path, model, {"model": QUICK.model.to_dict(), "regime": "us"})
    loaded, config = load_checkpoint(path)
    assert config["regime"] == "us"
    images = synthetic_subject("s", 5, size=80, seed=2).images
    before = predict(model, images, image_size=64)
    assert before.shape == images.shape
    np.testing.assert_array_equal(predict(loaded, images, image_size=64), before)
    for key, value in model.state_dict().items():
        torch.testing.assert_close(loaded.state_dict()[key], value, rtol=0, atol=0)


def test_bad_checkpoints_error_clearly(tmp_path) -> None:
    with pytest.raises(ResusError, match="checkpoint not found"):
        load_checkpoint(tmp_path / "none.pt")
    weights = tmp_path / "weights.pt"
    torch.save(torchvision.models.resnet18().state_dict(), weights)
    with pytest.raises(ResusError, match=r"not a resus\.segmentation-checkpoint/1 checkpoint"):
        load_checkpoint(weights)


def test_device_choice() -> None:
    expected = "cuda" if torch.cuda.is_available() else "cpu"
    assert resolve_device(None).type == expected == resolve_device("auto").type
    assert resolve_device("cpu") == torch.device("cpu")
    with pytest.raises(ResusError, match="not a torch device"):
        resolve_device("gpu0")
    if not torch.cuda.is_available():
        with pytest.raises(ResusError, match="CUDA is not available"):
            resolve_device("cuda")


def test_the_cpu128_preset_segments_at_128_px_with_four_encoder_stages() -> None:
    """128 px in, per-pixel scores for the three classes out, at the image's own size."""
    preset = get_preset("cpu128")
    assert preset.model.image_size == 128 and preset.model.encoder_depth == 4
    model = build_model(preset.model).eval()
    with torch.no_grad():
        scores = model(torch.zeros(1, 1, 128, 128))
    assert scores.shape == (1, 3, 128, 128)


def test_class_argmax_is_torch_argmax_first_class_on_ties() -> None:
    generator = torch.Generator().manual_seed(3)
    logits = torch.randint(0, 3, (4, 3, 17, 9), generator=generator).float()  # many ties
    labels = class_argmax(logits)
    assert labels.dtype == torch.uint8
    assert torch.equal(labels.long(), logits.argmax(1))


@pytest.mark.parametrize(
    ("make", "message"),
    [
        (lambda: ModelConfig(encoder_depth=3, decoder_channels=(64, 32)),
         r"ModelConfig\.decoder_channels needs one channel count per encoder stage"),
        (lambda: ModelConfig(encoder_depth=4, decoder_channels=(64, 32, 16, 8), image_size=100),
         r"ModelConfig\.image_size 100 must be divisible by 2\*\*encoder_depth = 16"),
        (lambda: dataclasses.replace(QUICK, validation_fraction=1.0),
         r"TrainingPreset\.validation_fraction must be in \(0, 1\), got 1\.0"),
        (lambda: dataclasses.replace(QUICK, patience=0),
         r"TrainingPreset\.patience must be at least 1, got 0"),
        (lambda: dataclasses.replace(QUICK, max_epochs=5, weight_averaging_epochs=6),
         r"TrainingPreset\.weight_averaging_epochs must be in \[0, max_epochs = 5\]"),
    ],
)  # fmt: skip
def test_refused_model_and_training_settings_are_named(make, message: str) -> None:
    with pytest.raises(ResusError, match=rf"^{message}"):
        make()


def test_predict_refuses_what_it_cannot_segment() -> None:
    model = build_model(QUICK.model)
    images = np.zeros((2, 16, 16), np.uint8)
    cases = [
        ({"images": images.astype(np.float32)}, r"needs \(N, H, W\) uint8 images, got \(2, 16"),
        ({"images": images[0]}, r"needs \(N, H, W\) uint8 images, got \(16, 16\) uint8"),
        ({"model": []}, r"needs at least one model"),
        ({"input_sizes": [64, 0]}, r"needs positive input sizes, got \[64, 0\]"),
    ]
    for changes, message in cases:
        arguments = {"model": model, "images": images, **changes}
        with pytest.raises(ResusError, match=rf"^predict {message}"):
            predict(arguments.pop("model"), arguments.pop("images"), image_size=64, **arguments)
