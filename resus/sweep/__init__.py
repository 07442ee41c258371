"""The Sweep: one tracked ultrasound scan and its files.

- `model`: the `Sweep` record, `SweepFrame`, the `FrameSink` protocol, the rules it checks.
- `io`: the `resus.sweep/1` HDF5 file, written frame by frame (`SweepWriter`) and read
  lazily (`SweepReader`).
- `plus`: PLUS `.igs.mha` sequences and config XML in and out.
- `ros`: ROS 1 and ROS 2 bags (sqlite3, MCAP) in and out.
- `igtl`: frames out over OpenIGTLink as PLUS sends them (live, or a file replayed).
- `cvat`: CVAT segmentation masks (or plain label PNGs) in and out as a sweep's labels.
- `preview`: a PNG contact sheet of evenly chosen frames.
- `summary`: what a sweep file holds, in numbers (`resus sweep info`).
- `images`: grey, BGR(A) or RGB(A) images to 8-bit grey, for every path into a Sweep.
- `timestamps`: what "now" is in every file the testbed writes (the clock, or
  SOURCE_DATE_EPOCH's time for byte-identical reruns).
"""

from resus import lazy_exports

__getattr__, __dir__, __all__ = lazy_exports(
    __name__,
    """
cvat: attach_labels export_labels read_label_masks
igtl: IgtlServer stream_sweep
images: to_grey
io: SweepReader SweepWriter read_sweep write_sweep
model: FrameSink Sweep SweepError SweepFrame pixel_spacing pixels_to_world
plus: export_plus_sequence import_plus_sequence read_plus_calibration write_plus_calibration
preview: save_contact_sheet
ros: RosImport export_ros import_ros
summary: SweepSummary summarize_sweep
""",
)
