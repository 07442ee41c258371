"""Tiny segmentation checkpoints with known answers, for tests that need a trained model."""

from __future__ import annotations

import torch
from torch import nn

from resus.segmentation.checkpoint import save_checkpoint
from resus.segmentation.model import build_model
from resus.segmentation.presets import QUICK


def tiny_checkpoint(path, label: int | None = None) -> nn.Module:
    """A QUICK-sized untrained U-Net saved at `path`; with `label`, its head is set to call
    every pixel that class (zero weights, one positive bias), so its scores are known."""
    torch.manual_seed(0)
    model = build_model(QUICK.model).eval()
    if label is not None:
        head = model.segmentation_head[0]
        with torch.no_grad():
            head.weight.zero_()
            head.bias.copy_(torch.eye(QUICK.model.classes)[label])
    save_checkpoint(path, model, {"model": QUICK.model.to_dict()})
    return model
