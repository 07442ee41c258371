"""The project's assets (MJCF models, phantom specs, scenes, scanner presets), installed as
the package `sim.assets`.

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


def named_or_path(kind: str, name_or_path: str | Path) -> tuple[Path, bool]:
    """The file that `name_or_path` means, and whether it was named: a `Path`, or text with a
    suffix or a folder in it, is that path; any other text names `KIND/NAME.yaml` here (e.g.
    kind "phantoms", name "femoral")."""
    path = Path(name_or_path)
    if isinstance(name_or_path, Path) or path.suffix or len(path.parts) > 1:
        return path, False
    return assets_dir() / kind / f"{name_or_path}.yaml", True
