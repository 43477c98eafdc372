"""The firmware's fixed-point core, called from Python through cffi.

The extension `inclino.engines._core` is the very C of firmware/src, compiled for the
host by `pip install` (host/inclino/engines/_build_core.py).  Every function here takes
NumPy arrays and makes one C call for the whole batch.
"""
from __future__ import annotations

from dataclasses import dataclass

import numpy as np

try:
    from inclino.engines._core import ffi, lib
except ImportError as exc:  # pragma: no cover - message for a broken install
    raise ImportError(
        "inclino.engines._core is not built: install the project with `pip install .` "
        "(or run `make test`), which compiles firmware/src through cffi"
    ) from exc

ATT_COLS = ("inc", "azi", "gtf", "mtf", "gt", "bt", "dip", "flags")
SURVEY_COLS = ("gx", "gy", "gz", "bx", "by", "bz") + ATT_COLS


@dataclass(frozen=True)
class FixedTemp:
    """The temperature terms as the firmware holds them (corr_cal_t's
    t_ref, t_order, acc_tc, mag_tc; correct.h): t_ref int16 Q7 degC, order
    1 or 2; per triad c1 (3 int32: Q38 g/degC, Q19 nT/degC), c2 (3 int16:
    Q31 g/degC^2, Q12 nT/degC^2), r1 (3 int32 Q38 /degC), r2 (3 int16 Q31
    /degC^2); |c1|, |r1| <= 2^30.  inclino.formats.caltemp converts CAL.json's temperature block."""

    t_ref: int
    order: int
    acc_c1: tuple
    acc_c2: tuple
    acc_r1: tuple
    acc_r2: tuple
    mag_c1: tuple
    mag_c2: tuple
    mag_r1: tuple
    mag_r2: tuple


@dataclass(frozen=True)
class FixedCal:
    """Fixed-point coefficients as the firmware holds them (corr_cal_t).

    acc_m, mag_m: 9 int32, Q29, row-major; acc_b: 3 int32, Q29 g;
    mag_b: 3 int32, Q10 nT; temp: the temperature terms (image version 2)
    or None (version 1: none)."""

    acc_m: tuple
    acc_b: tuple
    mag_m: tuple
    mag_b: tuple
    temp: FixedTemp | None = None

    @staticmethod
    def identity() -> "FixedCal":
        eye = tuple(int(v) for v in (np.eye(3).ravel() * 2**29).astype(np.int64))
        return FixedCal(eye, (0, 0, 0), eye, (0, 0, 0))

    def arrays(self):
        return (np.array(self.acc_m, dtype=np.int64), np.array(self.acc_b, dtype=np.int64),
                np.array(self.mag_m, dtype=np.int64), np.array(self.mag_b, dtype=np.int64))


_CTYPE = {np.int16: "int16_t[]", np.int32: "int32_t[]", np.uint32: "uint32_t[]",
          np.uint8: "uint8_t[]"}


def _p(a):
    """cffi pointer to a contiguous NumPy array's buffer."""
    return ffi.from_buffer(_CTYPE[a.dtype.type], a)


def _c(arr, dtype):
    a = np.ascontiguousarray(arr, dtype=dtype)
    return a, _p(a)


def _cal_struct(cals):
    buf = ffi.new("corr_cal_t[]", len(cals))
    for i, c in enumerate(cals):
        for k in range(9):
            buf[i].acc.m[k] = int(c.acc_m[k])
            buf[i].mag.m[k] = int(c.mag_m[k])
        for k in range(3):
            buf[i].acc.bias[k] = int(c.acc_b[k])
            buf[i].mag.bias[k] = int(c.mag_b[k])
        t = c.temp
        if t is not None:
            buf[i].t_ref, buf[i].t_order = int(t.t_ref), int(t.order)
            for tri, tc in (("acc", buf[i].acc_tc), ("mag", buf[i].mag_tc)):
                for name in ("c1", "c2", "r1", "r2"):
                    getattr(tc, name)[0:3] = [int(v) for v in getattr(t, f"{tri}_{name}")]
    return buf


def mul32_q31(a, b):
    a_, pa = _c(a, np.int32)
    b_, pb = _c(b, np.int32)
    out = np.empty(a_.shape, np.int32)
    sat = np.empty(a_.shape, np.uint8)
    lib.inc_batch_mul32_q31(pa, pb, _p(out), _p(sat), a_.size)
    return out, sat.astype(bool)


def asr32_rnd(x, n):
    x_, px = _c(x, np.int32)
    n_, pn = _c(np.broadcast_to(n, x_.shape), np.uint8)
    out = np.empty(x_.shape, np.int32)
    lib.inc_batch_asr32_rnd(px, pn, _p(out), x_.size)
    return out


