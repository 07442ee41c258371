"""The wheel carries everything an installed `resus` needs: every module of `resus` and `sim`
(subpackages included), and the assets as package data."""

import shutil
import subprocess
import sys
import zipfile
from pathlib import Path

import sim.assets

REPOSITORY = Path(__file__).resolve().parents[1]
NOT_SOURCES = (".git", ".venv", "build", "*.egg-info", "__pycache__", ".*_cache", "docs")


def test_wheel_ships_every_asset_as_package_data(tmp_path: Path) -> None:
    """Built from a copy of the sources: setuptools builds in the source tree's `build/`, and a
    build left there by an earlier version would ship the modules that version had."""
    source = tmp_path / "source"
    shutil.copytree(REPOSITORY, source, ignore=shutil.ignore_patterns(*NOT_SOURCES))
    subprocess.run(
        [sys.executable, "-m", "pip", "wheel", "--no-deps", "--no-build-isolation", "-q",
         "-w", str(tmp_path), str(source)],
        check=True, capture_output=True, timeout=300,
    )  # fmt: skip
    (wheel,) = tmp_path.glob("resus_testbed-*.whl")
    shipped = set(zipfile.ZipFile(wheel).namelist())
    assets = REPOSITORY / "assets"
    expected = {
        f"sim/assets/{path.relative_to(assets).as_posix()}"
        for path in assets.rglob("*")
        if path.is_file() and path.suffix in {".xml", ".yaml", ".md", ".py"}
    }
    assert expected and expected <= shipped, sorted(expected - shipped)
    sources = {
        path.relative_to(REPOSITORY).as_posix()
        for package in ("resus", "sim")
        for path in (REPOSITORY / package).rglob("*.py")
    }
    assert "resus/__main__.py" in sources and sources <= shipped, sorted(sources - shipped)


def test_assets_are_found_through_the_package() -> None:
    folder = sim.assets.assets_dir()
    assert (folder / "ur3e" / "scene.xml").is_file() and (folder / "phantoms").is_dir()
