"""Augmentation settings for tests of one transform at a time."""

from dataclasses import replace

from resus.segmentation.presets import AugmentationConfig

QUIET = replace(
    AugmentationConfig(),
    horizontal_flip_p=0.0,
    vertical_flip_p=0.0,
    noise_p=0.0,
    sharpen_p=0.0,
    brightness_contrast_p=0.0,
)
"""The `aug` regime with its flips and intensity transforms off: a transform under test acts
alone (zoom, framing and the elastic warp are off by default too)."""
