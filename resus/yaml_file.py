"""Reading the project's YAML files (trajectories, probe calibrations) with one-line errors."""

from __future__ import annotations

from pathlib import Path

import yaml

from resus.errors import ResusError


def read_yaml(path: str | Path, kind: str, schema: str) -> dict:
    """The parsed document of `path`, a mapping whose `schema` key is `schema`; a missing,
    unparsable or foreign file is a ResusError that names the file and what it should have
    been (`kind`, e.g. "trajectory")."""
    path = Path(path)
    try:
        document = yaml.safe_load(path.read_text())
    except FileNotFoundError:
        raise ResusError(f"{kind} file not found", path) from None
    except (OSError, UnicodeDecodeError, yaml.YAMLError) as error:
        reason = f"not a readable YAML {kind} file ({type(error).__name__})"
        raise ResusError(reason, path) from None
    if not isinstance(document, dict) or document.get("schema") != schema:
        raise ResusError(f"not a {kind} file (expected schema {schema})", path)
    return document
