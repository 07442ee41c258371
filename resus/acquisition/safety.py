"""Safety limits the scanner enforces before every command, for every backend."""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from resus.errors import ResusError


class SafetyViolation(ResusError):
    """A command or a reading broke a safety limit; the scan must stop."""


@dataclass(frozen=True)
class SafetyLimits:
    """A TCP workspace box in the base frame, a TCP speed limit and a contact-force limit."""

    workspace_min: tuple[float, float, float] = (-0.45, -0.45, -0.05)
    """Lower corner of the box the TCP must stay in (m, base frame)."""
    workspace_max: tuple[float, float, float] = (0.45, 0.45, 0.45)
    """Upper corner of that box (m, base frame)."""
    max_speed: float = 0.10
    """Highest TCP speed a command may ask for (m/s); scanning runs at about 0.01."""
    max_force: float = 20.0
    """Highest contact force tolerated at the TCP (N)."""

    def __post_init__(self) -> None:
        if not np.all(np.less(self.workspace_min, self.workspace_max)):
            raise ResusError(
                "SafetyLimits.workspace_min must be below workspace_max on every axis, got "
                f"{tuple(self.workspace_min)} and {tuple(self.workspace_max)}"
            )
        for name in ("max_speed", "max_force"):
            if not getattr(self, name) > 0:
                raise ResusError(f"SafetyLimits.{name} must be positive, got {getattr(self, name)}")

    def position_violation(self, position: np.ndarray) -> str | None:
        """Why a TCP position lies outside the workspace box, or None."""
        low, high = np.asarray(self.workspace_min), np.asarray(self.workspace_max)
        outside = (position < low) | (position > high)
        if not outside.any():
            return None
        axis = int(np.flatnonzero(outside)[0])
        return (
            f"TCP {'xyz'[axis]} = {position[axis]:.3f} m leaves the workspace box "
            f"[{low[axis]:.3f}, {high[axis]:.3f}] m"
        )

    def check_target(self, target: np.ndarray, current: np.ndarray, period: float) -> None:
        """Refuse a streamed target outside the box or farther than max_speed allows."""
        reason = self.position_violation(target[:3, 3])
        if reason is None:
            speed = float(np.linalg.norm(target[:3, 3] - current[:3, 3])) / period
            # A late control cycle doubles one step on hardware, so allow twice the distance.
            if speed > 2 * self.max_speed:
                reason = (
                    f"commanded TCP speed {speed:.3f} m/s exceeds the limit {self.max_speed} m/s"
                )
        if reason is not None:
            raise SafetyViolation(reason)

    def check_wrench(self, wrench: np.ndarray) -> None:
        """Refuse a measured contact force above max_force."""
        force = float(np.linalg.norm(wrench[:3]))
        if force > self.max_force:
            raise SafetyViolation(
                f"contact force {force:.1f} N exceeds the limit {self.max_force} N"
            )

    def plan_violations(self, poses: np.ndarray, speed: float, force: float | None) -> list[str]:
        """Every reason a whole plan (sampled TCP poses, cruise speed, force) is unsafe."""
        reasons = []
        for index, pose in enumerate(poses):
            reason = self.position_violation(pose[:3, 3])
            if reason is not None:
                reasons.append(f"pose {index}: {reason}")
                break
        if speed > self.max_speed:
            reasons.append(f"speed {speed} m/s exceeds the limit {self.max_speed} m/s")
        if force is not None and force > self.max_force:
            reasons.append(f"contact force {force} N exceeds the limit {self.max_force} N")
        return reasons
