"""Where the repository's assets (MJCF models, phantom specs, meshes) live."""

from __future__ import annotations

from pathlib import Path


def assets_dir() -> Path:
    """The `assets/` folder at the repository root."""
    return Path(__file__).resolve().parents[1] / "assets"
