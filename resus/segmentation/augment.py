"""The `aug` regime's random transforms, applied to an image and its label map together.

albumentations moves the mask with every geometric transform (the elastic warp, the flips;
nearest-neighbour for the mask, so no new classes) and leaves it out
of the intensity ones (noise, sharpening, brightness/contrast), so labels stay aligned.

Seeding: albumentations 2.0's `Compose(seed=s)` gives every transform its own generator
seeded with the same `s`, so all their "apply?" draws coincide (with equal probabilities,
both flips always happen together or not at all). Instead, the transforms here share one
seeded generator and draw from it in turn: repeatable, and independent of each other.
"""

from __future__ import annotations

import random
from dataclasses import dataclass

import albumentations as albu
import cv2
import numpy as np

from resus.segmentation.framing import ExportFraming
from resus.segmentation.presets import AugmentationConfig
from resus.segmentation.zoom import ScannerZoom

ELASTIC_REFERENCE_SIZE = 128
"""Network input size (px) at which `AugmentationConfig.elastic_alpha` and `elastic_sigma`
hold as given."""


@dataclass
class AugmentationPipeline:
    """Elastic warp, scanner zoom (`resus.segmentation.zoom`), export framing
    (`resus.segmentation.framing`), then the albumentations pipeline:
    `augment(image=uint8, mask=uint8) -> {"image", "mask"}`. The warp comes first so that the
    straight edges of a framed export stay straight."""

    elastic: albu.Compose
    zoom: ScannerZoom
    framing: ExportFraming
    pipeline: albu.Compose

    def __call__(self, *, image: np.ndarray, mask: np.ndarray) -> dict[str, np.ndarray]:
        warped = self.elastic(image=image, mask=mask)
        zoomed = self.zoom(image=warped["image"], mask=warped["mask"])
        framed = self.framing(**zoomed)
        return self.pipeline(image=framed["image"], mask=framed["mask"])


def build_augmentation(
    config: AugmentationConfig, seed: int, image_size: int = ELASTIC_REFERENCE_SIZE
) -> AugmentationPipeline:
    """The seeded transforms of the `aug` regime for images of `image_size` px (the network
    input: the elastic warp scales with it)."""
    scale = image_size / ELASTIC_REFERENCE_SIZE
    elastic = albu.Compose(
        [
            albu.ElasticTransform(
                alpha=config.elastic_alpha * scale**2,
                sigma=config.elastic_sigma * scale,
                border_mode=cv2.BORDER_REFLECT_101,  # no black wedges at the image's edges
                p=config.elastic_p,
            )
        ]
    )
    elastic.set_random_state(np.random.default_rng([seed, 0xE1A]), random.Random(seed + 0xE1A))
    pipeline = albu.Compose(
        [
            albu.HorizontalFlip(p=config.horizontal_flip_p),
            albu.VerticalFlip(p=config.vertical_flip_p),
            albu.GaussNoise(std_range=config.noise_std_range, p=config.noise_p),
            albu.Sharpen(alpha=config.sharpen_alpha, p=config.sharpen_p),
            albu.RandomBrightnessContrast(
                brightness_limit=config.brightness_limit,
                contrast_limit=config.contrast_limit,
                p=config.brightness_contrast_p,
            ),
        ]
    )
    pipeline.set_random_state(np.random.default_rng(seed), random.Random(seed))
    return AugmentationPipeline(
        elastic,
        ScannerZoom(config, np.random.default_rng([seed, 0x200])),
        ExportFraming(config, np.random.default_rng([seed, 0xF4A])),
        pipeline,
    )
