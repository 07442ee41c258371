"""Synthetic B-mode ultrasound of a vessel phantom, seen by a linear probe."""
