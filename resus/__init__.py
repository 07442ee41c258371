"""RESUS testbed: robotic ultrasound acquisition, reconstruction, reslicing and segmentation.

One package per pipeline stage, each exporting its API: `resus.sweep` (the Sweep record and
its files), `resus.acquisition` (robots, probes, the scanner), `resus.planning`,
`resus.reconstruction`, `resus.reslicing`, `resus.segmentation`, `resus.vessels`,
`resus.experiments`, `resus.visualize` (rerun) and `resus.cli`. The simulator is `sim`.
"""

from importlib.metadata import version

__version__ = version("resus-testbed")
