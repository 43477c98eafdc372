"""The temperature terms of CAL.json (inclino.calib.thermal) in the form the
firmware applies (calibration image version 2; correct.h, docs/calibration.md).

CAL.json's model, per axis of each triad, dT = T - t_ref:

    raw_ref = b + (raw - b - bias(T)) / (1 + s(T))
    bias(T) = c1 dT + c2 dT^2,   s(T) = 1e-6 (p1 dT + p2 dT^2)

The firmware has no division per axis: it multiplies by r(T) = 1 + r1 dT +
r2 dT^2, the expansion of 1 / (1 + s(T)) to second order in dT,

    r1 = -p1',  r2 = p1'^2 - p2'     (p' = 1e-6 p)

so raw_ref - b = (raw - b - bias(T)) r(T).  The truncation error is

    1/(1 + s) - r(T) = 2 p1' p2' dT^3 + p2'^2 dT^4 - s^3 / (1 + s)

which truncation_bound evaluates (max over a temperature range, per axis,
relative: a scale error); for the typical scenario's tempcos (|p1| <= 150
ppm/degC, |p2| <= 1 ppm/degC^2) it is below 0.05 ppm over -5..55 degC.

Fixed-point formats (correct.h corr_tc_t): t_ref int16 Q7 degC; c1 int32
Q38 g/degC (acc, +-3.9 mg/degC) or Q19 nT/degC (mag, +-2048 nT/degC), |c1|
<= 2^30; c2 int16 Q31 g/degC^2 (+-15 ug/degC^2) or Q12 nT/degC^2 (+-8
nT/degC^2); r1 int32 Q38 /degC (+-3906 ppm/degC), |r1| <= 2^30; r2 int16
Q31 /degC^2 (+-15 ppm/degC^2).  to_fixed refuses
(CalibrationError) terms beyond those ranges.

The temperature reading: TEMP_OUT averaged with 6 fraction bits (acquire.h
temp_q6; T = (1331 - raw) x 0.47 degC), 0.0073 degC per LSB.
"""
from __future__ import annotations

import numpy as np

from inclino.engines.firmware import FixedTemp
from inclino.errors import CalibrationError

T_REF_FRAC = 7
C1_FRAC = {"acc": 38, "mag": 19}
C2_FRAC = {"acc": 31, "mag": 12}
R1_FRAC = 38
R2_FRAC = 31
C1_LIMIT = 2**30  # |c1|, |r1| <= 2^30 (calimg_parse; corr_temp_eval's plain sums)
T_REF_RANGE_C = (-40.0, 125.0)
TEMP_RAW_ZERO = 1331      # TEMP_OUT count at 0 degC (adis16210.h)
TEMP_DEG_PER_COUNT = 0.47
TEMP_FRAC_BITS = 6        # temp_q6: TEMP_OUT mean in Q6 counts
OPERATING_RANGE_C = (-40.0, 125.0)  # the ADIS16210's, where the bound is also stated
I16 = 2**15 - 1


def temp_c_to_q6(temp_c):
    """Temperature (degC) -> the TEMP_OUT mean in Q6 counts the probe would
    report (raw = 1331 - T / 0.47; rounded half up as acq_avg_q6)."""
    raw = TEMP_RAW_ZERO - np.asarray(temp_c, dtype=float) / TEMP_DEG_PER_COUNT
    return np.floor(raw * (1 << TEMP_FRAC_BITS) + 0.5).astype(np.int64)


def q6_to_temp_c(temp_q6):
    """The TEMP_OUT mean in Q6 counts -> degC (exact, float)."""
    return (TEMP_RAW_ZERO - np.asarray(temp_q6, dtype=float) / (1 << TEMP_FRAC_BITS)) * TEMP_DEG_PER_COUNT


def _terms(block: dict, tri: str):
    """(c1, c2, p1, p2) (3,) each, in units (g or nT)/degC^k and 1/degC^k."""
    K = int(block["order"])
    b = np.zeros((2, 3))
    s = np.zeros((2, 3))
    t = block[tri]
    if K:
        b[:K] = np.asarray(t["bias"], float).reshape(K, 3)
        s[:K] = np.asarray(t["scale_ppm"], float).reshape(K, 3) * 1e-6
    return b[0], b[1], s[0], s[1]


def firmware_coefficients(block: dict, tri: str):
    """(c1, c2, r1, r2) in float: the firmware's form of one triad's terms."""
    c1, c2, p1, p2 = _terms(block, tri)
    return c1, c2, -p1, p1 * p1 - p2


def _q(v, frac, lim, what):
    with np.errstate(over="ignore", invalid="ignore"):  # a term beyond the range: the error below, no warning
        q = np.floor(np.asarray(v, float) * 2.0**frac + 0.5)
    if not np.all(np.isfinite(q)) or np.abs(q).max() > lim:
        rng = lim / 2.0**frac
        raise CalibrationError(f"temperature term {what} {np.asarray(v).tolist()} beyond the calibration "
                               f"image's range +-{rng:.3g}")
    return tuple(int(x) for x in q)


