"""Running `resus` in a fresh interpreter, as a user would, for CLI tests.

`python -m resus` runs the console script's entry point (`resus.cli.app:main`) without
depending on where the script was installed.
"""

from __future__ import annotations

import subprocess
import sys


def resus(*args: object, timeout: float = 300) -> subprocess.CompletedProcess:
    """Run `resus ARGS...` and return its exit code, stdout and stderr."""
    command = [sys.executable, "-m", "resus", *map(str, args)]
    return subprocess.run(command, capture_output=True, text=True, timeout=timeout)
