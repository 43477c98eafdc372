"""Progress of long link work (flash, acquire) when stderr is not a
terminal: tqdm draws bars on a terminal and turns itself off elsewhere, so
a log file or a CI job saw nothing for minutes.  `bar()` gives tqdm on a
terminal and, off one, a `LineProgress` that prints one plain line

    flash program: 12288/32768 B (38%), 4.1 s

at the start, at most every EVERY_S seconds, and at the end.  The same
methods as the tqdm calls the commands use (update, n, refresh, write,
set_postfix_str, close).
"""
from __future__ import annotations

import sys
import time

EVERY_S = 10.0   # seconds between two lines off a terminal


class LineProgress:
    def __init__(self, total: int, desc: str, unit: str = "", file=None):
        self.total, self.desc, self.unit = total, desc, unit
        self.file = file or sys.stderr
        self.n = 0
        self.postfix = ""
        self.t0 = time.monotonic()
        self._last = None
        self._closed = False
        self._line()

    def _line(self) -> None:
        self._last = time.monotonic()
        pct = f" ({100.0 * self.n / self.total:.0f}%)" if self.total else ""
        unit = f" {self.unit}" if self.unit else ""
        post = f", {self.postfix}" if self.postfix else ""
        print(f"{self.desc}: {self.n}/{self.total}{unit}{pct}{post}, {self._last - self.t0:.1f} s",
              file=self.file, flush=True)

    def refresh(self) -> None:
        if time.monotonic() - self._last >= EVERY_S:
            self._line()

    def update(self, k: int = 1) -> None:
        self.n += k
        self.refresh()

    def set_postfix_str(self, s: str) -> None:
        self.postfix = s

    def write(self, msg: str, file=None) -> None:
        print(msg, file=file or self.file, flush=True)

    def close(self) -> None:
        if not self._closed:
            self._closed = True
            self._line()


def bar(total: int, desc: str, unit: str = "", quiet: bool = False, **tqdm_kw):
    """tqdm on a terminal; LineProgress off one; a disabled tqdm with quiet."""
    from tqdm import tqdm

    if quiet:
        return tqdm(total=total, desc=desc, disable=True)
    if not sys.stderr.isatty():
        return LineProgress(total, desc, unit)
    return tqdm(total=total, desc=desc, unit=unit or "it", file=sys.stderr, **tqdm_kw)