def to_fixed(block: dict) -> FixedTemp:
    """CAL.json's temperature block -> FixedTemp (image version 2).
    CalibrationError when a term or t_ref is beyond the image's range."""
    order = int(block["order"])
    if order not in (1, 2):
        raise CalibrationError(f"temperature terms of order {order}: the image carries order 1 or 2")
    tr = float(block["t_ref_c"])
    if not T_REF_RANGE_C[0] <= tr <= T_REF_RANGE_C[1]:
        raise CalibrationError(f"temperature terms about {tr:g} degC: the image's t_ref is within "
                               f"{T_REF_RANGE_C[0]:g}..{T_REF_RANGE_C[1]:g} degC")
    out = {}
    for tri, unit in (("acc", "g"), ("mag", "nT")):
        c1, c2, r1, r2 = firmware_coefficients(block, tri)
        out[f"{tri}_c1"] = _q(c1, C1_FRAC[tri], C1_LIMIT, f"{tri} bias {unit}/degC")
        out[f"{tri}_c2"] = _q(c2, C2_FRAC[tri], I16, f"{tri} bias {unit}/degC^2")
        out[f"{tri}_r1"] = _q(r1, R1_FRAC, C1_LIMIT, f"{tri} scale (1/degC)")
        out[f"{tri}_r2"] = _q(r2, R2_FRAC, I16, f"{tri} scale, second order of 1/(1+s) (1/degC^2)")
    if order < 2 and any(any(out[f"{t}_{k}"]) for t in ("acc", "mag") for k in ("c2", "r2")):
        order = 2  # p1^2 makes r2 non-zero even for first-order terms
    return FixedTemp(t_ref=int(np.floor(tr * 2**T_REF_FRAC + 0.5)), order=order, **out)


def from_fixed(ft: FixedTemp, tri: str):
    """(c1, c2, r1, r2) (3,) float: the values the image's integers stand for."""
    return (np.asarray(getattr(ft, f"{tri}_c1"), float) / 2.0**C1_FRAC[tri],
            np.asarray(getattr(ft, f"{tri}_c2"), float) / 2.0**C2_FRAC[tri],
            np.asarray(getattr(ft, f"{tri}_r1"), float) / 2.0**R1_FRAC,
            np.asarray(getattr(ft, f"{tri}_r2"), float) / 2.0**R2_FRAC)


def truncation_bound(block: dict, lo_c: float, hi_c: float, n: int = 2001) -> dict:
    """max over T in [lo_c, hi_c] of |1/(1 + s(T)) - r(T)| per axis, both
    triads (relative scale error of the second-order expansion, float64
    on a grid of n temperatures, plus 1 % so that the bound also holds
    between the grid's points: the error is smooth, a polynomial plus
    s^3 / (1 + s))."""
    dT = np.linspace(lo_c, hi_c, n) - float(block["t_ref_c"])
    out = {}
    for tri in ("acc", "mag"):
        _, _, p1, p2 = _terms(block, tri)
        s = p1 * dT[:, None] + p2 * dT[:, None] ** 2
        r = 1.0 - p1 * dT[:, None] + (p1 * p1 - p2) * dT[:, None] ** 2
        out[tri] = (1.01 * np.abs(1.0 / (1.0 + s) - r).max(axis=0)).tolist()
    return out


def firmware_block(block: dict) -> dict:
    """What CAL.json's temperature block says about the firmware's form:
    applied_by_firmware and, when the image carries the terms, the
    truncation bound of 1/(1 + s) over the run's span and over the part's
    operating range; else the reason it does not."""
    try:
        ft = to_fixed(block)
    except CalibrationError as e:
        return {"applied_by_firmware": False,
                "firmware": {"image_version": 1, "why_not": str(e)}}
    span = block.get("span_c") or [block["t_ref_c"], block["t_ref_c"]]
    return {"applied_by_firmware": True,
            "firmware": {"image_version": 2, "order": ft.order,
                         "form": "raw_ref - b = (raw - b - dT (c1 + c2 dT)) (1 + dT (r1 + r2 dT)); "
                                 "r1 = -p1, r2 = p1^2 - p2 (1/(1+s) to second order)",
                         "scale_truncation_max": {"over_c": [float(span[0]), float(span[1])],
                                                  **truncation_bound(block, float(span[0]), float(span[1]))},
                         "scale_truncation_max_operating": {
                             "over_c": list(OPERATING_RANGE_C),
                             **truncation_bound(block, *OPERATING_RANGE_C)},
                         "temperature_resolution_c": TEMP_DEG_PER_COUNT / (1 << TEMP_FRAC_BITS)}}


def apply_float(raw, temp_c, b, ft: FixedTemp, tri: str):
    """float64 of what the firmware computes before M: raw_ref - b = (raw -
    b - bias(T)) r(T) with the image's own coefficients (dequantised) and
    the firmware's second-order r(T); raw, b in the triad's units (g / nT),
    raw (n, 3), temp_c (n,).  The reference of the fixed-point loss."""
    c1, c2, r1, r2 = from_fixed(ft, tri)
    dT = (np.asarray(temp_c, float) - ft.t_ref / 2.0**T_REF_FRAC)[:, None]
    return (np.asarray(raw, float) - np.asarray(b, float) - dT * (c1 + c2 * dT)) * (1.0 + dT * (r1 + r2 * dT))
