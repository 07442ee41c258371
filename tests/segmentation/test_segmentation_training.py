"""Training: the loss falls, seeded runs repeat exactly, early stopping keeps the best epoch."""

from dataclasses import replace

import numpy as np
import pytest
import torch
from torch.utils.data import DataLoader

from resus.segmentation.data import SegmentationDataset
from resus.segmentation.losses import SegmentationLoss
from resus.segmentation.model import build_model
from resus.segmentation.presets import QUICK
from resus.segmentation.synthetic import synthetic_subject
from resus.segmentation.train import (
    learning_rate_schedule,
    seed_everything,
    train_model,
    train_one_epoch,
)

torch.set_num_threads(1)  # one per pytest-xdist worker: more oversubscribes the 2 cores

TINY = replace(QUICK, max_epochs=2)


def test_loss_falls_within_a_few_dozen_steps() -> None:
    seed_everything(0)
    dataset = SegmentationDataset([synthetic_subject("s", 64, size=64, seed=3)], 64)
    model = build_model(QUICK.model)
    loss_function = SegmentationLoss()
    optimiser = torch.optim.Adam(model.parameters(), lr=QUICK.learning_rate)
    generator = torch.Generator().manual_seed(0)
    losses = []
    for _ in range(30):
        batch = torch.randint(len(dataset), (8,), generator=generator).tolist()
        images = torch.stack([dataset[i][0] for i in batch])
        labels = torch.stack([dataset[i][1] for i in batch])
        optimiser.zero_grad()
        loss = loss_function(model(images), labels)
        loss.backward()
        optimiser.step()
        losses.append(loss.item())
    assert np.mean(losses[-5:]) < 0.6 * np.mean(losses[:5])


def test_cross_entropy_punishes_vessels_on_vessel_free_frames() -> None:
    labels = torch.zeros(1, 8, 8, dtype=torch.long)  # no vessel anywhere
    says_artery = torch.zeros(1, 3, 8, 8)
    says_artery[:, 1] = 5.0
    says_background = torch.zeros(1, 3, 8, 8)
    says_background[:, 0] = 5.0
    dice_only = SegmentationLoss(cross_entropy=False)
    # Dice drops the terms of classes absent from the labels (artery, vein), so calling every
    # pixel artery costs it only the background term; cross-entropy charges every pixel.
    combined = SegmentationLoss()
    gap_dice = dice_only(says_artery, labels) - dice_only(says_background, labels)
    gap_combined = combined(says_artery, labels) - combined(says_background, labels)
    assert gap_combined > gap_dice + 4.0


def train_twice_data():
    a, b = (synthetic_subject(name, 24, size=64, seed=i) for i, name in enumerate("ab"))
    return [a.take(slice(0, 20)), b.take(slice(0, 20))], [a.take(slice(20, None))]


def test_seeded_runs_are_identical() -> None:
    train_sets, validation_sets = train_twice_data()
    runs = [
        train_model(train_sets, validation_sets, TINY, seed=5, augment=True, progress=False)
        for _ in range(2)
    ]
    assert [r.to_dict() for r in runs[0].history] != []
    for first, second in zip(runs[0].history, runs[1].history, strict=True):
        assert first.train_loss == second.train_loss
        assert first.validation_loss == second.validation_loss
    for key, value in runs[0].model.state_dict().items():
        torch.testing.assert_close(runs[1].model.state_dict()[key], value, rtol=0, atol=0)
    other = train_model(train_sets, validation_sets, TINY, seed=6, augment=True, progress=False)
    assert other.history[0].train_loss != runs[0].history[0].train_loss


def test_early_stopping_keeps_the_best_epoch() -> None:
    train_sets, validation_sets = train_twice_data()
    frozen = replace(QUICK, learning_rate=0.0, max_epochs=10, patience=2)
    result = train_model(train_sets, validation_sets, frozen, progress=False)
    # Nothing learns, so the validation loss never drops below epoch 1's.
    assert result.best_epoch == 1 and len(result.history) == 3 and result.stopped_early
    assert result.config["best_epoch"] == 1
    assert result.summary().best_validation_loss == pytest.approx(result.history[0].validation_loss)


@pytest.mark.parametrize("cosine_decay", [False, True])
def test_cosine_decay_lowers_the_rate_every_step_to_zero_at_the_last_epoch(
    cosine_decay: bool,
) -> None:
    preset = replace(QUICK, cosine_decay=cosine_decay, max_epochs=3)
    dataset = SegmentationDataset([synthetic_subject("s", 16, size=64, seed=1)], 64)
    loader = DataLoader(dataset, batch_size=5)  # 4 batches, the last one short
    model = build_model(preset.model)
    optimiser = torch.optim.Adam(model.parameters(), lr=preset.learning_rate)
    schedule = learning_rate_schedule(optimiser, preset, len(loader))
    rates = []
    for _ in range(preset.max_epochs):
        train_one_epoch(
            model, loader, SegmentationLoss(), optimiser, torch.device("cpu"), schedule=schedule
        )
        rates.append(optimiser.param_groups[0]["lr"])
    epochs = np.arange(1, preset.max_epochs + 1)
    # after epoch e of E: rate * (1 + cos(pi e / E)) / 2; constant without the decay
    expected = (1 + np.cos(np.pi * epochs / preset.max_epochs)) / 2 if cosine_decay else 1.0
    np.testing.assert_allclose(rates, preset.learning_rate * expected, atol=1e-12)
