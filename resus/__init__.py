"""RESUS testbed: robotic ultrasound acquisition, reconstruction, reslicing and segmentation.

One package per pipeline stage, each exporting its API: `resus.sweep` (the Sweep record and
its files), `resus.acquisition` (robots, probes, the scanner), `resus.planning`,
`resus.reconstruction`, `resus.reslicing`, `resus.segmentation`, `resus.vessels`,
`resus.experiments`, `resus.visualize` (rerun) and `resus.cli`. The simulator is `sim`.
"""

from importlib.metadata import version

__version__ = version("resus-testbed")


def lazy_exports(package: str, api: str):
    """A stage package's `__getattr__`, `__dir__` and `__all__` from its `api` table, one
    line per module (`module: Name other_name ...`), each module imported on first use
    (PEP 562), so that importing one small module of a stage does not import all of it."""
    import importlib

    owners = {
        name: f"{package}.{module.strip()}"
        for module, names in (line.split(":") for line in api.strip().splitlines())
        for name in names.split()
    }

    def __getattr__(name: str) -> object:  # noqa: N807 - the module hook's name
        if name not in owners:
            raise AttributeError(f"module {package!r} has no attribute {name!r}")
        return getattr(importlib.import_module(owners[name]), name)

    def __dir__() -> list[str]:  # noqa: N807
        return sorted(owners)

    return __getattr__, __dir__, sorted(owners)
