"""Segmenting new images with a trained model, or with several as one.

Images of any size are resized to the network's square input, and the class scores are
resized back (bilinear) before the arg-max, so labels come out at the images' own size. A
single network's scores are its logits; an ensemble's are its members' mean class
probabilities (logits of separately trained networks share no scale, probabilities do).

`mirror` also segments every image mirrored left to right and averages the two (flipped
back): test-time augmentation with the one flip that is physics, not a trick. A linear
probe's image of a left groin is the mirror of a right one's, and which side of the screen is
medial is the sonographer's choice of the probe's orientation, so a network trained with
horizontal flips must label an image and its mirror alike; where it does not, averaging the
two cancels part of its error. Measured on the real images of usgra-seg with seven 128 px
simulation-only models (README Sim-to-real): vessel IoU +0.000 to +0.025, +0.012 on average
(seed 0: 0.372 alone, 0.397 mirrored), and +0.005 for a five-model ensemble, whose members'
disagreement already averages much of the same error; turning the image upside down as well
(no scanner does) added nothing (seed 0: 0.391).

`input_sizes` segments every image at several network input sizes and averages the class
probabilities (each size's scores resized to the image first): test-time zoom. The network
sees an image resized to its square input, so how large a vessel looks to it depends on the
scanner's depth setting and the export's framing, which vary from scanner to scanner and
image to image; averaging over a quarter less and a quarter more magnification
(`Segmenter.zooms`) makes the labels depend less on that one setting, as the scanner zoom of
training (`resus.segmentation.zoom`) makes the network. Measured on usgra-seg with the five
128 px simulation-only models of README Sim-to-real: vessel IoU +0.008 to +0.031 over
mirroring alone, +0.019 on average, and +0.013 for their ensemble.
"""

from __future__ import annotations

from collections.abc import Sequence

import numpy as np
import torch
from torch import nn
from tqdm import tqdm

from resus.errors import ResusError
from resus.segmentation.data import images_to_tensor, resize_images


@torch.no_grad()
def predict(
    model: nn.Module | Sequence[nn.Module],
    images: np.ndarray,
    *,
    image_size: int,
    batch_size: int = 32,
    progress: bool = False,
    mirror: bool = False,
    input_sizes: Sequence[int] | None = None,
) -> np.ndarray:
    """(N, H, W) uint8 images (array or h5py dataset) -> (N, H, W) uint8 labels, batched.

    Runs on the model's device; `image_size` is the size the model was trained at. A
    sequence of models (an ensemble: one device, one input size) labels by the mean of their
    class probabilities; `mirror` adds each image's left-right mirror to that mean, and
    `input_sizes` (None: `image_size` alone) the images segmented at each of those sizes.
    """
    if len(images.shape) != 3 or images.dtype != np.uint8:
        raise ResusError(f"predict needs (N, H, W) uint8 images, got {images.shape} {images.dtype}")
    models = [model] if isinstance(model, nn.Module) else list(model)
    if not models:
        raise ResusError("predict needs at least one model")
    device = next(models[0].parameters()).device
    was_training = [member.training for member in models]
    for member in models:
        member.eval()
    sizes = [image_size] if input_sizes is None else list(input_sizes)
    if not sizes or min(sizes) < 1:
        raise ResusError(f"predict needs positive input sizes, got {sizes}")
    count, height, width = images.shape
    labels = np.empty((count, height, width), dtype=np.uint8)
    starts = range(0, count, batch_size)
    for start in tqdm(starts, desc="segment", unit="batch", disable=not progress):
        batch = np.asarray(images[start : start + batch_size])
        total: torch.Tensor | None = None  # a sum of probabilities: its arg-max is the mean's
        for size in sizes:
            inputs = images_to_tensor(resize_images(batch, size)).to(device)
            scores = class_scores(models, inputs, mirror=mirror, probabilities=len(sizes) > 1)
            if (height, width) != (size, size):
                scores = nn.functional.interpolate(scores, size=(height, width), mode="bilinear")
            total = scores if total is None else total + scores
        assert total is not None  # sizes is not empty
        labels[start : start + len(batch)] = class_argmax(total).cpu().numpy()
    for member, mode in zip(models, was_training, strict=True):
        member.train(mode)
    return labels


def class_scores(
    models: Sequence[nn.Module],
    inputs: torch.Tensor,
    *,
    mirror: bool = False,
    probabilities: bool = False,
) -> torch.Tensor:
    """(N, C, H, W) scores of `inputs`: one model's logits, or the mean softmax of several
    models, or of one or several models on the inputs and on their left-right mirrors;
    `probabilities` gives one model's softmax too (scores to average with others)."""
    if len(models) == 1 and not mirror and not probabilities:
        return models[0](inputs)
    total = torch.zeros((), device=inputs.device)
    for member in models:
        total = total + torch.softmax(member(inputs), dim=1)
        if mirror:
            total = total + torch.softmax(member(inputs.flip(3)), dim=1).flip(3)
    return total / (len(models) * (2 if mirror else 1))


def class_argmax(logits: torch.Tensor) -> torch.Tensor:
    """(N, C, H, W) scores -> (N, H, W) uint8 index of the highest class (the first on a tie,
    as `argmax`). A running comparison over the few classes: on a CPU, `argmax(1)` over the
    strided class axis took 6x longer than segmenting the images (1.8 s against 0.3 s for 32
    images at 534 x 512)."""
    best = logits[:, 0]
    labels = torch.zeros(best.shape, dtype=torch.uint8, device=logits.device)
    for value in range(1, logits.shape[1]):
        scores = logits[:, value]
        labels[scores > best] = value
        best = torch.maximum(best, scores)
    return labels
