"""Attitude from raw readings through one of three engines:

* firmware: the firmware's C (inclino.engines.firmware), fixed-point coefficients;
* golden:   the NumPy golden model (inclino.engines.golden), same integers;
* reference: float64 (inclino.engines.reference), float coefficients, unquantised.

The firmware and golden engines take the readings as the probe's acquisition
passes them to the correction: the mean with 6 fraction bits (Q6 counts,
acquire.h acq_avg_q6; reference.readings_acc/_mag), saturated at the sensors'
rails.  A reading that is a whole count (one sample) is passed exactly; an
average of n samples keeps its resolution to 1/64 count.
"""
from __future__ import annotations

import numpy as np

from inclino.engines import firmware as core, golden, reference
from inclino.formats.calfile import Calibration

ENGINES = ("firmware", "golden", "reference")
OUT_COLS = ("inc_deg", "azi_deg", "tf_deg", "mtf_deg", "gt_g", "bt_nT", "dip_deg", "flags")
Q16 = 65536.0
Q27 = float(2**27)
Q8 = 256.0


def _from_fixed(r) -> dict:
    return {
        "inc_deg": r["inc"] / Q16, "azi_deg": r["azi"] / Q16, "tf_deg": r["gtf"] / Q16,
        "mtf_deg": r["mtf"] / Q16, "gt_g": r["gt"] / Q27, "bt_nT": r["bt"] / Q8,
        "dip_deg": r["dip"] / Q16, "flags": np.asarray(r["flags"], dtype=np.int64),
    }


def reference_flags(acc_g, mag_nT, out) -> np.ndarray:
    """The firmware's status flags, decided on float values."""
    acc = np.asarray(acc_g) / reference.ACC_LSB_G
    mag = np.asarray(mag_nT) / reference.MAG_LSB_NT
    f = np.zeros(len(acc), dtype=np.int64)
    inc = out["inc_deg"]
    f |= np.where((inc < 0.5) | (inc > 179.5), golden.F_NEAR_VERTICAL, 0)
    f |= np.where((np.abs(acc) > golden.ACC_RANGE_COUNTS).any(-1), golden.F_ACC_OVERRANGE, 0)
    f |= np.where((np.abs(mag) > golden.MAG_RANGE_COUNTS).any(-1), golden.F_MAG_OVERRANGE, 0)
    f |= np.where(out["gt_g"] == 0, golden.F_ZERO_GRAVITY, 0)
    f |= np.where(out["bt_nT"] == 0, golden.F_ZERO_FIELD, 0)
    return f


def run(acc_g, mag_nT, cal: Calibration | None = None, engine: str = "firmware") -> dict:
    """acc_g (n, 3) raw accelerometer in g, mag_nT (n, 3) raw fluxgate in nT."""
    cal = cal or Calibration()
    acc_g = np.atleast_2d(np.asarray(acc_g, dtype=float))
    mag_nT = np.atleast_2d(np.asarray(mag_nT, dtype=float))
    if engine == "reference":
        g = reference.correct(acc_g, cal.acc_m, cal.acc_b)
        b = reference.correct(mag_nT, cal.mag_m, cal.mag_b)
        a = reference.attitude(g, b)
        out = {"inc_deg": a["inc"], "azi_deg": a["azi"], "tf_deg": a["gtf"], "mtf_deg": a["mtf"],
               "gt_g": a["gt"], "bt_nT": a["bt"], "dip_deg": a["dip"]}
        out["flags"] = reference_flags(acc_g, mag_nT, out)
        return out
    acc = reference.readings_acc(acc_g)
    mag = reference.readings_mag(mag_nT)
    fc = cal.to_fixed()
    if engine == "firmware":
        return _from_fixed(core.survey(acc, mag, fc))
    if engine == "golden":
        return _from_fixed(golden.survey_compute(acc, mag, *fc.arrays()))
    raise ValueError(f"unknown engine {engine!r} (one of {', '.join(ENGINES)})")
