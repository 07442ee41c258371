"""What a Sweep file holds, in numbers, read without its frame images (`resus sweep info`)."""

from __future__ import annotations

from dataclasses import dataclass
from pathlib import Path

import numpy as np

from resus.sweep.io import SweepReader
from resus.sweep.model import pixel_spacing, pixels_to_world


@dataclass(frozen=True)
class SweepSummary:
    """A sweep file's size, geometry, motion and contents (lengths in metres, times in s)."""

    path: Path
    frames: int
    rows: int
    cols: int
    pixel_spacing: tuple[float, float]
    """Column and row spacing of the image."""
    duration: float | None
    """From the first frame's timestamp to the last's (None without frames)."""
    path_length: float | None
    """How far the probe's origin travelled, frame to frame (None without frames)."""
    frame_spacing: tuple[float, float, float] | None
    """Mean, least and largest distance between consecutive frames' image centres (None
    under two frames)."""
    source: str
    subject: str
    created: str
    label_names: tuple[str, ...] | None
    """The label vocabulary (None: no labels)."""
    has_wrench: bool
    has_joint_positions: bool

    def lines(self) -> list[tuple[str, str]]:
        """(field, value) lines as `resus sweep info` prints them, lengths in millimetres."""
        column, row = (1e3 * spacing for spacing in self.pixel_spacing)
        optional = [
            f"labels ({', '.join(self.label_names)})" if self.label_names is not None else "",
            "wrench" if self.has_wrench else "",
            "joint positions" if self.has_joint_positions else "",
        ]
        lines = [
            ("file", str(self.path)),
            ("frames", str(self.frames)),
            ("image size", f"{self.cols} x {self.rows} px (width x height)"),
            ("pixel spacing", f"{column:.4f} x {row:.4f} mm (column x row)"),
        ]
        if self.duration is not None and self.path_length is not None:
            spacing = "n/a (one frame)"
            if self.frame_spacing is not None:
                mean, least, largest = (1e3 * step for step in self.frame_spacing)
                spacing = (
                    f"mean {mean:.3f}, min {least:.3f}, max {largest:.3f} mm "
                    "(between frame centres)"
                )
            lines += [
                ("duration", f"{self.duration:.3f} s"),
                ("path length", f"{self.path_length * 1e3:.2f} mm (probe)"),
                ("frame spacing", spacing),
            ]
        return [
            *lines,
            ("source", self.source),
            ("subject", self.subject or "(none)"),
            ("created", self.created),
            ("optional data", "; ".join(item for item in optional if item) or "none"),
        ]


def summarize_sweep(path: str | Path) -> SweepSummary:
    """The `SweepSummary` of the sweep file at `path`, reading no frame images."""
    path = Path(path)
    with SweepReader(path) as sweep:
        rows, cols = sweep.frame_shape
        duration = path_length = frame_spacing = None
        if len(sweep):
            origins = sweep.probe_to_base[:, :3, 3]
            centres = pixels_to_world(
                sweep.probe_to_base,
                sweep.image_to_probe,
                np.array((cols - 1) / 2),
                np.array((rows - 1) / 2),
            )
            steps = np.linalg.norm(np.diff(centres, axis=0), axis=-1)
            duration = float(sweep.timestamps[-1] - sweep.timestamps[0])
            path_length = float(np.linalg.norm(np.diff(origins, axis=0), axis=-1).sum())
            if len(steps):
                frame_spacing = (float(steps.mean()), float(steps.min()), float(steps.max()))
        return SweepSummary(
            path=path,
            frames=len(sweep),
            rows=rows,
            cols=cols,
            pixel_spacing=pixel_spacing(sweep.image_to_probe),
            duration=duration,
            path_length=path_length,
            frame_spacing=frame_spacing,
            source=sweep.source,
            subject=sweep.subject,
            created=sweep.created,
            label_names=tuple(sweep.label_names) if sweep.has_labels else None,
            has_wrench=sweep.wrench is not None,
            has_joint_positions=sweep.joint_positions is not None,
        )
