"""Stochastic weight averaging: one network whose weights are the mean over a run's last steps.

At a constant learning rate the weights do not settle into one point of a minimum of the
training loss: each step moves them about a wide basin of it. The mean of the weights after
every step of the last epochs lies nearer the basin's middle than any one of them (Izmailov
et al., "Averaging weights leads to wider optima and better generalization", 2018), and a
network there changes its output less when its inputs shift a little, which is what a model
trained on simulated images meets on real ones; averaged densely, over every step, it is the
recipe Cha et al. ("SWAD: domain generalization by seeking flat minima", 2021) found to
generalise across domains. Batch-norm statistics are not weights: the mean network's are
measured afresh in one pass over the training images (`torch.optim.swa_utils.update_bn`).
"""

from __future__ import annotations

from dataclasses import asdict, dataclass

import torch
from torch import nn
from torch.optim.swa_utils import AveragedModel, update_bn
from torch.utils.data import DataLoader

from resus.segmentation.metrics import VesselIoU


class WeightAverage:
    """The running mean of a network's weights over every step from `first_epoch` on."""

    def __init__(self, model: nn.Module, first_epoch: int) -> None:
        self.first_epoch = first_epoch
        self._average = AveragedModel(model)

    def covers(self, epoch: int) -> bool:
        """Whether the steps of `epoch` join the mean."""
        return epoch >= self.first_epoch

    def add(self, model: nn.Module) -> None:
        """Add `model`'s current weights to the mean (after an optimiser step)."""
        self._average.update_parameters(model)

    @property
    def steps(self) -> int:
        """Steps averaged so far."""
        return int(self._average.n_averaged.item())

    def network(self, loader: DataLoader, device: torch.device) -> nn.Module:
        """The mean network, its batch-norm statistics measured over one pass of `loader`."""
        update_bn(loader, self._average, device)
        return self._average.module


@dataclass(frozen=True)
class WeightAverageRecord:
    """Which steps a run's averaged network is the mean of, and how it did on validation."""

    first_epoch: int
    last_epoch: int
    steps: int
    validation_loss: float
    validation_iou: VesselIoU

    def to_dict(self) -> dict:
        return {**asdict(self), "validation_iou": self.validation_iou.to_dict()}

    @classmethod
    def from_dict(cls, data: dict) -> WeightAverageRecord:
        """Inverse of `to_dict`."""
        return cls(**{**data, "validation_iou": VesselIoU.from_dict(data["validation_iou"])})
