"""What a check says: PASS or FAIL, where on the path, and what to change."""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from resus.acquisition.trajectory import Trajectory


@dataclass(frozen=True)
class Place:
    """A point (or, with `until`, a stretch) on a trajectory."""

    time: float
    """Seconds from the start of the sweep."""
    arc_length: float
    """Path length travelled by then (m)."""
    waypoint: int
    """Index of the waypoint at or before it."""
    until: float | None = None
    """End time of a stretch (s), None for a single point."""

    def describe(self) -> str:
        """'t = 3.20 s, s = 32.0 mm, waypoint 6' (or 't = 3.20-5.00 s, ...')."""
        times = (
            f"{self.time:.2f} s" if self.until is None else f"{self.time:.2f}-{self.until:.2f} s"
        )
        return f"t = {times}, s = {self.arc_length * 1e3:.1f} mm, waypoint {self.waypoint}"


def place_at(trajectory: Trajectory, time: float, until: float | None = None) -> Place:
    """The place on `trajectory` at `time` (s)."""
    arc = float(trajectory.arc_length_at(time))
    knots = np.concatenate([[0.0], np.cumsum(trajectory.segment_lengths)])
    waypoint = int(
        np.clip(np.searchsorted(knots, arc + 1e-12, side="right") - 1, 0, len(knots) - 1)
    )
    return Place(float(time), arc, waypoint, None if until is None else float(until))


@dataclass(frozen=True)
class CheckResult:
    """One check's verdict."""

    name: str
    passed: bool
    summary: str
    """What was measured, e.g. 'max 0.31 of the joint speed limit (wrist_3)'."""
    place: Place | None = None
    """Where it fails (or where the worst value is)."""
    advice: str = ""
    """What to change when it fails."""

    @property
    def verdict(self) -> str:
        return "PASS" if self.passed else "FAIL"

    def line(self) -> str:
        """One line for a terminal."""
        where = f" at {self.place.describe()}" if self.place is not None and not self.passed else ""
        advice = f" -> {self.advice}" if self.advice and not self.passed else ""
        return f"{self.verdict}  {self.name}: {self.summary}{where}{advice}"
