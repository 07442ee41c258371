"""Training presets: every knob of a segmentation run, named and documented.

`paper` is the paper's configuration (U-Net with a ResNet34 encoder, Adam 1e-4, batch 8,
256 x 256); it needs a GPU to finish in reasonable time. `quick` is a tiny U-Net at 64 x 64
that trains at about 200 images/s on a 2-core CPU; tests and the demo use it.
"""

from __future__ import annotations

from collections.abc import Mapping
from dataclasses import asdict, dataclass, field, replace
from typing import TypeVar

from resus.errors import ResusError
from sim.labels import LABEL_NAMES

Preset = TypeVar("Preset")


@dataclass(frozen=True)
class ModelConfig:
    """The network's architecture; saved with every checkpoint so it can be rebuilt."""

    encoder_name: str = "resnet34"
    """smp / torchvision ResNet name of the encoder."""
    encoder_depth: int = 5
    """Number of encoder stages (downsamplings) used, 1..5."""
    decoder_channels: tuple[int, ...] = (256, 128, 64, 32, 16)
    """Channels of each decoder block; one per encoder stage."""
    image_size: int = 256
    """Side of the square network input (pixels); images are resized to it and back."""
    classes: int = len(LABEL_NAMES)
    """Output classes: one per label value (0 background, 1 artery, 2 vein)."""

    def __post_init__(self) -> None:
        object.__setattr__(self, "decoder_channels", tuple(int(c) for c in self.decoder_channels))
        if len(self.decoder_channels) != self.encoder_depth:
            raise ResusError(
                f"ModelConfig.decoder_channels needs one channel count per encoder stage: "
                f"encoder_depth {self.encoder_depth}, decoder_channels {self.decoder_channels}"
            )
        if self.image_size % (2**self.encoder_depth):
            raise ResusError(
                f"ModelConfig.image_size {self.image_size} must be divisible by "
                f"2**encoder_depth = {2**self.encoder_depth}"
            )

    def to_dict(self) -> dict:
        """JSON-able form (lists for tuples)."""
        data = asdict(self)
        data["decoder_channels"] = list(self.decoder_channels)
        return data

    @classmethod
    def from_dict(cls, data: dict) -> ModelConfig:
        """Inverse of `to_dict`."""
        return cls(**{**data, "decoder_channels": tuple(data["decoder_channels"])})


@dataclass(frozen=True)
class AugmentationConfig:
    """The `aug` regime's random transforms (albumentations 2), applied to image and mask."""

    horizontal_flip_p: float = 0.5
    """Probability of a left-right flip."""
    vertical_flip_p: float = 0.5
    """Probability of an up-down flip."""
    noise_p: float = 0.5
    """Probability of additive Gaussian noise."""
    noise_std_range: tuple[float, float] = (0.02, 0.08)
    """Noise standard deviation as a fraction of 255 (albumentations' default is far stronger)."""
    sharpen_p: float = 0.5
    """Probability of unsharp-kernel sharpening."""
    sharpen_alpha: tuple[float, float] = (0.2, 0.5)
    """Blend of the sharpened image into the original."""
    brightness_contrast_p: float = 0.5
    """Probability of a brightness/contrast change."""
    brightness_limit: float = 0.2
    """Brightness shift up to this fraction of 255, either way."""
    contrast_limit: float = 0.2
    """Contrast scaled by up to this fraction, either way."""
    elastic_p: float = 0.0
    """Probability of an elastic warp of image and mask together (albumentations'
    `ElasticTransform`), before any zoom or framing: vessels of irregular, non-elliptical
    outline, as real veins squeezed by their neighbours are. Off by default (the paper's
    regime has none)."""
    elastic_alpha: float = 250.0
    """Warp strength in albumentations' units at a 128 px network input (scaled with the
    square of the input size, so the warp is the same share of the image at any size)."""
    elastic_sigma: float = 9.0
    """Smoothness of the warp (Gaussian sigma, pixels at a 128 px input; scaled with the size):
    about a vessel's radius, so outlines bend without tearing. At 128 px, alpha 250 and sigma
    9 leave a 30 px disc at IoU 0.84-0.90 with itself."""
    zoom_p: float = 0.0
    """Probability of a scanner zoom (`resus.segmentation.zoom`): a random window of the frame
    enlarged to the whole frame, before any framing. Off by default (the paper's regime has
    none)."""
    zoom_range: tuple[float, float] = (1.0, 1.8)
    """Linear magnification of a zoom (1: the whole frame)."""
    zoom_aspect: tuple[float, float] = (0.75, 1.33)
    """Height-to-width stretch of the zoom window against the frame's, drawn log-uniformly."""
    framing_p: float = 0.0
    """Probability of export framing (`resus.segmentation.framing`): the frame shrunk into a
    black canvas like a scanner's export. Off by default (the paper's regime has none)."""
    framing_height: tuple[float, float] = (0.6, 1.0)
    """Share of the canvas height the imaged area keeps (real 512-row exports: about 0.65)."""
    framing_width: tuple[float, float] = (0.8, 1.0)
    """Share of the canvas width the imaged area keeps."""
    framing_marks_p: float = 0.5
    """Probability, once framed, of depth dots and text blocks in the margins."""


