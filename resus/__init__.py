"""RESUS testbed: robotic ultrasound acquisition, reconstruction, reslicing and segmentation.

One package per pipeline stage, each exporting its API: `resus.sweep` (the Sweep record and
its files), `resus.acquisition` (robots, probes, the scanner), `resus.planning`,
`resus.reconstruction`, `resus.reslicing`, `resus.segmentation`, `resus.vessels`,
`resus.experiments`, `resus.visualize` (rerun) and `resus.cli`. The simulator is `sim`.
"""

from importlib.metadata import version

__version__ = version("resus-testbed")


def lazy_exports(package: str, exports: dict[str, str]):
    """`__getattr__` and `__dir__` for a stage package whose `__init__` names its API
    (`exports`: name -> defining module) but imports each module on first use (PEP 562), so
    `import resus.sweep.model` does not pull in matplotlib or SimpleITK behind it."""
    import importlib

    def __getattr__(name: str) -> object:  # noqa: N807 - the module hook's name
        if name not in exports:
            raise AttributeError(f"module {package!r} has no attribute {name!r}")
        return getattr(importlib.import_module(exports[name]), name)

    def __dir__() -> list[str]:  # noqa: N807
        return sorted(exports)

    return __getattr__, __dir__
