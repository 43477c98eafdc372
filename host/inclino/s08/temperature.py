"""The temperature path on the S08 simulator (firmware/sim/s08/harness.c
commands 'H', 'Y', 'J'; the rest of the driver is inclino.s08.harness).

  enc_temp(ft)             'H': the loaded calibration's temperature terms
  survey_temp(b, ...)      survey_compute_temp per row (as s08.harness.survey, plus
                           the TEMP_OUT mean in Q6 counts)
  calimg_parse_temp(b, ..) calimg_parse's temperature fields per image
  temp_eval(b, ...)        corr_temp_eval ('e') per dT
  triad_temp(b, ...)       corr_triad_temp ('k') per row, after 'e' of its dT
(its cycles in `inclino bench mcu`: inclino.benchmarks.s08)
"""
from __future__ import annotations

import numpy as np

from inclino.s08.harness import SURVEY_DT, _be, _decode, _jobs, _records, _split, _u16, enc_cal
from inclino.s08.simulator import run_streams

TC_DT = [("c1", ">i4", (3,)), ("c2", ">i2", (3,)), ("r1", ">i4", (3,)), ("r2", ">i2", (3,))]
CALIMG_TEMP_DT = np.dtype([("status", "u1"), ("t_order", "u1"), ("t_ref", ">i2")]
                          + [(f"acc_{k}", d, s) for k, d, s in TC_DT] + [(f"mag_{k}", d, s) for k, d, s in TC_DT])


def enc_temp(ft) -> bytes:
    """'H' + t_ref, order, then c1 c2 r1 r2 of acc and of mag (core.FixedTemp)."""
    out = b"H" + int(ft.t_ref).to_bytes(2, "big", signed=True) + bytes([int(ft.order)])
    for tri in ("acc", "mag"):
        for k, dt in (("c1", ">i4"), ("c2", ">i2"), ("r1", ">i4"), ("r2", ">i2")):
            out += _be(getattr(ft, f"{tri}_{k}"), dt)
    return out


def enc_setup(fc) -> bytes:
    """The calibration (and its temperature terms when it has them)."""
    return enc_cal(fc) + (enc_temp(fc.temp) if fc.temp is not None else b"")


def records(acc, mag, temp_q6) -> list[bytes]:
    return _records(b"Y", (acc, ">i4"), (mag, ">i4"), (np.asarray(temp_q6).reshape(-1, 1), ">i4"))


def survey_temp(b, acc, mag, temp_q6, fc) -> dict:
    """survey_compute_temp on the S08 for each row (acc, mag Q6 counts,
    temp_q6 the TEMP_OUT means in Q6 counts) with one calibration."""
    acc = np.clip(np.asarray(acc, dtype=np.int64), -(2**31), 2**31 - 1)
    mag = np.clip(np.asarray(mag, dtype=np.int64), -(2**31), 2**31 - 1)
    t = np.clip(np.asarray(temp_q6, dtype=np.int64), -(2**31), 2**31 - 1)
    n = len(acc)
    recs = records(acc, mag, t)
    jobs = _jobs(n)
    outs = run_streams(b, _split(recs, jobs, enc_setup(fc)), jobs)
    res = _decode(outs, SURVEY_DT, n)
    return {k: res[k].astype(np.int64) for k in SURVEY_DT.names}


TT_DT = [("beff", ">i4", (3,)), ("e", ">i4", (3,)), ("tsat", "u1")]
TRIAD_DT = [("out", ">i4", (3,)), ("sat", "u1")]


def enc_temp_eval(which: int, dt: int) -> bytes:
    """'e' triad (0 acc, 1 mag) dT (Q7 degC, int16)."""
    return b"e" + bytes([which]) + int(dt).to_bytes(2, "big", signed=True)


def enc_triad_temp(which: int, x) -> bytes:
    """'k' triad x[3] (the scaled input, int32)."""
    return b"k" + bytes([which]) + _be(x, ">i4")


def temp_eval(b, dt, fc, which: int) -> dict:
    """corr_temp_eval on the S08 of fc's accelerometer (which=0) or fluxgate
    (1) terms at each dT (int16 Q7): beff (n, 3), e (n, 3), sat (n,)."""
    dt = np.asarray(dt, dtype=np.int64)
    n = len(dt)
    cmds = [enc_temp_eval(which, int(d)) for d in dt]
    jobs = _jobs(n // 20)
    outs = run_streams(b, _split(cmds, jobs, enc_setup(fc)), jobs)
    r = _decode(outs, np.dtype(TT_DT), n)
    return {"beff": r["beff"].astype(np.int64), "e": r["e"].astype(np.int64), "sat": r["tsat"].astype(bool)}


def triad_temp(b, x, dt, fc, which: int) -> dict:
    """corr_triad_temp on the S08 of each row of x (n, 3, scaled input) with
    fc's terms of one triad evaluated at that row's dT (corr_temp_eval first,
    on the S08 too): the terms (beff, e, tsat) and out (n, 3), sat (n,)."""
    x = np.asarray(x, dtype=np.int64)
    dt = np.asarray(dt, dtype=np.int64)
    n = len(x)
    cmds = [enc_temp_eval(which, int(d)) + enc_triad_temp(which, r) for d, r in zip(dt, x)]
    jobs = _jobs(n // 20)
    outs = run_streams(b, _split(cmds, jobs, enc_setup(fc)), jobs)
    r = _decode(outs, np.dtype(TT_DT + TRIAD_DT), n)
    return {k: r[k].astype(np.int64) if k not in ("sat", "tsat") else r[k].astype(bool) for k in r.dtype.names}


def calimg_parse_temp(b, images: list) -> np.ndarray:
    """calimg_parse on the S08 of each image: its status and the temperature
    fields (the harness's fill 0x25A5A5A5 / 0x25A5 / 0xA5 when untouched)."""
    cmds = [b"J" + _u16(len(d)) + bytes(d) for d in images]
    outs = run_streams(b, _split(cmds, _jobs(len(cmds) // 2)))
    return _decode(outs, CALIMG_TEMP_DT, len(images)).copy()
