"""Reading the simulator's YAML files (phantom specs, scenes, scanner presets) with one-line
errors."""

from __future__ import annotations

from pathlib import Path
from typing import Any

import yaml


def read_yaml_file(path: Path, kind: str) -> dict[str, Any]:
    """The mapping `path` holds (an empty file: an empty one); a missing, unreadable or
    unparsable file, or one that holds something else (a list, a text), is one ValueError
    that names the file and what it should have been (`kind`, e.g. "scene")."""
    try:
        data = yaml.safe_load(path.read_text())
    except FileNotFoundError:
        raise ValueError(f"{path}: {kind} file not found") from None
    except (OSError, UnicodeDecodeError) as error:
        raise ValueError(f"{path}: not a readable {kind} file ({type(error).__name__})") from None
    except yaml.YAMLError as error:
        first_line = str(error).splitlines()[0] if str(error) else "parse error"
        raise ValueError(f"{path}: not valid YAML ({first_line})") from None
    if data is None:
        return {}
    if not isinstance(data, dict):
        raise ValueError(
            f"{path}: a {kind} file holds a mapping of keys, got a {type(data).__name__}"
        )
    return data
