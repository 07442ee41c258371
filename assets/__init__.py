"""The project's assets (MJCF models, phantom specs, scenes), installed as the package `sim.assets`.

The folder stays at the repository root, where MuJoCo Menagerie keeps its models, and ships
inside the wheel as package data (see setup.py), so an installed `sim` finds it from any
working directory.
"""

from __future__ import annotations

from importlib.resources import files
from pathlib import Path


def assets_dir() -> Path:
    """The assets folder as a path: MuJoCo reads models, and their includes, by path."""
    return Path(str(files(__name__)))
