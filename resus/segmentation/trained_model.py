"""A trained segmentation model from its checkpoint, ready to label images of any size.

`load_model(path).predict(images)` is the short way from a `checkpoint.pt` (as `resus train`
writes it) to labels: the network, its input size and its device travel together, so a caller
need not know the preset the model was trained with. `load_ensemble(paths)` makes several
checkpoints one model (a deep ensemble): under a domain shift, such as simulated training
images against real ones, separately trained networks err differently, and their mean class
probabilities err less than any one of them. A model that learnt with horizontal flips also
labels each image mirrored and averages the two (`Segmenter.mirror`,
`resus.segmentation.inference`).
"""

from __future__ import annotations

from collections.abc import Sequence
from pathlib import Path
from typing import overload

import numpy as np
import torch
from torch import nn

from resus.errors import ResusError
from resus.segmentation.checkpoint import load_checkpoint
from resus.segmentation.inference import predict
from resus.segmentation.model import resolve_device
from resus.segmentation.presets import ModelConfig, TrainingPreset


class Segmenter:
    """What labels images: its networks (one, or an ensemble's), their input size, the
    images per forward pass, whether it also labels their mirrors, and the checkpoints they
    came from."""

    networks: tuple[nn.Module, ...]
    image_size: int
    batch_size: int
    mirror: bool
    """Average each image's labelling with its left-right mirror's (test-time flips)."""
    checkpoints: tuple[Path, ...]

    @property
    def device(self) -> torch.device:
        """Where the networks run."""
        return next(self.networks[0].parameters()).device

    @overload
    def predict(self, images: np.ndarray, *, progress: bool = False) -> np.ndarray: ...

    @overload
    def predict(
        self, images: Sequence[np.ndarray], *, progress: bool = False
    ) -> list[np.ndarray]: ...

    def predict(
        self, images: np.ndarray | Sequence[np.ndarray], *, progress: bool = False
    ) -> np.ndarray | list[np.ndarray]:
        """Labels (0 background, 1 artery, 2 vein) of uint8 grey images at their own size.

        An (N, H, W) array gives an (N, H, W) array, one (H, W) image an (H, W) array, and a
        list of (H, W) images (sizes may differ) a list; images of one size share batches.
        """
        if isinstance(images, np.ndarray) and images.ndim == 2:
            return self.predict(images[None], progress=progress)[0]
        if isinstance(images, np.ndarray):
            return predict(
                self.networks,
                images,
                image_size=self.image_size,
                batch_size=self.batch_size,
                progress=progress,
                mirror=self.mirror,
            )
        by_shape: dict[tuple[int, ...], list[int]] = {}
        for index, image in enumerate(images):
            image = np.asarray(image)
            if image.ndim != 2 or image.dtype != np.uint8:
                raise ResusError(
                    f"image {index}: expected an (H, W) uint8 image, got {image.shape} "
                    f"{image.dtype}"
                )
            by_shape.setdefault(image.shape, []).append(index)
        labels: list[np.ndarray] = [np.empty(0, np.uint8)] * len(images)
        for indices in by_shape.values():
            stacked = np.stack([np.asarray(images[i]) for i in indices])
            for index, label in zip(indices, self.predict(stacked, progress=progress), strict=True):
                labels[index] = label
        return labels


class TrainedModel(Segmenter):
    """A U-Net in eval mode with the config it was saved with."""

    def __init__(
        self,
        network: nn.Module,
        config: dict,
        path: Path | None = None,
        mirror: bool | None = None,
    ) -> None:
        """`mirror` None: mirror when the network learnt with horizontal flips
        (`learnt_mirrors`)."""
        self.network = network.eval()
        self.networks = (self.network,)
        self.config = config
        """The checkpoint's config (`model`, and for trained ones `preset`, `regime`, ...)."""
        self.path = path
        """The checkpoint file it came from, if any."""
        self.checkpoints = () if path is None else (Path(path),)
        self.image_size = ModelConfig.from_dict(config["model"]).image_size
        """Side of the square input the network was trained at."""
        self.batch_size = int(
            config.get("preset", {}).get(
                "evaluation_batch_size", TrainingPreset.evaluation_batch_size
            )
        )
        """Images per forward pass (the training preset's evaluation batch size)."""
        self.mirror = learnt_mirrors(config) if mirror is None else mirror


def learnt_mirrors(config: dict) -> bool:
    """Whether a checkpoint's network trained with horizontal flips (its config's `augment`
    and its preset's `horizontal_flip_p`), so that an image's mirror is as much its domain as
    the image."""
    flip_p = config.get("preset", {}).get("augmentation", {}).get("horizontal_flip_p", 0.0)
    return bool(config.get("augment", False)) and float(flip_p) > 0


def load_model(
    path: Path, device: str | torch.device | None = "auto", mirror: bool | None = None
) -> TrainedModel:
    """The model saved at `path` (a `resus.segmentation-checkpoint/1` file) on `device`
    ("auto": CUDA when present, else the CPU). `mirror` None: as the network learnt
    (`learnt_mirrors`)."""
    torch_device = device if isinstance(device, torch.device) else resolve_device(device)
    network, config = load_checkpoint(Path(path), torch_device)
    return TrainedModel(network, config, Path(path), mirror)


class ModelEnsemble(Segmenter):
    """Trained models of one input size on one device as one model: each image labelled by
    the mean of the members' class probabilities (`resus.segmentation.inference`)."""

    def __init__(self, members: Sequence[TrainedModel]) -> None:
        if not members:
            raise ResusError("ModelEnsemble.members is empty")
        sizes = sorted({member.image_size for member in members})
        if len(sizes) > 1:
            raise ResusError(f"ModelEnsemble.members must share one input size, got sizes {sizes}")
        self.members = tuple(members)
        self.networks = tuple(member.network for member in members)
        self.image_size = sizes[0]
        self.batch_size = min(member.batch_size for member in members)
        self.mirror = all(member.mirror for member in members)
        self.checkpoints = tuple(path for member in members for path in member.checkpoints)


def load_ensemble(
    paths: Sequence[Path], device: str | torch.device | None = "auto", mirror: bool | None = None
) -> ModelEnsemble:
    """The models saved at `paths` as one ensemble on `device` (as `load_model`)."""
    torch_device = device if isinstance(device, torch.device) else resolve_device(device)
    return ModelEnsemble([load_model(path, torch_device, mirror) for path in paths])
