"""RESUS testbed: robotic ultrasound acquisition, reconstruction, reslicing and segmentation."""

__version__ = "0.1.0"
