"""Model checkpoints: the weights plus a JSON-able config that is enough to rebuild the model.

Written with `torch.save` and read with `torch.load(..., weights_only=True)`, so loading a
checkpoint never runs pickled code. The config's `model` entry is a `ModelConfig.to_dict()`.
"""

from __future__ import annotations

from pathlib import Path

import torch
from torch import nn

from resus.errors import ResusError
from resus.segmentation.model import build_model, load_torch_file
from resus.segmentation.presets import ModelConfig

SCHEMA = "resus.segmentation-checkpoint/1"


def save_checkpoint(path: Path, model: nn.Module, config: dict) -> None:
    """Write `model`'s weights (on the CPU) and `config` (must hold `model`) to `path`."""
    if "model" not in config:
        raise ValueError("checkpoint config needs a 'model' entry (ModelConfig.to_dict())")
    state_dict = {key: value.detach().cpu() for key, value in model.state_dict().items()}
    path = Path(path)
    path.parent.mkdir(parents=True, exist_ok=True)
    torch.save({"schema": SCHEMA, "config": config, "state_dict": state_dict}, path)


def load_checkpoint(path: Path, device: torch.device | str = "cpu") -> tuple[nn.Module, dict]:
    """The model (in eval mode, on `device`) and config saved at `path`."""
    saved = load_torch_file(
        path, missing="checkpoint not found", unreadable="not a readable checkpoint"
    )
    if not isinstance(saved, dict) or saved.get("schema") != SCHEMA:
        raise ResusError(f"not a {SCHEMA} checkpoint", path)
    config = saved["config"]
    model = build_model(ModelConfig.from_dict(config["model"]))
    model.load_state_dict(saved["state_dict"])
    return model.to(device).eval(), config
