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


# ------------------------------------------------------------------ offline processing of a dataset
COLS_BY_TRIADS = {
    "both": ("inc_deg", "azi_deg", "tf_deg", "gt_g", "bt_nT", "dip_deg", "flags", "mtf_deg"),
    "acc": ("inc_deg", "tf_deg", "gt_g", "flags"),      # what gravity alone determines
    "mag": ("bt_nT", "mtf_deg", "flags"),               # what the field alone determines
}
# the status flags of each triad (docs/conventions.md)
ACC_FLAGS = 0x0001 | 0x0002 | 0x0008 | 0x0020 | 0x0040
MAG_FLAGS = 0x0004 | 0x0010 | 0x0020 | 0x0080
_STANDIN_MAG = np.array([50000.0, 0.0, 0.0])  # nT: a field that leaves every gravity output alone
_STANDIN_ACC = np.array([1.0, 0.0, 0.0])      # g: horizontal, so nothing is flagged near vertical


def temp_q6_of(temp_c) -> np.ndarray:
    """TEMP_OUT as the probe's correction receives it for a temperature in
    degC: the mean in Q6 counts (inclino.formats.caltemp.temp_c_to_q6)."""
    from inclino.formats import caltemp

    return np.asarray(caltemp.temp_c_to_q6(np.atleast_1d(np.asarray(temp_c, float))), np.int64)


def run_dataset(acc_g, mag_nT, cal: Calibration, engine: str = "firmware", temp_c=None, triads: str = "both",
                notes: list | None = None) -> dict:
    """Attitude of a dataset's rows through `engine`, applying every term of
    the calibration: with temperature terms (CAL.json "temperature"), each
    row's temp_c (an array, or one temperature for every row).  The firmware
    and golden engines apply them as the probe does (its fixed-point
    correction with image version 2's terms); terms the image cannot hold are
    applied on the host in float64 before the firmware's correction (said in
    `notes`).  The reference engine applies them in float64.  triads "acc"
    or "mag": the other triad is a stand-in, and only what the present
    triad determines is returned (COLS_BY_TRIADS)."""
    from inclino.engines import temperature as te

    n = len(acc_g) if acc_g is not None else len(mag_nT)
    acc = np.broadcast_to(_STANDIN_ACC, (n, 3)) if acc_g is None else np.asarray(acc_g, float)
    mag = np.broadcast_to(_STANDIN_MAG, (n, 3)) if mag_nT is None else np.asarray(mag_nT, float)
    terms = te.has_terms(cal)
    if terms and temp_c is None:
        raise ValueError("temperature terms need temp_c")
    if not terms:
        out = run(acc, mag, cal, engine)
    elif engine == "reference":
        from inclino.calib import thermal

        T = np.broadcast_to(np.asarray(temp_c, float), (n,))
        a, m = thermal.to_reference(acc, mag, T, cal, cal.temperature)
        out = run(a, m, te.without_terms(cal), "reference")
    else:
        tq6 = np.broadcast_to(temp_q6_of(temp_c), (n,))
        aq, mq = reference.readings_acc(acc), reference.readings_mag(mag)
        try:
            eng = te.get(engine)
            eng.check(cal)
        except Exception as e:  # the image cannot hold the terms (or this build lacks the path): the host applies them
            if notes is not None and not any(x.startswith("temperature terms") for x in notes):
                notes.append(f"temperature terms applied on the host (float64) before the {engine}'s correction: {e}")
            eng = te.HostTerms()
        out = _from_fixed(eng.survey(aq, mq, tq6, cal, terms=True))
    keep = COLS_BY_TRIADS[triads]
    out = {k: out[k] for k in keep}
    if triads == "acc":
        out["flags"] = np.asarray(out["flags"], np.int64) & ACC_FLAGS
    elif triads == "mag":
        out["flags"] = np.asarray(out["flags"], np.int64) & MAG_FLAGS
    return out
