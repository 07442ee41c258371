"""The package layout the project promises: stage packages with their API, a small top level,
and `sim` a leaf that never imports `resus`."""

import ast
import importlib
import inspect
import pkgutil
import re
from pathlib import Path

import pytest

REPOSITORY = Path(__file__).resolve().parents[1]
STAGES = (
    "sweep", "acquisition", "acquisition.backends", "acquisition.calibration", "planning",
    "reconstruction", "reslicing", "segmentation", "vessels", "experiments",
    "experiments.realism", "experiments.sim2real", "visualize", "cli",
)  # fmt: skip


@pytest.mark.parametrize("stage", STAGES)
def test_every_stage_package_exports_what_it_names(stage: str) -> None:
    package = importlib.import_module(f"resus.{stage}")
    assert package.__doc__, f"resus.{stage} has no docstring"
    names = getattr(package, "__all__", None) or [
        name
        for name, value in vars(package).items()
        if not name.startswith("_") and not inspect.ismodule(value)
    ]
    assert names, f"resus.{stage} exports nothing"
    for name in names:
        assert getattr(package, name) is not None


@pytest.mark.parametrize("stage", STAGES)
def test_no_stage_exports_a_name_that_one_of_its_modules_has(stage: str) -> None:
    """Importing a package's module sets the package's attribute of that name to the module,
    so an exported function named like a module would turn into the module once that module
    (or any import of it) had run."""
    package = importlib.import_module(f"resus.{stage}")
    modules = {module.name for module in pkgutil.iter_modules(package.__path__)}
    assert not modules & set(getattr(package, "__all__", ())), f"resus.{stage}"


def test_resus_keeps_at_most_six_top_level_modules() -> None:
    modules = sorted(path.name for path in (REPOSITORY / "resus").glob("*.py"))
    assert len(modules) <= 6, modules


def test_sim_never_imports_resus() -> None:
    offenders = []
    for path in (REPOSITORY / "sim").rglob("*.py"):
        for node in ast.walk(ast.parse(path.read_text())):
            names = []
            if isinstance(node, ast.Import):
                names = [alias.name for alias in node.names]
            elif isinstance(node, ast.ImportFrom) and node.module:
                names = [node.module]
            offenders += [f"{path}: {n}" for n in names if n.split(".")[0] == "resus"]
    assert not offenders, offenders


DOCUMENTED_NAME = re.compile(r"`((?:resus|sim)(?:\.[A-Za-z_]\w*)+)(?![\w/.])")
"""A dotted name in backticks (`resus.sweep.summary.summarize_sweep`); not a schema name
(`resus.probe/1`)."""


@pytest.mark.parametrize("document", ["README.md", "docs/architecture.md"])
def test_every_name_the_documents_give_exists(document: str) -> None:
    """The README and the architecture notes send readers to modules and functions by name:
    each must import, so a move or a rename cannot leave them pointing nowhere."""
    missing = [
        name
        for name in sorted(set(DOCUMENTED_NAME.findall((REPOSITORY / document).read_text())))
        if _resolved(name) is None
    ]
    assert not missing, missing


def _resolved(name: str) -> object:
    """What the dotted `name` names: its longest importable module, then attributes (None
    where one is missing)."""
    parts = name.split(".")
    for split in range(len(parts), 0, -1):
        try:
            target: object = importlib.import_module(".".join(parts[:split]))
        except ImportError:
            continue
        for attribute in parts[split:]:
            target = getattr(target, attribute, None)
        return target
    return None
