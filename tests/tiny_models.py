"""Tiny segmentation checkpoints with known answers, for tests that need a trained model."""

from __future__ import annotations

import dataclasses
from collections.abc import Sequence

import torch
from torch import nn

from resus.segmentation.checkpoint import save_checkpoint
from resus.segmentation.model import build_model
from resus.segmentation.presets import QUICK


def tiny_checkpoint(
    path, label: int | None = None, logits: Sequence[float] | None = None, size: int = 0
) -> nn.Module:
    """A QUICK-sized untrained U-Net saved at `path`; with `label`, its head is set to call
    every pixel that class (zero weights, one positive bias), and with `logits` to give those
    class scores at every pixel, so its scores are known. `size`: another input size."""
    torch.manual_seed(0)
    config = QUICK.model if not size else dataclasses.replace(QUICK.model, image_size=size)
    model = build_model(config).eval()
    if label is not None:
        logits = torch.eye(QUICK.model.classes)[label].tolist()
    if logits is not None:
        head = model.segmentation_head[0]
        with torch.no_grad():
            head.weight.zero_()
            head.bias.copy_(torch.tensor(logits))
    save_checkpoint(path, model, {"model": config.to_dict()})
    return model
