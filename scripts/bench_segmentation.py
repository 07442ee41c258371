"""Segmentation speed: training and inference images/s of the quick and paper presets.

Trains on synthetic 64- or 256-pixel images with the real training step (batch 8, Adam,
Dice + cross-entropy) on the default device, and reports the best of `--repeats` timed
epochs (the machine is shared, so the best run is the least disturbed one).
The last line printed is one JSON object with the figures.
"""

from __future__ import annotations

import argparse
import json
import time

import torch
from torch.utils.data import DataLoader

from resus.segmentation.data import SegmentationDataset
from resus.segmentation.inference import predict
from resus.segmentation.losses import SegmentationLoss
from resus.segmentation.model import build_model, resolve_device
from resus.segmentation.presets import PRESETS
from resus.segmentation.synthetic import synthetic_subject
from resus.segmentation.train import seed_everything, train_one_epoch


def measure(preset_name: str, batches: int, repeats: int, device: torch.device) -> dict:
    preset = PRESETS[preset_name]
    size = preset.model.image_size
    seed_everything(0)
    images = synthetic_subject("bench", batches * preset.batch_size, size=size, seed=0)
    loader = DataLoader(SegmentationDataset([images], size), batch_size=preset.batch_size)
    model = build_model(preset.model).to(device)
    optimiser = torch.optim.Adam(model.parameters(), lr=preset.learning_rate)
    loss_function = SegmentationLoss(preset.cross_entropy).to(device)
    train_one_epoch(model, loader, loss_function, optimiser, device)  # warm-up
    train_seconds = min(
        train_one_epoch(model, loader, loss_function, optimiser, device)[1] for _ in range(repeats)
    )
    infer_seconds = []
    for _ in range(repeats):
        start = time.perf_counter()
        predict(model, images.images, image_size=size, batch_size=preset.evaluation_batch_size)
        infer_seconds.append(time.perf_counter() - start)
    return {
        "train_images_per_second": round(len(images) / train_seconds, 1),
        "predict_images_per_second": round(len(images) / min(infer_seconds), 1),
        "image_size": size,
        "encoder": preset.model.encoder_name,
    }


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--repeats", type=int, default=3, help="timed epochs per figure")
    parser.add_argument("--device", default="auto", help="auto, cpu or cuda")
    args = parser.parse_args()
    device = resolve_device(args.device)
    figures = {"device": str(device), "threads": torch.get_num_threads()}
    for name, batches in (("quick", 16), ("paper", 2 if device.type == "cpu" else 32)):
        figures[name] = measure(name, batches, args.repeats, device)
        print(name, figures[name], flush=True)
    print(json.dumps(figures))


if __name__ == "__main__":
    main()
