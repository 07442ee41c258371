"""A trained segmentation model from its checkpoint, ready to label images of any size.

`load_model(path).predict(images)` is the short way from a `checkpoint.pt` (as `resus train`
writes it) to labels: the network, its input size and its device travel together, so a caller
need not know the preset the model was trained with. `load_ensemble(paths)` makes several
checkpoints one model (a deep ensemble): under a domain shift, such as simulated training
images against real ones, separately trained networks err differently, and their mean class
probabilities err less than any one of them. A model that learnt with horizontal flips also
labels each image mirrored and averages the two (`Segmenter.mirror`), and every model
averages its labelling at three magnifications (`Segmenter.zooms`; both explained in
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

DEFAULT_ZOOMS = (0.75, 1.0, 1.25)
"""Magnifications a model's labels are averaged over by default (test-time zoom): the
trained input size, a quarter less and a quarter more."""


def zoomed_sizes(image_size: int, stride: int, zooms: Sequence[float]) -> tuple[int, ...]:
    """The network input sizes for `zooms` of `image_size`: each the nearest multiple of the
    encoder's `stride` (a U-Net's input must divide by it), at least one stride, repeats
    dropped."""
    if not zooms or min(zooms) <= 0:
        raise ResusError(f"Segmenter.zooms must be positive magnifications, got {tuple(zooms)}")
    sizes = (max(stride, stride * round(image_size * zoom / stride)) for zoom in zooms)
    return tuple(dict.fromkeys(sizes))


class Segmenter:
    """What labels images: its networks (one, or an ensemble's), their input size, the
    images per forward pass, whether it also labels their mirrors, and the checkpoints they
    came from."""

    networks: tuple[nn.Module, ...]
    image_size: int
    batch_size: int
    mirror: bool
    """Average each image's labelling with its left-right mirror's (test-time flips)."""
    zooms: tuple[float, ...]
    """Magnifications of `image_size` whose labellings are averaged (test-time zoom)."""
    stride: int
    """The encoder's total downsampling: every input size is a multiple of it."""
    checkpoints: tuple[Path, ...]

    @property
    def input_sizes(self) -> tuple[int, ...]:
        """The network input sizes the images are segmented at (`zooms` of `image_size`)."""
        return zoomed_sizes(self.image_size, self.stride, self.zooms)

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
                input_sizes=self.input_sizes,
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
        zooms: Sequence[float] = DEFAULT_ZOOMS,
    ) -> None:
        """`mirror` None: mirror when the network learnt with horizontal flips
        (`learnt_mirrors`); `zooms`: (1.0,) for the trained input size alone."""
        self.network = network.eval()
        self.networks = (self.network,)
        self.config = config
        """The checkpoint's config (`model`, and for trained ones `preset`, `regime`, ...)."""
        self.path = path
        """The checkpoint file it came from, if any."""
        self.checkpoints = () if path is None else (Path(path),)
        architecture = ModelConfig.from_dict(config["model"])
        self.image_size = architecture.image_size
        """Side of the square input the network was trained at."""
        self.stride = 2**architecture.encoder_depth
        self.zooms = tuple(float(zoom) for zoom in zooms)
        zoomed_sizes(self.image_size, self.stride, self.zooms)  # refuses bad zooms here
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
    path: Path,
    device: str | torch.device | None = "auto",
    mirror: bool | None = None,
    zooms: Sequence[float] = DEFAULT_ZOOMS,
) -> TrainedModel:
    """The model saved at `path` (a `resus.segmentation-checkpoint/1` file) on `device`
    ("auto": CUDA when present, else the CPU). `mirror` None: as the network learnt
    (`learnt_mirrors`); `zooms` as `TrainedModel`."""
    torch_device = device if isinstance(device, torch.device) else resolve_device(device)
    network, config = load_checkpoint(Path(path), torch_device)
    return TrainedModel(network, config, Path(path), mirror, zooms)


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
        zooms = sorted({member.zooms for member in members})
        if len(zooms) > 1:
            raise ResusError(f"ModelEnsemble.members must share one set of zooms, got {zooms}")
        self.zooms = zooms[0]
        self.stride = max(member.stride for member in members)  # powers of two: the multiple
        self.checkpoints = tuple(path for member in members for path in member.checkpoints)


def load_ensemble(
    paths: Sequence[Path],
    device: str | torch.device | None = "auto",
    mirror: bool | None = None,
    zooms: Sequence[float] = DEFAULT_ZOOMS,
) -> ModelEnsemble:
    """The models saved at `paths` as one ensemble on `device` (as `load_model`)."""
    torch_device = device if isinstance(device, torch.device) else resolve_device(device)
    return ModelEnsemble([load_model(path, torch_device, mirror, zooms) for path in paths])
