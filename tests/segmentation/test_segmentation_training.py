"""Training: the loss falls, seeded runs repeat exactly, early stopping keeps the best epoch."""

from dataclasses import replace

import numpy as np
import pytest
import torch
from torch.optim.optimizer import register_optimizer_step_post_hook
from torch.utils.data import DataLoader

from resus.errors import ResusError
from resus.segmentation.checkpoint import load_checkpoint
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


def test_weight_averaging_returns_the_mean_of_the_last_epochs_step_weights(tmp_path) -> None:
    train_sets, validation_sets = train_twice_data()  # 40 images: 5 steps of 8 an epoch
    preset = replace(QUICK, max_epochs=3, patience=1, weight_averaging_epochs=2)
    steps: list[dict[str, torch.Tensor]] = []

    def record(optimiser: torch.optim.Optimizer, *_: object) -> None:
        # each step's weights, read from the optimiser's own parameters
        params = [p for group in optimiser.param_groups for p in group["params"]]
        steps.append({str(i): p.detach().clone() for i, p in enumerate(params)})

    hook = register_optimizer_step_post_hook(record)
    try:
        result = train_model(
            train_sets, validation_sets, preset, checkpoint_path=tmp_path / "c.pt", progress=False
        )
    finally:
        hook.remove()
    assert len(steps) == 15 and len(result.history) == 3 and not result.stopped_early
    averaged = steps[5:]  # epochs 2 and 3
    parameters = list(result.model.parameters())
    for i, parameter in enumerate(parameters):
        mean = torch.stack([step[str(i)] for step in averaged]).mean(0)
        torch.testing.assert_close(parameter.detach(), mean, rtol=1e-5, atol=1e-6)
    record_ = result.weight_average
    assert record_ is not None and (record_.first_epoch, record_.last_epoch) == (2, 3)
    assert record_.steps == 10 and "best_epoch" not in result.config
    assert result.summary().to_dict()["weight_average"]["steps"] == 10
    # batch norm measured afresh in one pass over the training images: 5 batches, not the 15
    # of training (0 in the encoder's stages past its depth, which never run)
    norms = [m for m in result.model.modules() if isinstance(m, torch.nn.BatchNorm2d)]
    counts = [int(m.num_batches_tracked) for m in norms]
    assert set(counts) == {0, 5} and counts[0] == 5
    loaded, config = load_checkpoint(tmp_path / "c.pt")
    assert config["weight_average"]["first_epoch"] == 2
    for key, value in result.model.state_dict().items():
        torch.testing.assert_close(loaded.state_dict()[key], value, rtol=0, atol=0)


def test_weight_averaging_beyond_the_run_is_refused() -> None:
    with pytest.raises(ResusError, match=r"TrainingPreset.weight_averaging_epochs .* got 9"):
        replace(QUICK, max_epochs=8, weight_averaging_epochs=9)


def test_a_weight_averaged_preset_runs_at_a_constant_rate() -> None:
    cosine = replace(QUICK, cosine_decay=True)
    assert cosine.weight_averaged(0) is cosine
    averaged = cosine.weight_averaged(3)
    assert averaged == replace(cosine, cosine_decay=False, weight_averaging_epochs=3)
    with pytest.raises(ResusError, match=r"weight_averaging_epochs .* got -1"):
        cosine.weight_averaged(-1)


def test_a_training_outcome_with_a_weight_average_survives_json(tmp_path) -> None:
    import json

    from resus.experiments.training_units import TrainingOutcome

    train_sets, validation_sets = train_twice_data()
    preset = replace(QUICK, max_epochs=2, weight_averaging_epochs=1)
    result = train_model(train_sets, validation_sets, preset, progress=False)
    average = result.weight_average
    assert average is not None
    outcome = TrainingOutcome({}, average.validation_iou, 40, result.summary(), "cpu")
    again = TrainingOutcome.from_dict(json.loads(json.dumps(outcome.to_dict())))
    assert again == outcome and again.summary.weight_average == average
