"""Package layout that pyproject.toml cannot state alone: the root `assets/` folder ships inside
the wheel as the package `sim.assets` (MJCF models, phantom specs, scenes as package data)."""

from setuptools import find_packages, setup

setup(
    packages=[*find_packages(include=["resus", "resus.*", "sim", "sim.*"]), "sim.assets"],
    package_dir={"sim.assets": "assets"},
    package_data={"sim.assets": ["*.md", "**/*.md", "**/*.xml", "**/*.yaml"]},
)
