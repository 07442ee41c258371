"""Calibrations a real probe needs: where its image sits in the TCP frame (`probe`, the
`resus.probe/1` file) and how late its frames arrive (`temporal`, PLUS's method).
"""

from resus import lazy_exports

__getattr__, __dir__, __all__ = lazy_exports(
    __name__,
    """
probe: ProbeCalibration
temporal: TemporalCalibration calibrate_time
""",
)
