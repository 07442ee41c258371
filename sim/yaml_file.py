"""Reading the simulator's YAML files (phantom specs, scenes, scanner presets) with one-line
errors."""

from __future__ import annotations

from pathlib import Path
from typing import Any

import yaml


def read_yaml_file(path: Path, kind: str) -> Any:
    """The parsed content of `path`; a missing, unreadable or unparsable file is one
    ValueError that names the file and what it should have been (`kind`, e.g. "scene")."""
    try:
        return yaml.safe_load(path.read_text())
    except FileNotFoundError:
        raise ValueError(f"{path}: {kind} file not found") from None
    except (OSError, UnicodeDecodeError) as error:
        raise ValueError(f"{path}: not a readable {kind} file ({type(error).__name__})") from None
    except yaml.YAMLError as error:
        first_line = str(error).splitlines()[0] if str(error) else "parse error"
        raise ValueError(f"{path}: not valid YAML ({first_line})") from None
