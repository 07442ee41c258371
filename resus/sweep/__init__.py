"""The Sweep: one tracked ultrasound scan and its files.

- `model`: the `Sweep` record, `SweepFrame`, the `FrameSink` protocol, the rules it checks.
- `io`: the `resus.sweep/1` HDF5 file, written frame by frame (`SweepWriter`) and read
  lazily (`SweepReader`).
- `plus`: PLUS `.igs.mha` sequences and config XML in and out.
- `preview`: a PNG contact sheet of evenly chosen frames.
"""

from resus import lazy_exports

_EXPORTS = {
    "Sweep": "resus.sweep.model",
    "SweepError": "resus.sweep.model",
    "SweepFrame": "resus.sweep.model",
    "FrameSink": "resus.sweep.model",
    "pixels_to_world": "resus.sweep.model",
    "pixel_spacing": "resus.sweep.model",
    "SweepWriter": "resus.sweep.io",
    "SweepReader": "resus.sweep.io",
    "read_sweep": "resus.sweep.io",
    "write_sweep": "resus.sweep.io",
    "import_plus_sequence": "resus.sweep.plus",
    "export_plus_sequence": "resus.sweep.plus",
    "read_plus_calibration": "resus.sweep.plus",
    "write_plus_calibration": "resus.sweep.plus",
    "save_contact_sheet": "resus.sweep.preview",
}
__all__ = sorted(_EXPORTS)
__getattr__, __dir__ = lazy_exports(__name__, _EXPORTS)
