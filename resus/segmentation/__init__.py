"""Stage 4: U-Net segmentation of femoral artery and vein, and the RESUS training regimes.

Everything here works on plain `LabelledImages` (images, labels, subject) so that frames from
sweeps, reslices from volumes and synthetic test images all go through the same path.

- `presets`: every knob of a training run (`TrainingPreset`, `ModelConfig`, `QUICK`, `PAPER`).
- `data`: `LabelledImages`, resizing and the torch dataset; `loaders` reads them from sweep
  and reslice files; `synthetic` draws labelled test images without the simulator.
- `model`: the U-Net, local ImageNet encoder weights and the device; `checkpoint` saves and
  loads trained models.
- `augment` (the `aug` regime's transforms), `losses` (Dice + cross-entropy), `train` (one
  seeded, early-stopped fit), `curves` (its PNG).
- `metrics` (pooled vessel IoU), `stats` (paired t-test), `loso` (the four regimes and
  leave-one-subject-out evaluation), `inference` (segmenting new frames).
- Real images: `folders` reads a folder of images and one of masks; `trained_model` wraps a
  checkpoint (`load_model(path).predict(images)`) and makes several one (`load_ensemble`);
  `evaluate` scores a model on a folder (vessel IoU and Dice, overlays, metrics.json).

The names below are imported from their modules on first use, so `resus.segmentation.presets`
(which experiment settings and data-preparation workers import) does not load torch.
"""

from __future__ import annotations

import importlib
from typing import TYPE_CHECKING

if TYPE_CHECKING:
    from resus.segmentation.augment import build_augmentation
    from resus.segmentation.checkpoint import load_checkpoint, save_checkpoint
    from resus.segmentation.curves import plot_training_curves
    from resus.segmentation.data import LabelledImages, SegmentationDataset
    from resus.segmentation.evaluate import Evaluation, Overlap, evaluate_folder, score_labels
    from resus.segmentation.folders import FolderImages, read_data_set, read_folders
    from resus.segmentation.inference import predict
    from resus.segmentation.loaders import load_reslice_sets, load_sweep_frames
    from resus.segmentation.loso import (
        REGIMES,
        LosoResult,
        RegimeRun,
        Split,
        make_split,
        pooled_iou,
        run_loso,
        run_regime,
    )
    from resus.segmentation.losses import SegmentationLoss
    from resus.segmentation.metrics import IOU_METRICS, VesselIoU, vessel_iou
    from resus.segmentation.model import build_model, resolve_device
    from resus.segmentation.presets import (
        PAPER,
        PRESETS,
        QUICK,
        AugmentationConfig,
        ModelConfig,
        TrainingPreset,
        get_preset,
    )
    from resus.segmentation.stats import PairedTest, paired_t_test
    from resus.segmentation.synthetic import synthetic_subject
    from resus.segmentation.train import EpochRecord, TrainingResult, TrainingSummary, train_model
    from resus.segmentation.trained_model import (
        ModelEnsemble,
        Segmenter,
        TrainedModel,
        load_ensemble,
        load_model,
    )

_MODULES: dict[str, tuple[str, ...]] = {
    "augment": ("build_augmentation",),
    "checkpoint": ("load_checkpoint", "save_checkpoint"),
    "curves": ("plot_training_curves",),
    "data": ("LabelledImages", "SegmentationDataset"),
    "evaluate": ("Evaluation", "Overlap", "evaluate_folder", "score_labels"),
    "folders": ("FolderImages", "read_data_set", "read_folders"),
    "inference": ("predict",),
    "loaders": ("load_reslice_sets", "load_sweep_frames"),
    "loso": (
        "REGIMES", "LosoResult", "RegimeRun", "Split", "make_split", "pooled_iou", "run_loso",
        "run_regime",
    ),
    "losses": ("SegmentationLoss",),
    "metrics": ("IOU_METRICS", "VesselIoU", "vessel_iou"),
    "model": ("build_model", "resolve_device"),
    "presets": (
        "PAPER", "PRESETS", "QUICK", "AugmentationConfig", "ModelConfig", "TrainingPreset",
        "get_preset",
    ),
    "stats": ("PairedTest", "paired_t_test"),
    "synthetic": ("synthetic_subject",),
    "train": ("EpochRecord", "TrainingResult", "TrainingSummary", "train_model"),
    "trained_model": ("ModelEnsemble", "Segmenter", "TrainedModel", "load_ensemble", "load_model"),
}  # fmt: skip
_HOMES = {name: module for module, names in _MODULES.items() for name in names}

__all__ = [
    "IOU_METRICS",
    "PAPER",
    "PRESETS",
    "QUICK",
    "REGIMES",
    "AugmentationConfig",
    "EpochRecord",
    "Evaluation",
    "FolderImages",
    "LabelledImages",
    "LosoResult",
    "ModelConfig",
    "ModelEnsemble",
    "Overlap",
    "PairedTest",
    "RegimeRun",
    "SegmentationDataset",
    "SegmentationLoss",
    "Segmenter",
    "Split",
    "TrainedModel",
    "TrainingPreset",
    "TrainingResult",
    "TrainingSummary",
    "VesselIoU",
    "build_augmentation",
    "build_model",
    "evaluate_folder",
    "get_preset",
    "load_checkpoint",
    "load_ensemble",
    "load_model",
    "load_reslice_sets",
    "load_sweep_frames",
    "make_split",
    "paired_t_test",
    "plot_training_curves",
    "pooled_iou",
    "predict",
    "read_data_set",
    "read_folders",
    "resolve_device",
    "run_loso",
    "run_regime",
    "save_checkpoint",
    "score_labels",
    "synthetic_subject",
    "train_model",
    "vessel_iou",
]


def __getattr__(name: str) -> object:
    """An exported name, imported from its module when first asked for (PEP 562)."""
    if name not in _HOMES:
        raise AttributeError(f"module {__name__!r} has no attribute {name!r}")
    value = getattr(importlib.import_module(f"{__name__}.{_HOMES[name]}"), name)
    globals()[name] = value
    return value
