"""Acquisition: one interface for simulated, emulated and real robots and probes.

A `Robot` moves the probe and reports its pose and wrench; a `Probe` delivers timestamped
images; a `Scanner` runs a `Trajectory` on both and streams a Sweep to disk, pairing every
frame with the robot pose at the frame's time. Safety limits are checked by the scanner
before every command, whatever the backend.

- `robot`, `probe`: the abstract `Robot` and `Probe`; `backends/` holds the implementations,
  built from their config dataclasses by `factory.make_robot` / `make_probe`.
- `scanner`: the control loop that records a Sweep; `safety`: its limits.
- `trajectory`: a planned path (`resus.trajectory/1` YAML); `patterns`: paths made from a few
  parameters (linear, fan, multipass, raster).
- `simulation`: scene, simulated robot and probe, trajectory -> a Sweep file.
- `calibration/`: probe and temporal calibration.
"""

from resus import lazy_exports

_EXPORTS = {
    "Robot": "resus.acquisition.robot",
    "RobotFault": "resus.acquisition.robot",
    "Frame": "resus.acquisition.probe",
    "Probe": "resus.acquisition.probe",
    "SafetyLimits": "resus.acquisition.safety",
    "Scanner": "resus.acquisition.scanner",
    "ScannerSettings": "resus.acquisition.scanner",
    "ScanResult": "resus.acquisition.scanner",
    "Trajectory": "resus.acquisition.trajectory",
    "SweepPattern": "resus.acquisition.patterns",
    "LinearPattern": "resus.acquisition.patterns",
    "FanPattern": "resus.acquisition.patterns",
    "MultipassPattern": "resus.acquisition.patterns",
    "RasterPattern": "resus.acquisition.patterns",
    "PATTERNS": "resus.acquisition.patterns",
    "make_robot": "resus.acquisition.factory",
    "make_probe": "resus.acquisition.factory",
    "resolve_scene": "resus.acquisition.simulation",
    "simulate_sweep": "resus.acquisition.simulation",
}
__all__ = sorted(_EXPORTS)
__getattr__, __dir__ = lazy_exports(__name__, _EXPORTS)
