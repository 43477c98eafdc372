"""Reading the probe at a pose: one SURVEY_RAW reading, readings until they
settle within a tolerance (the stability check of `inclino acquire` and
`inclino accept`, docs in inclino.procedures.acquire), their mean as a
dataset row, the probe's averaging and the runs' progress bar.  Shared by
acquire, accept and their temperature forms."""
from __future__ import annotations

import math
from dataclasses import dataclass

from inclino.errors import DataError
from inclino.link.serial_link import ProbeError
from inclino.engines.reference import ACC_LSB_G, MAG_LSB_NT
from inclino.procedures.poses import wrap_deg


class Unsettled(ProbeError):
    """The readings did not agree within the tolerance (exit status 4)."""


DEFAULT_AVERAGE = 16  # the probe's samples per reading after a restart (docs/bench.md, --average)


@dataclass
class Reading:
    t_s: float
    acc: tuple  # counts (the probe's means: fractional, 1/64 count resolution)
    mag: tuple  # counts
    temp_c: float
    survey: dict  # the probe's survey of the same acquisition (units)
    record: object = None  # that survey's protocol.SurveyRecord (fixed point)
    temp_q6: int | None = None  # TEMP_OUT mean, Q6 counts (the temperature terms' input); None: older firmware


def read_once(link) -> Reading:
    from inclino.link import operations as calops

    s, r = calops.survey_with_raw(link)
    return Reading(s.t_ms / 1000.0, r.acc_counts, r.mag_counts, r.temp_centi_c / 100.0,
                   s.to_units(), s, getattr(r, "temp_q6", None))


@dataclass
class Tolerance:
    acc_mg: float = 1.0
    mag_nT: float = 20.0
    reads: int = 3

    def check(self, max_reads: int | None = None) -> None:
        """max_reads: the bench's --max-reads, which must leave room for
        --reads agreeing readings (fewer: no position can ever settle)."""
        if self.reads < 1:
            raise DataError("--reads must be >= 1")
        if max_reads is not None and max_reads < self.reads:
            raise DataError(f"--max-reads {max_reads}: at least --reads ({self.reads}) readings, or no position "
                            f"can settle")
        if not (self.acc_mg > 0 and self.mag_nT > 0):
            raise DataError("the stability tolerances must be > 0")

    def spread(self, window: list[Reading]) -> tuple[float, float]:
        """(accelerometer spread mg, fluxgate spread nT): the largest max - min over the axes."""
        sa = max(max(w.acc[k] for w in window) - min(w.acc[k] for w in window) for k in range(3))
        sm = max(max(w.mag[k] for w in window) - min(w.mag[k] for w in window) for k in range(3))
        return sa * ACC_LSB_G * 1e3, sm * MAG_LSB_NT

    def agrees(self, window: list[Reading]) -> bool:
        sa, sm = self.spread(window)
        return sa <= self.acc_mg and sm <= self.mag_nT


def read_stable(link, tol: Tolerance, max_reads: int | None = 30, waiting=None) -> list[Reading]:
    """Readings until the last tol.reads agree within tol; returns them.
    max_reads None: go on (an operator is there); `waiting(spread_mg,
    spread_nT, n)` is called after each disagreeing window."""
    win: list[Reading] = []
    n = 0
    while True:
        win.append(read_once(link))
        n += 1
        win = win[-tol.reads:]
        if len(win) == tol.reads and tol.agrees(win):
            return win
        if len(win) == tol.reads:
            sa, sm = tol.spread(win)
            if waiting is not None:
                waiting(sa, sm, n)
            if max_reads is not None and n >= max_reads:
                raise Unsettled(f"the readings did not settle in {n} reads (spread {sa:.2f} mg, {sm:.0f} nT; "
                                f"tolerance {tol.acc_mg:g} mg, {tol.mag_nT:g} nT){_few_samples(win)}")


def _few_samples(win: list[Reading]) -> str:
    """A probe left averaging fewer samples than its default (an earlier
    --average: it keeps it in RAM) reads noisier than the tolerances assume:
    say so, with the fix, where that can be why nothing settled."""
    n = getattr(win[-1].record, "count", None) if win else None
    if n is None or n >= DEFAULT_AVERAGE:
        return ""
    return (f"; the probe averages {n} sample{'s' if n != 1 else ''} per reading, fewer than its default "
            f"{DEFAULT_AVERAGE} (an --average it keeps until restarted): readings that noisy need --average "
            f"{DEFAULT_AVERAGE} or more, or wider --tol-acc-mg / --tol-mag-nt")


def mean_row(win: list[Reading]) -> dict:
    n = float(len(win))
    row = {"t_s": sum(w.t_s for w in win) / n, "temp_c": sum(w.temp_c for w in win) / n}
    for k, c in enumerate(("ax_g", "ay_g", "az_g")):
        row[c] = sum(w.acc[k] for w in win) / n * ACC_LSB_G
    for k, c in enumerate(("mx_nT", "my_nT", "mz_nT")):
        row[c] = sum(w.mag[k] for w in win) / n * MAG_LSB_NT
    return row


def gravity_toolface(acc) -> float:
    """The probe's gravity toolface from raw accelerometer counts (deg)."""
    return wrap_deg(math.degrees(math.atan2(acc[1], -acc[0] + 0.0)))


def set_average(link, n: int | None) -> None:
    if n is None:
        return
    if not 1 <= n <= 64:
        raise DataError("--average must be within 1-64 samples")
    link.set_average(n)


def progress_bar(total: int, desc: str, quiet: bool):
    """The per-position progress bar of a run (acquire, accept and their
    temperature forms): "pos" units, cleared at the end."""
    from inclino.progress import bar   # a bar on a terminal, periodic lines off one

    return bar(total, desc, unit="pos", quiet=quiet, leave=False, dynamic_ncols=True)
