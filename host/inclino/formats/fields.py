"""One rule per field of a structured input (JSON objects, TOML tables):
type and range checked before the value is used, every defect one line
naming the file and the field, never a Python exception's own text.

    f = Fields(d, "reference file r.json")          # d: what safeio.parse_json returned
    dec = f.number("declination_deg", -180, 180, null=True)
    epsg = f.integer("grid_epsg", 1024, 32767, null=True)
    tol = f.obj("tol")
    gt = tol.number("gt_g", 0, 0.5, lo_open=True)

The error class is the caller's (DataError: exit 2; CalibrationError: 3).
Numbers are JSON numbers (a bool is not a number, a string is not either);
NaN and infinities are refused (safeio.parse_json already refuses them in
JSON text; a TOML file may hold `inf`).  The same rules as the control
channel's (emulator/inclino_emu/control.py: `number`, `integer`, ...).
"""
from __future__ import annotations

import math

from inclino.errors import DataError

_MISSING = object()


def show(v, n: int = 24) -> str:
    """A value for an error line: short, never a Python type name."""
    if isinstance(v, str):
        t = repr(v)
    elif isinstance(v, bool):
        t = "true" if v else "false"
    elif v is None:
        t = "null"
    elif isinstance(v, dict):
        t = "an object"
    elif isinstance(v, list):
        t = "a list"
    else:
        t = str(v)
    return t if len(t) <= n else t[:n - 3] + "..."


def _range_text(lo, hi, lo_open=False, hi_open=False) -> str:
    if lo == -math.inf and hi == math.inf:
        return "a finite number"
    if hi == math.inf:
        return f"a number {'>' if lo_open else '>='} {lo:g}"
    if lo == -math.inf:
        return f"a number {'<' if hi_open else '<='} {hi:g}"
    return f"a number within {'(' if lo_open else '['}{lo:g}, {hi:g}{')' if hi_open else ']'}"


def check_number(v, what: str, lo=-math.inf, hi=math.inf, *, lo_open=False, hi_open=False, error=DataError):
    """v as a finite float within the range, else `error` naming `what`."""
    if isinstance(v, bool) or not isinstance(v, (int, float)):
        raise error(f"{what} must be {_range_text(lo, hi, lo_open, hi_open)}, not {show(v)}")
    try:
        x = float(v)
    except OverflowError:
        raise error(f"{what} must be {_range_text(lo, hi, lo_open, hi_open)}, not {show(v)}") from None
    if not math.isfinite(x) or x < lo or x > hi or (lo_open and x == lo) or (hi_open and x == hi):
        raise error(f"{what} must be {_range_text(lo, hi, lo_open, hi_open)}, not {show(v)}")
    return x


class Fields:
    """The fields of one JSON object (or TOML table) `d`, `where` naming it
    in every error line (the file, and the path to the object in it)."""

    def __init__(self, d, where: str, error=DataError):
        self.where, self.error = where, error
        if not isinstance(d, dict):
            raise error(f"{where} must be a JSON object, not {show(d)}")
        self.d = d

    def _get(self, key, required, default):
        v = self.d.get(key, _MISSING)
        if v is _MISSING:
            if required:
                raise self.error(f"{self.where}: {key} is missing")
            return _MISSING, default
        return v, None

    def has(self, key) -> bool:
        return key in self.d

    def number(self, key, lo=-math.inf, hi=math.inf, *, required=True, default=None, null=False,
               lo_open=False, hi_open=False):
        """A finite number within [lo, hi] (open ends with lo_open/hi_open);
        null=True: JSON null is allowed (returns None)."""
        v, dflt = self._get(key, required, default)
        if v is _MISSING:
            return dflt
        if v is None and null:
            return None
        return check_number(v, f"{self.where}: {key}", lo, hi, lo_open=lo_open, hi_open=hi_open, error=self.error)

    def integer(self, key, lo, hi, *, required=True, default=None, null=False):
        v, dflt = self._get(key, required, default)
        if v is _MISSING:
            return dflt
        if v is None and null:
            return None
        if isinstance(v, float) and v.is_integer() and abs(v) < 2**53:
            v = int(v)
        if isinstance(v, bool) or not isinstance(v, int) or not lo <= v <= hi:
            raise self.error(f"{self.where}: {key} must be an integer within [{lo}, {hi}], not {show(v)}")
        return v

    def string(self, key, *, required=True, default=None, null=False, max_len=1000, choices=None):
        v, dflt = self._get(key, required, default)
        if v is _MISSING:
            return dflt
        if v is None and null:
            return None
        if not isinstance(v, str) or len(v) > max_len:
            raise self.error(f"{self.where}: {key} must be text (at most {max_len} characters), not {show(v)}")
        if choices is not None and v not in choices:
            raise self.error(f"{self.where}: {key} must be one of {', '.join(choices)}, not {show(v)}")
        return v

    def boolean(self, key, *, required=True, default=None):
        v, dflt = self._get(key, required, default)
        if v is _MISSING:
            return dflt
        if not isinstance(v, bool):
            raise self.error(f"{self.where}: {key} must be true or false, not {show(v)}")
        return v

    def obj(self, key, *, required=True, null=False):
        """A nested object as Fields (None when absent and not required)."""
        v, _ = self._get(key, required, None)
        if v is _MISSING or (v is None and null):
            return None
        return Fields(v, f"{self.where}: {key}", self.error)

    def numbers(self, key, shape, lo=-math.inf, hi=math.inf, *, required=True, null=False):
        """A list (of lists) of finite numbers of the given shape (a tuple;
        None in it: any length), each within [lo, hi]; returns a numpy
        array (ragged, non-numeric, wrongly shaped: one error line)."""
        v, _ = self._get(key, required, None)
        if v is _MISSING or (v is None and null):
            return None
        return check_array(v, f"{self.where}: {key}", shape, lo, hi, self.error)

    def known(self, *keys) -> None:
        """Refuse a key not among `keys` (a misspelt field must not pass silently)."""
        extra = sorted(set(self.d) - set(keys))
        if extra:
            raise self.error(f"{self.where}: unknown field {show(extra[0], 40)} (known: {', '.join(keys)})")


def check_array(v, what: str, shape, lo=-math.inf, hi=math.inf, error=DataError):
    """A nested list of finite numbers of `shape` as a float array."""
    import numpy as np

    def walk(x, dims, path):
        if not dims:
            check_number(x, f"{what}{path}", lo, hi, error=error)
            return
        n = dims[0]
        if not isinstance(x, list) or (n is not None and len(x) != n):
            want = f"a list of {n}" if n is not None else "a list"
            raise error(f"{what}{path} must be {want}, not {show(x)}"
                        + (f" of {len(x)}" if isinstance(x, list) else ""))
        for i, e in enumerate(x):
            walk(e, dims[1:], f"{path}[{i}]")

    walk(v, tuple(shape), "")
    return np.asarray(v, dtype=float)
