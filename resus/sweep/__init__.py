"""The Sweep: one tracked ultrasound scan and its files.

- `model`: the `Sweep` record, `SweepFrame`, the `FrameSink` protocol, the rules it checks.
- `io`: the `resus.sweep/1` HDF5 file, written frame by frame (`SweepWriter`) and read
  lazily (`SweepReader`).
- `plus`: PLUS `.igs.mha` sequences and config XML in and out.
- `preview`: a PNG contact sheet of evenly chosen frames.
"""

from resus import lazy_exports

__getattr__, __dir__, __all__ = lazy_exports(
    __name__,
    """
io: SweepReader SweepWriter read_sweep write_sweep
model: FrameSink Sweep SweepError SweepFrame pixel_spacing pixels_to_world
plus: export_plus_sequence import_plus_sequence read_plus_calibration write_plus_calibration
preview: save_contact_sheet
""",
)
