"""acquisition/calibration."""
