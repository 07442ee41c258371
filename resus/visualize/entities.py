"""Where each pipeline stage lives in a recording: entity paths, timelines, label colours.

world                      3D scene, robot base frame, z up (metres)
  robot/<body>             UR3e bodies: Transform3D per frame, static shapes below
  probe                    tracked probe pose (axes), per frame
  probe_path               the probe's path over the sweep
  ultrasound/frame         the current frame as a textured quad, true size and place
  phantom                  phantom_to_base (static); body outline, artery, vein meshes below
  volume                   reconstructed volume: slices/{i,j,k} quads, outline, dense
  reslices/plane           one reslice plane as a textured quad (timeline "reslice")
  vessel_map/<labels>      mapped artery and vein surfaces and needle path, per label source
frame/{image,labels,prediction}     the current frame in 2D
reslice/{image,labels}              the current reslice in 2D
signals/{force,torque,joints}       time series (N, N m, rad)
training/...                        per-epoch curves (timeline "epoch")
"""

from __future__ import annotations

import rerun as rr

from sim.labels import label_palette

WORLD = "world"
ROBOT = "world/robot"
PROBE = "world/probe"
PROBE_PATH = "world/probe_path"
FRAME_QUAD = "world/ultrasound/frame"
PHANTOM = "world/phantom"
VOLUME = "world/volume"
RESLICE_QUAD = "world/reslices/plane"
VESSEL_MAP = "world/vessel_map"
FRAME_2D = "frame"
RESLICE_2D = "reslice"
SIGNALS = "signals"
FORCE = "signals/force"
TORQUE = "signals/torque"
JOINTS = "signals/joints"
TRAINING = "training"

TIME = "time"
"""Sweep timeline: seconds on the robot clock (a duration)."""
FRAME = "frame"
"""Sweep timeline: frame number."""
RESLICE = "reslice"
"""Reslice timeline: index in the reslice dataset."""
EPOCH = "epoch"
"""Training timeline: epoch number."""
LABEL_OPACITY = 0.5
"""Opacity of 2D label images over their frame."""


def annotation_context(label_names: tuple[str, ...] | list[str]) -> rr.AnnotationContext:
    """Class names and colours for `SegmentationImage`s; background is transparent."""
    colours = label_palette(len(label_names))
    return rr.AnnotationContext(
        [
            rr.AnnotationInfo(
                id=value, label=name, color=(*colours[value], 0 if value == 0 else 255)
            )
            for value, name in enumerate(label_names)
        ]
    )
