"""Training loss: multiclass Dice, plus cross-entropy by default.

smp's multiclass `DiceLoss` zeroes the term of every class absent from the batch's labels, so
on vessel-free frames it never punishes predicted vessels; cross-entropy scores every pixel
and closes that gap (and gives smoother gradients early in training).
"""

from __future__ import annotations

import segmentation_models_pytorch as smp
import torch
from torch import nn


class SegmentationLoss(nn.Module):
    """Dice (+ cross-entropy) of (B, C, H, W) logits against (B, H, W) integer labels."""

    def __init__(self, cross_entropy: bool = True) -> None:
        super().__init__()
        self.dice = smp.losses.DiceLoss(mode="multiclass", from_logits=True)
        self.cross_entropy = nn.CrossEntropyLoss() if cross_entropy else None

    def forward(self, logits: torch.Tensor, labels: torch.Tensor) -> torch.Tensor:
        loss = self.dice(logits, labels)
        if self.cross_entropy is not None:
            loss = loss + self.cross_entropy(logits, labels)
        return loss
