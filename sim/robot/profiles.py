"""Trapezoidal velocity profiles: the timing law of UR's moveJ and moveL."""

from __future__ import annotations

import math
from dataclasses import dataclass


@dataclass(frozen=True)
class TrapezoidalProfile:
    """Travel `distance` accelerating at `acceleration` up to `speed`, cruising, then braking.

    When the distance is too short to reach `speed` the profile is triangular.
    """

    distance: float
    speed: float
    acceleration: float

    def __post_init__(self) -> None:
        if not self.distance >= 0:
            raise ValueError(f"profile distance must be >= 0, got {self.distance}")
        if not (self.speed > 0 and self.acceleration > 0):
            raise ValueError(
                f"speed and acceleration must be positive, got {self.speed}, {self.acceleration}"
            )

    @property
    def peak_speed(self) -> float:
        """Highest speed reached: `speed`, or less for a triangular profile."""
        return min(self.speed, math.sqrt(self.distance * self.acceleration))

    @property
    def ramp_time(self) -> float:
        """Duration of the acceleration (and of the braking) phase."""
        return self.peak_speed / self.acceleration

    @property
    def duration(self) -> float:
        """Total time from rest to rest."""
        if self.distance == 0:
            return 0.0
        ramp = self.ramp_time
        cruise_distance = self.distance - self.peak_speed * ramp
        return 2 * ramp + cruise_distance / self.peak_speed

    def position(self, t: float) -> float:
        """Distance travelled at time `t` (clamped to [0, duration])."""
        total, ramp, peak = self.duration, self.ramp_time, self.peak_speed
        t = min(max(t, 0.0), total)
        if t < ramp:
            return 0.5 * self.acceleration * t * t
        if t <= total - ramp:
            return 0.5 * peak * ramp + peak * (t - ramp)
        remaining = total - t
        return self.distance - 0.5 * self.acceleration * remaining * remaining

    def velocity(self, t: float) -> float:
        """Speed at time `t` (zero outside the motion)."""
        total, ramp = self.duration, self.ramp_time
        if t <= 0 or t >= total:
            return 0.0
        return self.acceleration * min(t, ramp, total - t)