def div_frac_q20(num, den):
    n_, pn = _c(num, np.uint32)
    d_, pd = _c(den, np.uint32)
    out = np.empty(n_.shape, np.uint32)
    lib.inc_batch_div_frac_q20(pn, pd, _p(out), n_.size)
    return out


def sqrt_u32_q8(x):
    x_, px = _c(x, np.uint32)
    out = np.empty(x_.shape, np.uint32)
    lib.inc_batch_sqrt_u32_q8(px, _p(out), x_.size)
    return out


def atan2_q16(y, x):
    y_, py = _c(y, np.int32)
    x_, px = _c(x, np.int32)
    out = np.empty(y_.shape, np.int32)
    lib.inc_batch_atan2_q16(py, px, _p(out), y_.size)
    return out


def att_compute(g, b):
    """g (n, 3) Q27 g, b (n, 3) Q8 nT -> dict of int32 arrays (ATT_COLS)."""
    g_, pg = _c(g, np.int32)
    b_, pb = _c(b, np.int32)
    n = g_.shape[0]
    out = np.empty((n, len(ATT_COLS)), np.int32)
    lib.inc_batch_att(pg, pb, _p(out), n)
    return {k: out[:, i] for i, k in enumerate(ATT_COLS)}


def survey(acc, mag, cal: FixedCal | list[FixedCal] | None = None, temp_q6=None):
    """acc (n, 3) ADIS16210 readings, mag (n, 3) fluxgate readings, both in
    Q6 counts (golden.IN_ONE = 64 per count; golden.to_q6) -> dict of
    int32 arrays: g (n, 3) Q27 g, b (n, 3) Q8 nT and ATT_COLS.  With a list
    of calibrations, vector i uses cal[i % len(cal)].  temp_q6 (n,): the
    TEMP_OUT means in Q6 counts: survey_compute_temp, which applies the
    calibration's temperature terms (none in a FixedCal without temp: the
    same bits as without temp_q6); None: survey_compute."""
    cals = [FixedCal.identity()] if cal is None else (cal if isinstance(cal, list) else [cal])
    acc_ = np.clip(np.asarray(acc, dtype=np.int64), -(2**31), 2**31 - 1)
    a_, pa = _c(acc_, np.int32)
    mag_ = np.clip(np.asarray(mag, dtype=np.int64), -(2**31), 2**31 - 1)
    m_, pm = _c(mag_, np.int32)
    n = a_.shape[0]
    out = np.empty((n, len(SURVEY_COLS)), np.int32)
    if temp_q6 is None:
        lib.inc_batch_survey(pa, pm, _cal_struct(cals), len(cals), _p(out), n)
    else:
        t_ = np.clip(np.broadcast_to(np.asarray(temp_q6, dtype=np.int64), (n,)), -(2**31), 2**31 - 1)
        t_, pt = _c(t_, np.int32)
        lib.inc_batch_survey_temp(pa, pm, pt, _cal_struct(cals), len(cals), _p(out), n)
    res = {k: out[:, 6 + i] for i, k in enumerate(ATT_COLS)}
    res["g"] = out[:, 0:3]
    res["b"] = out[:, 3:6]
    return res


def survey_one(acc, mag, cal: FixedCal | None = None):
    """One survey through the firmware's own survey_compute (one C call per
    vector: what the per-call speed figure measures).  acc, mag in Q6 counts."""
    c = _cal_struct([cal or FixedCal.identity()])
    s = ffi.new("survey_t *")
    a = ffi.new("int32_t[3]", [int(v) for v in acc])
    m = ffi.new("int32_t[3]", [int(v) for v in mag])
    lib.survey_compute(a, m, c, s)
    att = s.att
    return {"g": list(s.g), "b": list(s.b), "inc": att.inc, "azi": att.azi, "gtf": att.gtf,
            "mtf": att.mtf, "gt": att.gt, "bt": att.bt, "dip": att.dip, "flags": att.flags}


@dataclass(frozen=True)
class QcRef:
    """Survey QC reference (qc_ref_t): G total Q27 g, B total Q8 nT, dip Q16
    degrees, each with its tolerance in the same format."""

    gt_ref: int = 2**27
    gt_tol: int = 335544
    bt_ref: int = 0
    bt_tol: int = 76800
    dip_ref: int = 0
    dip_tol: int = 16384


def qc_check(att: dict, ref: QcRef):
    """QC bits (qc.h QC_F_*) for a dict of attitude arrays (ATT_COLS)."""
    rows = np.stack([np.asarray(att[k], dtype=np.int64) for k in ATT_COLS], axis=-1)
    a_, pa = _c(rows, np.int32)
    r = ffi.new("qc_ref_t *", {k: int(getattr(ref, k)) for k in
                               ("gt_ref", "gt_tol", "bt_ref", "bt_tol", "dip_ref", "dip_tol")})
    out = np.empty(a_.shape[0], np.uint8)
    lib.inc_batch_qc(pa, r, _p(out), a_.shape[0])
    return out
