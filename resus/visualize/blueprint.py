"""The default arrangement of views: the 3D scene large on the left; on the right the current
frame in 2D above tabs of time series (force, torque, joints) and, when logged, reslices and
training curves."""

from __future__ import annotations

import numpy as np
import rerun.blueprint as rrb

from resus.visualize import entities as at

EYE_OFFSET = np.array([0.16, -0.32, 0.20])
"""Where the 3D camera starts, from the point it looks at (m, base frame): in front of and
above the scan, close enough that the phantom, vessels, frame and probe fill the view."""


def make_blueprint(
    *,
    sweep: bool = True,
    reslices: bool = False,
    training: bool = False,
    look_at: np.ndarray | None = None,
) -> rrb.Blueprint:
    """A blueprint for a recording holding a sweep, and optionally reslices and curves;
    `look_at` (base frame, m), e.g. the middle of the sweep, aims the 3D camera."""
    right: list[rrb.View | rrb.Container] = []
    tabs: list[rrb.View] = []
    if sweep:
        right.append(rrb.Spatial2DView(origin=at.FRAME_2D, name="ultrasound frame"))
        tabs += [
            rrb.TimeSeriesView(origin=at.FORCE, name="force (N)"),
            rrb.TimeSeriesView(origin=at.TORQUE, name="torque (N m)"),
            rrb.TimeSeriesView(origin=at.JOINTS, name="joints (rad)"),
        ]
    if reslices:
        tabs.append(rrb.Spatial2DView(origin=at.RESLICE_2D, name="reslice"))
    if training:
        tabs.append(rrb.TimeSeriesView(origin=at.TRAINING, name="training"))
    if tabs:
        right.append(rrb.Tabs(*tabs))
    eye = None
    if look_at is not None:
        target = np.asarray(look_at, dtype=np.float64)
        eye = rrb.EyeControls3D(position=target + EYE_OFFSET, look_target=target, eye_up=(0, 0, 1))
    scene = rrb.Spatial3DView(origin=at.WORLD, name="scene (robot base frame)", eye_controls=eye)
    layout = rrb.Horizontal(scene, rrb.Vertical(*right), column_shares=[3, 2]) if right else scene
    return rrb.Blueprint(
        layout,
        rrb.BlueprintPanel(state="collapsed"),
        rrb.SelectionPanel(state="collapsed"),
        rrb.TimePanel(state="collapsed"),
    )
