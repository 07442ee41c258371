"""The simulator's fingerprint: a hash of its source and assets, recorded with every sweep it makes.

Caches of simulated data (the sim-to-real experiment's sweeps, the experiments' scans,
`resus simulate --subjects`) decide whether a sweep on disk can be reused by what it was made
from: phantom, subject, seed, the scanner preset's name, the sweep pattern. None of those
changes when a preset's knobs or the renderer do, so a cache keyed on them alone would hand
back sweeps an older simulator made. Keyed on this fingerprint as well, a cached sweep is
reused only if the same simulator would make it again. A Python module counts by its syntax
tree without its docstrings, so an edited comment, docstring or line break keeps the
fingerprint (and every cache keyed on it, the models trained on cached sweeps included); any
other change errs the safe way and re-simulates, which costs time, never a wrong figure.
`files_digest` does the same for files outside the simulator that a cache depends on (a
phantom spec of one's own, weights).
"""

from __future__ import annotations

import ast
import hashlib
from collections.abc import Iterable
from functools import cache
from pathlib import Path

from sim.assets import assets_dir

SOURCE_SUFFIXES = (".py", ".xml", ".yaml", ".stl", ".obj")
"""What is hashed: the simulator's Python source and every model, mesh and spec it reads."""


@cache
def simulator_fingerprint() -> str:
    """The fingerprint (`tree_fingerprint`) of the `sim` package and the assets."""
    return tree_fingerprint((Path(__file__).parent, assets_dir()))


def tree_fingerprint(roots: tuple[Path, ...]) -> str:
    """The first 16 hex digits of a SHA-256 over the source files under `roots`, each by its
    path relative to its root and its content (`hashed_content`), in sorted order: the same
    files give the same fingerprint wherever they are installed (on one Python version: the
    syntax tree's form is Python's)."""
    digest = hashlib.sha256()
    for root in roots:
        files = sorted(
            path
            for path in root.rglob("*")
            if path.suffix in SOURCE_SUFFIXES and "__pycache__" not in path.parts
        )
        for path in files:
            digest.update(path.relative_to(root).as_posix().encode())
            digest.update(hashed_content(path))
    return digest.hexdigest()[:16]


def hashed_content(path: Path) -> bytes:
    """What of a source file the fingerprint hashes: a Python module's syntax tree with every
    statement that is a bare string (a docstring: it does nothing) left out, so comments,
    docstrings and layout do not count; any other file's bytes."""
    if path.suffix != ".py":
        return path.read_bytes()
    tree = ast.parse(path.read_bytes(), filename=str(path))
    for node in ast.walk(tree):
        body = getattr(node, "body", None)
        if isinstance(body, list):
            code = [statement for statement in body if not _is_bare_string(statement)]
            node.body = code or [ast.Pass()]  # type: ignore[attr-defined]
    return ast.dump(tree).encode()


def _is_bare_string(statement: ast.stmt) -> bool:
    return (
        isinstance(statement, ast.Expr)
        and isinstance(statement.value, ast.Constant)
        and isinstance(statement.value.value, str)
    )


def files_digest(paths: Iterable[Path]) -> str:
    """The first 16 hex digits of a SHA-256 over the files' bytes, in the order given: what a
    cache key holds for files that may change under the same names."""
    digest = hashlib.sha256()
    for path in paths:
        with Path(path).open("rb") as stream:
            while chunk := stream.read(1 << 20):
                digest.update(chunk)
    return digest.hexdigest()[:16]
