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

from resus import lazy_exports

__getattr__, __dir__, __all__ = lazy_exports(
    __name__,
    """
augment: build_augmentation
checkpoint: load_checkpoint save_checkpoint
curves: plot_training_curves
data: LabelledImages SegmentationDataset
evaluate: Evaluation Overlap evaluate_folder score_labels
folders: FolderImages read_data_set read_folders
inference: predict
loaders: load_reslice_sets load_sweep_frames
loso: REGIMES LosoResult RegimeRun Split make_split pooled_iou run_loso run_regime
losses: SegmentationLoss
metrics: IOU_METRICS VesselIoU vessel_iou
model: build_model resolve_device
presets: PAPER PRESETS QUICK AugmentationConfig ModelConfig TrainingPreset get_preset
stats: PairedTest paired_t_test
synthetic: synthetic_subject
train: EpochRecord TrainingResult TrainingSummary train_model
trained_model: ModelEnsemble Segmenter TrainedModel load_ensemble load_model
""",
)
