"""LAS 2.0 files as the survey commands write and read them (lasio).

Writing (CWLS LAS 2.0):

* the index is the first curve and is named DEPT (measured depth, unit M)
  or TIME (seconds);
* STRT and STOP are the first and last index values, in the index's unit;
  STEP is the constant spacing when every step is the same (to 1e-9 of the
  range), else 0, as the standard asks for irregular sampling;
* every ~Well item the standard makes mandatory is present (COMP, WELL,
  FLD, LOC, PROV, SRVC, DATE, UWI); DATE is the run's start, UTC, ISO 8601;
* values at full precision (10 significant digits), NULL -999.25.

Reading depth: the unit of a DEPT/DEPTH/MD curve is read as metres (M, m),
international feet (F, FT, feet), US survey feet (USFT, SFT, US ft: 1200/3937
m) or centimetres (CM); any other unit, or none, is refused.
"""
from __future__ import annotations

import io
import math

import numpy as np

from inclino.errors import DataError

NULL = -999.25
FT = 0.3048
US_FT = 1200.0 / 3937.0
DEPTH_UNITS = {"m": 1.0, "meter": 1.0, "meters": 1.0, "metre": 1.0, "metres": 1.0,
               "f": FT, "ft": FT, "feet": FT, "foot": FT, "intl ft": FT,
               "usft": US_FT, "us ft": US_FT, "us_ft": US_FT, "sft": US_FT, "ftus": US_FT, "us survey ft": US_FT,
               "us survey foot": US_FT, "us survey feet": US_FT,
               "cm": 0.01}
WELL_ITEMS = ("COMP", "WELL", "FLD", "LOC", "PROV", "SRVC", "UWI")


def depth_factor(unit: str, where: str) -> float:
    """Metres per unit of a depth curve; DataError for a unit that is not one
    of DEPTH_UNITS (never taken as metres)."""
    u = " ".join((unit or "").strip().lower().replace(".", " ").split())
    if u not in DEPTH_UNITS:
        raise DataError(f"{where}: depth unit {unit.strip()!r} is not one inclino reads (M, F/FT, USFT for US survey "
                        "feet, CM)" if (unit or "").strip() else
                        f"{where}: the depth curve has no unit (give M, F/FT, USFT or CM)")
    return DEPTH_UNITS[u]


def step_of(index) -> float:
    """LAS STEP of an index: the constant spacing, else 0 (irregular)."""
    x = np.asarray(index, float)
    if len(x) < 2:
        return 0.0
    d = np.diff(x)
    span = max(float(np.abs(x).max()), float(abs(x[-1] - x[0])), 1.0)
    if d[0] != 0 and np.all(np.abs(d - d[0]) <= 1e-9 * span):
        return float(d[0])
    return 0.0


def _num(v):
    return f"{v:.10g}"


def render(index_name: str, index_unit: str, index_descr: str, index, curves, params=(), date: str = "",
           other: str = "", well: dict | None = None) -> str:
    """The text of a LAS 2.0 file.  curves: (mnemonic, unit, description,
    values) after the index; params: (mnemonic, unit, value, description)."""
    import lasio

    if index_name not in ("DEPT", "TIME"):
        raise ValueError(index_name)
    x = np.asarray(index, float)
    las = lasio.LASFile()
    for k in WELL_ITEMS:
        las.well[k] = lasio.HeaderItem(k, value=str((well or {}).get(k, "")), descr=las.well[k].descr
                                       if k in las.well else k)
    las.well["DATE"] = lasio.HeaderItem("DATE", value=date, descr="start of the run, UTC (ISO 8601)")
    las.well["NULL"] = lasio.HeaderItem("NULL", value=NULL, descr="null value")
    las.other = other
    las.append_curve(index_name, x, unit=index_unit, descr=index_descr)
    for mnem, unit, descr, values in curves:
        v = np.asarray(values, float)
        las.append_curve(mnem, np.where(np.isfinite(v), v, NULL), unit=unit, descr=descr)
    for mnem, unit, value, descr in params:
        las.params[mnem] = lasio.HeaderItem(mnem, unit=unit, value=value, descr=descr)
    for k in ("STRT", "STOP", "STEP"):
        las.well[k].unit = index_unit
    if len(x):
        strt, stop, step = _num(x[0]), _num(x[-1]), _num(step_of(x))
    else:
        strt = stop = step = "0"
    buf = io.StringIO()
    las.write(buf, version=2.0, wrap=False, fmt="%.10g", STRT=strt, STOP=stop, STEP=step)
    return buf.getvalue()


MAX_HEADER_LINE = 4096  # characters in a header-section line (~V, ~W, ~C, ~P, ~O): LAS 2.0's are one item each


def read(text: str, where: str):
    """A lasio LASFile from text; DataError when it is not readable.  A
    header line longer than MAX_HEADER_LINE is refused before lasio sees it:
    lasio formats every header item for its debug log whether or not the log
    is on, in time quadratic in the item's length (a 1 MB STEP value took 25
    CPU s)."""
    import logging

    import lasio

    for lineno, line in enumerate(io.StringIO(text), 1):  # the header only: no copy of the data section
        line = line.rstrip("\r\n")
        if line.lstrip().upper().startswith("~A"):
            break
        if len(line) > MAX_HEADER_LINE:
            raise DataError(f"{where}:{lineno}: a header line of {len(line)} characters; a LAS header item fits "
                            f"in {MAX_HEADER_LINE}: not a readable LAS file")

    log = logging.getLogger("lasio")  # lasio logs its own notes ("Only engine='normal' ..."): kept off stderr
    level = log.level
    log.setLevel(logging.CRITICAL + 1)
    try:
        # read_policy=(): none of lasio's regular-expression rewrites of the data
        # lines -- its run-on pattern (-?\d*\.\d*\.\d*) backtracks in time
        # quadratic in a line's length (a line of a million digits ran for hours), and
        # its decimal-comma rewrite read "1,5" as 1.5 where every other reader refuses
        # it: a cell that is not a plain number stays text and is refused by name
        return lasio.read(io.StringIO(text), read_policy=())
    except Exception as e:  # lasio raises many kinds for a malformed file
        # lasio's own errors name the defect; anything else is an internal of its parser (a file of
        # "~" alone gave "string index out of range"), not worth a user's reading
        own = type(e).__module__.startswith("lasio") and str(e).strip()
        why = " ".join(str(e).split())[:80] if own else "its sections (~V, ~W, ~C, ~A) could not be parsed"
        raise DataError(f"{where}: not a readable LAS file ({why})") from None
    finally:
        log.setLevel(level)


def finite(v) -> bool:
    try:
        return math.isfinite(float(v))
    except (TypeError, ValueError):
        return False
