"""The turntable a procedure moves the probe on: what acquire, accept and
the temperature run need of it (`move`, `world`, `close`, `unattended`), and
its manual implementation, a person at the turntable.  The emulated
turntable, driven over the emulator's control channel, is in
turntable_emulated.py (the application layer: it imports the emulator)."""
from __future__ import annotations

import sys

from inclino.errors import DataError
from inclino.link.serial_link import ProbeError
from inclino.procedures.poses import Step, describe


class TurntableError(ProbeError):
    """The bench's control channel failed or refused (exit status 4)."""


class ManualTurntable:
    """A person at the turntable: instructions on stderr, Enter on stdin."""

    unattended = False

    def __init__(self, stdin=None, say=None):
        self.stdin = stdin or sys.stdin
        self.default_say = say is None  # then the run prints above its progress bar
        self.say = say or (lambda m: print(m, file=sys.stderr, flush=True))

    def ask(self, prompt: str) -> str:
        self.say(prompt)
        line = self.stdin.readline()
        if not line:
            raise DataError("no operator input (end of input): run stopped")
        ans = line.strip().lower()
        if ans in ("q", "quit"):
            raise KeyboardInterrupt
        return ans

    def move(self, step: Step, index: int, total: int) -> None:
        if step.rotation:
            self.ask(f"[{index}/{total}] {step.label}: set inclination {step.inc:g} deg, azimuth {step.azi:g} deg, "
                     f"toolface 0; press Enter, then turn the toolface slowly (about 10 deg/s) through a full "
                     "turn ('q' to stop)")
        else:
            self.ask(f"[{index}/{total}] {step.label}: set inclination {step.inc:.1f} deg, azimuth "
                     f"{step.azi:.1f} deg, toolface {step.tf:.1f} deg ({describe(step.inc, step.azi, step.tf)}); "
                     "press Enter when set ('q' to stop)")

    def world(self) -> dict:
        return {}

    def close(self) -> None:
        pass
