"""The emulator's simulated clock.

Time in the emulator never comes from the wall clock: whoever drives the
emulation (the firmware's HAL glue, a test, the dataset generator) advances
this clock explicitly, and every sensor model reads `now` from the same
instance.  Units: seconds (float64; 1 ns resolution is kept up to ~100 days).
"""
from __future__ import annotations

from dataclasses import dataclass


@dataclass
class Clock:
    now: float = 0.0

    def advance(self, dt: float) -> float:
        """Move time forward by dt >= 0 seconds; return the new time."""
        if dt < 0:
            raise ValueError("the clock cannot run backwards")
        self.now += float(dt)
        return self.now

    def advance_to(self, t: float) -> float:
        """Move time forward to t (no-op if t <= now); return the new time."""
        if t > self.now:
            self.now = float(t)
        return self.now
