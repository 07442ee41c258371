"""Faults the emulator can inject, for testing how clients cope with a misbehaving robot.

Spelled on the command line as repeatable `--fault` items:

    drop@T          close every connection at T and refuse new ones from then on
    drop@T+D        the same, but accept connections again D seconds later
    protective-stop@T
                    raise a protective stop at T (safety_mode 3, program stopped)
    latency=L       delay every RTDE data packet by L seconds
    jitter=J        and by a further uniform random 0..J seconds (seeded, order kept)

A time T is either absolute, on the emulator's clock (which starts at 0 when it reports ready
and runs with wall-clock time), or relative to the first motion command a client sends
(moveJ, moveL, servoJ, servoL, speedJ or speedL), spelled `motion+T`:

    drop@motion+2.5+1.0     drop the link 2.5 s after the first motion command, for 1 s
    protective-stop@motion+6

A client's start-up time (imports, connecting, a render worker) varies with the machine's
load, so a fault meant to strike mid-scan needs the motion-relative form: an absolute time
may land before the robot has moved at all. A motion-relative fault never strikes while no
motion command has arrived.
"""

from __future__ import annotations

import math
import re
from dataclasses import dataclass
from typing import Any

_TIMED = re.compile(r"^(drop|protective-stop)@(motion\+)?([0-9.]+)(?:\+([0-9.]+))?$")
_DELAY = re.compile(r"^(latency|jitter)=([0-9.]+)$")


@dataclass(frozen=True)
class FaultPlan:
    """When the emulator misbehaves, and how much it delays its data stream."""

    drop_at: float = math.inf
    """Time (s) at which every connection is closed: emulator time, or seconds after the first
    motion command when `drop_after_motion`."""
    drop_after_motion: bool = False
    """`drop_at` counts from the first motion command instead of the emulator's start."""
    drop_for: float = math.inf
    """How long after the drop connections stay refused (s)."""
    protective_stop_at: float = math.inf
    """Time (s) of an injected protective stop, on the clock `protective_stop_after_motion`
    names."""
    protective_stop_after_motion: bool = False
    """`protective_stop_at` counts from the first motion command."""
    latency: float = 0.0
    """Constant delay added to each RTDE data packet (s)."""
    jitter: float = 0.0
    """Largest extra random delay per data packet (s)."""
    seed: int = 0
    """Seed of the jitter's random numbers."""

    @classmethod
    def parse(cls, items: list[str] | tuple[str, ...], seed: int = 0) -> FaultPlan:
        """Build from `--fault` items; a bad item raises ValueError naming it."""
        fields: dict[str, Any] = {}  # FaultPlan's fields by name
        for item in items:
            timed, delay = _TIMED.match(item.strip()), _DELAY.match(item.strip())
            try:
                if timed and timed.group(1) == "drop":
                    fields["drop_at"] = float(timed.group(3))
                    fields["drop_after_motion"] = timed.group(2) is not None
                    if timed.group(4):
                        fields["drop_for"] = float(timed.group(4))
                elif timed and not timed.group(4):
                    fields["protective_stop_at"] = float(timed.group(3))
                    fields["protective_stop_after_motion"] = timed.group(2) is not None
                elif delay:
                    fields[delay.group(1)] = float(delay.group(2))
                else:
                    raise ValueError
            except ValueError:
                raise ValueError(
                    f"--fault {item!r}: expected drop@T, drop@T+D, protective-stop@T, "
                    "latency=L or jitter=J (seconds; T absolute or motion+T)"
                ) from None
        return cls(**fields, seed=seed)

    def drop_time(self, motion_started: float | None = None) -> float:
        """Emulator time (s) of the drop; infinite while a motion-relative one waits for the
        first motion command (`motion_started`, emulator time, None before it)."""
        return _strike_time(self.drop_at, self.drop_after_motion, motion_started)

    def protective_stop_time(self, motion_started: float | None = None) -> float:
        """Emulator time (s) of the injected protective stop (see `drop_time`)."""
        return _strike_time(
            self.protective_stop_at, self.protective_stop_after_motion, motion_started
        )

    def refusing(self, now: float, motion_started: float | None = None) -> bool:
        """True while the dropped link refuses connections (`now`: emulator time)."""
        start = self.drop_time(motion_started)
        return start <= now < start + self.drop_for

    @property
    def delays_data(self) -> bool:
        return self.latency > 0 or self.jitter > 0


def _strike_time(at: float, after_motion: bool, motion_started: float | None) -> float:
    if not after_motion:
        return at
    return math.inf if motion_started is None else motion_started + at
