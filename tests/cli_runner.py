"""Running `resus` for CLI tests: in a fresh interpreter, as a user would (`resus`), or through
`main` in the test's own process (`run_main`: a fresh interpreter costs seconds), and checking
that an error is one line.

`python -m resus` runs the console script's entry point (`resus.cli.app:main`) without
depending on where the script was installed.
"""

from __future__ import annotations

import os
import socket
import subprocess
import sys

import pytest

from resus.cli.app import main


def resus(
    *args: object, timeout: float = 300, env: dict[str, str] | None = None
) -> subprocess.CompletedProcess:
    """Run `resus ARGS...` (with `env` added to the environment) and return its exit code,
    stdout and stderr."""
    command = [sys.executable, "-m", "resus", *map(str, args)]
    environment = None if env is None else {**os.environ, **env}
    return subprocess.run(command, capture_output=True, text=True, timeout=timeout, env=environment)


def run_main(monkeypatch, capsys, *args: object) -> tuple[int, str, str]:
    """`resus ARGS...` through `main` in this process: exit status, stdout, stderr."""
    monkeypatch.setattr(sys, "argv", ["resus", *map(str, args)])
    with pytest.raises(SystemExit) as exited:
        main()
    out, err = capsys.readouterr()
    return exited.value.code, out, err


def one_line_error(outcome: tuple[int, str, str], *fragments: str) -> str:
    """Assert exit status 2 and exactly one `error:` line holding `fragments`; return it."""
    status, _, err = outcome
    assert status == 2, err
    lines = err.strip().splitlines()
    assert len(lines) == 1 and lines[0].startswith("error: "), err
    for fragment in fragments:
        assert fragment in lines[0], (fragment, lines[0])
    return lines[0]


def free_port() -> int:
    """A TCP port on 127.0.0.1 that nothing listens on now."""
    with socket.create_server(("127.0.0.1", 0)) as probe:
        return probe.getsockname()[1]
