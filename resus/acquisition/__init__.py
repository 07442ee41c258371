"""Acquisition: one interface for simulated, emulated and real robots and probes.

A `Robot` moves the probe and reports its pose and wrench; a `Probe` delivers timestamped
images; a `Scanner` runs a `Trajectory` on both and streams a Sweep to disk, pairing every
frame with the robot pose at the frame's time. Safety limits are checked by the scanner
before every command, whatever the backend.

- `robot`, `probe`: the abstract `Robot` and `Probe`; `backends/` holds the implementations,
  built from their config dataclasses by `factory.make_robot` / `make_probe`.
- `scanner`: the control loop that records a Sweep; `safety`: its limits.
- `trajectory`: a planned path (`resus.trajectory/1` YAML), with stops and a force profile
  where it presses; `patterns`: paths made from a few parameters (linear, fan, multipass,
  raster, compression).
- `simulation`: scene, simulated robot and probe, trajectory -> a Sweep file; one sweep per
  phantom subject, each a resumable unit.
- `calibration/`: probe and temporal calibration.
"""

from resus import lazy_exports

__getattr__, __dir__, __all__ = lazy_exports(
    __name__,
    """
factory: make_probe make_robot
patterns: PATTERNS CompressionPattern FanPattern LinearPattern MultipassPattern
patterns: RasterPattern SweepPattern
probe: Frame Probe
robot: Robot RobotFault host_clock_offset
safety: SafetyLimits
scanner: Scanner ScannerSettings ScanResult
simulation: SimulatedSweepJob resolve_scene simulate_subject_sweeps simulate_sweep simulate_sweeps
trajectory: Trajectory
""",
)
