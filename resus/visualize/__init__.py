"""Rerun visualisation of every pipeline stage under one recording.

`open_recording` opens a recording from the command line's choices (save an `.rrd`, serve a
web viewer on localhost, spawn the native viewer); `SweepLogger` logs a scan frame by frame
(live or replayed); `log_phantom`, `log_volume`, `log_reslices`, `log_training_curves` and
`log_vessel_map` add the other stages; `make_blueprint` arranges the views. Entity paths live
in `entities`.
"""

from resus.visualize.blueprint import make_blueprint
from resus.visualize.recording import RerunSession, open_recording
from resus.visualize.scene import log_phantom
from resus.visualize.sweep_logger import SweepLogger, log_sweep
from resus.visualize.training import log_training_curves
from resus.visualize.vessels import log_vessel_map
from resus.visualize.volume import log_reslices, log_volume

__all__ = [
    "RerunSession",
    "SweepLogger",
    "log_phantom",
    "log_reslices",
    "log_sweep",
    "log_training_curves",
    "log_vessel_map",
    "log_volume",
    "make_blueprint",
    "open_recording",
]
