"""Faults the emulator can inject, for testing how clients cope with a misbehaving robot.

Spelled on the command line as repeatable `--fault` items (times on the emulator's clock,
which starts at 0 when it reports ready and runs with wall-clock time):

    drop@T          close every connection at T and refuse new ones from then on
    drop@T+D        the same, but accept connections again D seconds later
    protective-stop@T
                    raise a protective stop at T (safety_mode 3, program stopped)
    latency=L       delay every RTDE data packet by L seconds
    jitter=J        and by a further uniform random 0..J seconds (seeded, order kept)
"""

from __future__ import annotations

import math
import re
from dataclasses import dataclass

_TIMED = re.compile(r"^(drop|protective-stop)@([0-9.]+)(?:\+([0-9.]+))?$")
_DELAY = re.compile(r"^(latency|jitter)=([0-9.]+)$")


@dataclass(frozen=True)
class FaultPlan:
    """When the emulator misbehaves, and how much it delays its data stream."""

    drop_at: float = math.inf
    """Emulator time (s) at which every connection is closed."""
    drop_for: float = math.inf
    """How long after `drop_at` connections stay refused (s)."""
    protective_stop_at: float = math.inf
    """Emulator time (s) of an injected protective stop."""
    latency: float = 0.0
    """Constant delay added to each RTDE data packet (s)."""
    jitter: float = 0.0
    """Largest extra random delay per data packet (s)."""
    seed: int = 0
    """Seed of the jitter's random numbers."""

    @classmethod
    def parse(cls, items: list[str] | tuple[str, ...], seed: int = 0) -> FaultPlan:
        """Build from `--fault` items; a bad item raises ValueError naming it."""
        fields: dict[str, float] = {}
        for item in items:
            timed, delay = _TIMED.match(item.strip()), _DELAY.match(item.strip())
            try:
                if timed and timed.group(1) == "drop":
                    fields["drop_at"] = float(timed.group(2))
                    if timed.group(3):
                        fields["drop_for"] = float(timed.group(3))
                elif timed and not timed.group(3):
                    fields["protective_stop_at"] = float(timed.group(2))
                elif delay:
                    fields[delay.group(1)] = float(delay.group(2))
                else:
                    raise ValueError
            except ValueError:
                raise ValueError(
                    f"--fault {item!r}: expected drop@T, drop@T+D, protective-stop@T, "
                    "latency=L or jitter=J (seconds)"
                ) from None
        return cls(**fields, seed=seed)

    def refusing(self, now: float) -> bool:
        """True while the dropped link refuses connections."""
        return self.drop_at <= now < self.drop_at + self.drop_for

    @property
    def delays_data(self) -> bool:
        return self.latency > 0 or self.jitter > 0
