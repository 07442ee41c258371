"""Running the `resus` console script in a fresh interpreter, as a user would, for CLI tests."""

from __future__ import annotations

import subprocess
import sys


def resus(*args: object, timeout: float = 300) -> subprocess.CompletedProcess:
    """Run `resus ARGS...` and return its exit code, stdout and stderr."""
    command = [sys.executable, "-c", "from resus.cli.app import main; main()", *map(str, args)]
    return subprocess.run(command, capture_output=True, text=True, timeout=timeout)
