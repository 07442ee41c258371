"""Calibrations a real probe needs: where its image sits in the TCP frame (`probe`, the
`resus.probe/1` file) and how late its frames arrive (`temporal`, PLUS's method).
"""

from resus import lazy_exports

_EXPORTS = {
    "ProbeCalibration": "resus.acquisition.calibration.probe",
    "TemporalCalibration": "resus.acquisition.calibration.temporal",
    "calibrate_time": "resus.acquisition.calibration.temporal",
}
__all__ = sorted(_EXPORTS)
__getattr__, __dir__ = lazy_exports(__name__, _EXPORTS)