@dataclass(frozen=True)
class TrainingPreset:
    """Everything a training run needs besides its data, regime, seed and device."""

    name: str
    model: ModelConfig
    learning_rate: float = 1e-4
    """Adam learning rate (the starting one, with `cosine_decay`)."""
    cosine_decay: bool = False
    """Lower the learning rate after every step along a half cosine, from `learning_rate` to
    zero at the last step of `max_epochs` (Loshchilov & Hutter's SGDR, without restarts):
    large steps while the loss is far from a minimum, small ones to settle into it, so a run
    capped at a few epochs ends converged rather than still moving. Early stopping is kept."""
    batch_size: int = 8
    """Training images per optimiser step."""
    max_epochs: int = 100
    """Upper bound on passes over the training set."""
    patience: int = 10
    """Stop after this many epochs without a lower validation loss; the best epoch is kept."""
    weight_averaging_epochs: int = 0
    """Run every epoch and return the mean of the weights after each step of the last this
    many (stochastic weight averaging, `resus.segmentation.averaging`), its batch-norm
    statistics measured over the training images, instead of the best epoch's weights; early
    stopping is then off. Meant for a constant rate (`cosine_decay` off): a rate decayed to
    zero leaves little to average. 0: off."""
    validation_fraction: float = 0.15
    """Share of each training subject's frames held out for validation (the last block of
    each frame set, so neighbouring frames of a sweep rarely straddle the split)."""
    cross_entropy: bool = True
    """Add cross-entropy to the Dice loss. smp's multiclass Dice ignores classes absent from
    a batch, so alone it never penalises vessels predicted on vessel-free frames."""
    evaluation_batch_size: int = 32
    """Images per forward pass when validating and predicting."""
    augmentation: AugmentationConfig = field(default_factory=AugmentationConfig)
    """Transforms used by the `aug` regime (other regimes train on unaltered images)."""

    def __post_init__(self) -> None:
        if not 0 < self.validation_fraction < 1:
            raise ResusError(
                "TrainingPreset.validation_fraction must be in (0, 1), "
                f"got {self.validation_fraction}"
            )
        for name in ("batch_size", "max_epochs", "patience", "evaluation_batch_size"):
            if getattr(self, name) < 1:
                raise ResusError(
                    f"TrainingPreset.{name} must be at least 1, got {getattr(self, name)}"
                )
        if not 0 <= self.weight_averaging_epochs <= self.max_epochs:
            raise ResusError(
                f"TrainingPreset.weight_averaging_epochs must be in [0, max_epochs = "
                f"{self.max_epochs}], got {self.weight_averaging_epochs}"
            )

    def to_dict(self) -> dict:
        """JSON-able form, stored in checkpoints and metrics files."""
        data = asdict(self)
        data["model"] = self.model.to_dict()
        return data

    def weight_averaged(self, epochs: int) -> TrainingPreset:
        """This preset with its model the weight average of the last `epochs` epochs, at a
        constant rate (cosine decay off: a rate decayed to zero leaves little to average);
        0: this preset unchanged."""
        if epochs == 0:
            return self
        return replace(self, cosine_decay=False, weight_averaging_epochs=epochs)


QUICK = TrainingPreset(
    name="quick",
    model=ModelConfig(
        encoder_name="resnet18", encoder_depth=3, decoder_channels=(32, 16, 8), image_size=64
    ),
    learning_rate=1e-3,
    max_epochs=8,
    patience=3,
    validation_fraction=0.2,
)
"""Tiny and fast (CPU, minutes): for tests, demos and smoke runs, not for results."""

CPU128 = TrainingPreset(
    name="cpu128",
    model=ModelConfig(
        encoder_name="resnet18",
        encoder_depth=4,
        decoder_channels=(64, 32, 16, 8),
        image_size=128,
    ),
    learning_rate=1e-3,
    cosine_decay=True,
    max_epochs=20,
    patience=3,
    validation_fraction=0.2,
)
"""128 x 128, the least a real image's vessels need (a 4 mm vein in a 4 cm image is 13 px
across), still on 2 CPU cores: ten epochs on six 60 mm sweeps (about 1,100 frames) took 12
minutes at 15 images/s. Up to 20 epochs: capped at 10 (until 2026-12-04), every
simulation-only model of five seeds was still improving on its simulated validation frames
at its last epoch, and at a constant rate three of five still were at 20. With the rate's
cosine decay all five reach their best in the last three epochs, at under 3 % of the starting
rate: they end converged (README Sim-to-real has what each change did to the real score)."""

PAPER = TrainingPreset(name="paper", model=ModelConfig())
"""The paper's settings: U-Net/ResNet34, Adam 1e-4, batch 8, 256 x 256 (needs a GPU)."""

PRESETS: dict[str, TrainingPreset] = {preset.name: preset for preset in (QUICK, CPU128, PAPER)}


def pick_preset(presets: Mapping[str, Preset], name: str) -> Preset:
    """The preset called `name` in `presets`, or a ResusError listing the choices: one lookup
    for every table of presets (training, experiments, sim-to-real), so all refuse alike."""
    if name not in presets:
        raise ResusError(f"unknown preset {name!r}; choose one of {', '.join(presets)}")
    return presets[name]


def get_preset(name: str) -> TrainingPreset:
    """The training preset called `name`, or a ResusError listing the choices."""
    return pick_preset(PRESETS, name)
