"""The U-Net (segmentation-models-pytorch), its optional ImageNet encoder, and the device.

smp's default `encoder_weights="imagenet"` downloads from a model hub that these machines
cannot reach, so models are always built with `encoder_weights=None`; ImageNet weights come
only from a local torchvision-format ResNet state dict.
"""

from __future__ import annotations

from collections.abc import Mapping
from pathlib import Path

import segmentation_models_pytorch as smp
import torch

from resus.errors import ResusError
from resus.segmentation.presets import ModelConfig


def build_model(config: ModelConfig, encoder_weights: Path | None = None) -> smp.Unet:
    """A 1-channel U-Net; with `encoder_weights`, its encoder starts from that ResNet file.

    The weights are loaded into a 3-channel encoder, whose first convolution is then folded
    to one channel by summing the colour filters (`set_in_channels(1, pretrained=True)`).
    """
    in_channels = 1 if encoder_weights is None else 3
    model = smp.Unet(
        encoder_name=config.encoder_name,
        encoder_depth=config.encoder_depth,
        encoder_weights=None,
        decoder_channels=config.decoder_channels,
        in_channels=in_channels,
        classes=config.classes,
    )
    if encoder_weights is not None:
        state_dict = read_state_dict(encoder_weights)
        problem = state_dict_mismatch(model.encoder.state_dict(), state_dict)
        if problem:
            raise ResusError(
                f"not a torchvision {config.encoder_name} state dict: {problem}", encoder_weights
            )
        model.encoder.load_state_dict(dict(state_dict))
        model.encoder.set_in_channels(1, pretrained=True)
    return model


def load_torch_file(path: Path, missing: str, unreadable: str) -> object:
    """What a torch file holds, read safely (`weights_only=True`: no pickled code runs) onto
    the CPU; a missing file or one torch cannot read is a ResusError (`missing`, `unreadable`
    and the reason) naming the path."""
    path = Path(path)
    if not path.is_file():
        raise ResusError(missing, path)
    try:
        return torch.load(path, map_location="cpu", weights_only=True)
    except Exception as error:
        raise ResusError(f"{unreadable} ({type(error).__name__})", path) from None


def read_state_dict(path: Path) -> Mapping[str, torch.Tensor]:
    """A tensor state dict from a torch file, read safely (`weights_only=True`)."""
    state_dict = load_torch_file(
        path, missing="weights file not found", unreadable="not a readable torch weights file"
    )
    if not isinstance(state_dict, Mapping) or not all(
        isinstance(value, torch.Tensor) for value in state_dict.values()
    ):
        raise ResusError("weights file does not hold a state dict of tensors", path)
    return state_dict


def state_dict_mismatch(
    expected: Mapping[str, torch.Tensor], given: Mapping[str, torch.Tensor]
) -> str:
    """What keeps `given` from loading into a module whose state is `expected` ("" if nothing).

    A torchvision ResNet's classifier (`fc.*`) is allowed: the encoder has none and drops it.
    """
    given_keys = set(given) - {"fc.weight", "fc.bias"}
    missing = sorted(set(expected) - given_keys)
    unexpected = sorted(given_keys - set(expected))
    reshaped = sorted(
        key for key in set(expected) & given_keys if expected[key].shape != given[key].shape
    )
    problems = [
        f"{len(keys)} {what} (e.g. {keys[0]})"
        for keys, what in (
            (missing, "missing keys"),
            (unexpected, "unexpected keys"),
            (reshaped, "shape mismatches"),
        )
        if keys
    ]
    return ", ".join(problems)


def resolve_device(name: str | None = None) -> torch.device:
    """`name` as a torch device; None or "auto" picks CUDA when present, else the CPU."""
    if name in (None, "auto"):
        return torch.device("cuda" if torch.cuda.is_available() else "cpu")
    try:
        device = torch.device(name)
    except RuntimeError:
        raise ResusError(f"device {name!r} is not a torch device (try cpu, cuda, auto)") from None
    if device.type == "cuda" and not torch.cuda.is_available():
        raise ResusError(f"device {name!r}: CUDA is not available on this machine")
    return device
