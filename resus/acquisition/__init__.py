"""Acquisition: one interface for simulated, emulated and real robots and probes.

A `Robot` moves the probe and reports its pose and wrench; a `Probe` delivers timestamped
images; a `Scanner` runs a `Trajectory` on both and streams a Sweep to disk, pairing every
frame with the robot pose at the frame's time. Safety limits are checked by the scanner
before every command, whatever the backend.
"""
