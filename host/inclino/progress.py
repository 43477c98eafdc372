"""Progress of long work on stderr, on a terminal and off one (tqdm).

On a terminal: a tqdm bar that appears once the work has taken more than a
second (or PERIOD, when shorter).  Off a terminal (a log file, CI, a pipe): the same tqdm status as a
plain line every PERIOD seconds (default 10; environment variable
INCLINO_PROGRESS_PERIOD), the first after PERIOD seconds, so short work
prints nothing (`delay=0` and `leave=True` give a first and a last line
as well, for work whose phases a log should show).  `quiet=True` (or INCLINO_PROGRESS=0) turns both off.

    with progress.bar(total, "reading run.csv", unit="B") as p:  # counted work
        p.update(n)
    with progress.phase("fitting joint to 40000 rows"):           # work without a count
        fit(...)
"""
from __future__ import annotations

import contextlib
import os
import sys
import threading

import tqdm as _tqdm
from tqdm import tqdm

_tqdm.tqdm.monitor_interval = 0  # no tqdm monitor thread: nothing starts behind the command's back


def period() -> float:
    try:
        v = float(os.environ.get("INCLINO_PROGRESS_PERIOD", "10"))
    except ValueError:
        v = 10.0
    return v if 0.0 < v < 1e6 else 10.0


def _off() -> bool:
    return os.environ.get("INCLINO_PROGRESS", "1") == "0"


class _Lines:
    """A file for tqdm that turns each status refresh into one line."""

    def __init__(self, stream):
        self.stream = stream

    def write(self, s: str) -> None:
        line = s.replace("\r", "").strip()
        if line and not line.startswith("\x1b"):
            self.stream.write("inclino: " + line + "\n")

    def flush(self) -> None:
        try:
            self.stream.flush()
        except (OSError, ValueError):
            pass


def _is_tty(stream) -> bool:
    try:
        return stream.isatty()
    except (AttributeError, ValueError):
        return False


def bar(total=None, desc: str = "", unit: str = "it", quiet: bool = False, stream=None, **kw) -> tqdm:
    stream = stream or sys.stderr
    if quiet or _off():
        return tqdm(total=total, disable=True)
    if _is_tty(stream):
        import shutil

        cols, rows = shutil.get_terminal_size((100, 24))  # a terminal without a size: 100 x 24
        kw.setdefault("leave", False)
        kw.setdefault("delay", min(1.0, period()))
        return tqdm(total=total, desc=desc, unit=unit, file=stream,
                    ncols=cols if cols > 20 else 100, nrows=rows if rows > 2 else 24, unit_scale=(unit == "B"),
                    **kw)
    p = period()
    if total is not None and "bar_format" not in kw:
        kw["bar_format"] = "{desc}: {percentage:.0f}% ({n_fmt}/{total_fmt} {unit}, {elapsed} elapsed, {remaining} left)"
    kw.setdefault("leave", False)
    kw.setdefault("delay", p)
    return tqdm(total=total, desc=desc, unit=unit, file=_Lines(stream), mininterval=p,
                maxinterval=p, ncols=100, ascii=True, unit_scale=(unit == "B"), **kw)


@contextlib.contextmanager
def phase(desc: str, quiet: bool = False, stream=None):
    """A status for work without a count: the elapsed time, refreshed by a
    thread (every half second on a terminal, every PERIOD off one)."""
    b = bar(None, desc, unit="s", quiet=quiet, stream=stream,
            bar_format="{desc}: {elapsed} elapsed")
    if b.disable:
        yield
        return
    stop = threading.Event()
    tty = _is_tty(stream or sys.stderr)
    step, first = (min(0.5, period()), min(1.0, period())) if tty else (period(), period())

    def beat():
        while not stop.wait(step):
            if b.format_dict["elapsed"] >= first:
                b.refresh()
                # what tqdm's close() reads to know the status was shown (refresh() alone leaves it as at
                # the start): without it the status stays on the line and the next output runs into it
                b.last_print_t = b._time()

    t = threading.Thread(target=beat, daemon=True)
    try:
        t.start()
    except RuntimeError:  # no thread to be had (a memory limit): the work goes on without the status
        b.close()
        yield
        return
    try:
        yield
    finally:
        stop.set()
        t.join()
        b.close()
