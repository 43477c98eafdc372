"""The temperature path on the S08 simulator (firmware/sim/s08/harness.c
commands 'H', 'Y', 'J'; the rest of the driver is inclino.s08.harness).

  enc_temp(ft)             'H': the loaded calibration's temperature terms
  survey_temp(b, ...)      survey_compute_temp per row (as inclino.s08.harness.survey, plus
                           the TEMP_OUT mean in Q6 counts)
  calimg_parse_temp(b, ..) calimg_parse's temperature fields per image
  bench_survey_temp(b, n)  cycles of survey_compute_temp on the bench
                           vectors at temperatures of -5..55 degC
"""
from __future__ import annotations

import numpy as np

from inclino.s08.harness import SURVEY_DT, _be, _decode, _jobs, _records, _split, _u16
from inclino.s08.toolchain import TARGET_SURVEY_CYCLES
from inclino.benchmarks.s08 import _stats
from inclino.benchmarks.s08 import bench as mcu_bench
from inclino.benchmarks.s08 import bench_vectors
from inclino.s08.toolchain import build
from inclino.s08.harness import enc_cal
from inclino.s08.simulator import run_streams, timed

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


def calimg_parse_temp(b, images: list) -> np.ndarray:
    """calimg_parse on the S08 of each image: its status and the temperature
    fields (the harness's fill 0x25A5A5A5 / 0x25A5 / 0xA5 when untouched)."""
    cmds = [b"J" + _u16(len(d)) + bytes(d) for d in images]
    outs = run_streams(b, _split(cmds, _jobs(len(cmds) // 2)))
    return _decode(outs, CALIMG_TEMP_DT, len(images)).copy()


def bench_inputs(vectors: int, seed: int):
    """The bench vectors (bench_vectors), the typical calibration with
    the typical scenario's temperature terms (bench_temperature.typical_block)
    and temperatures drawn in -5..55 degC (the acceptance range)."""
    from inclino import caltemp
    from inclino.bench_temperature import typical_block

    acc, mag, fc = bench_vectors(vectors, seed)
    ft = caltemp.to_fixed(typical_block())
    fct = type(fc)(fc.acc_m, fc.acc_b, fc.mag_m, fc.mag_b, ft)
    rng = np.random.default_rng(seed)
    tq = caltemp.temp_c_to_q6(rng.uniform(-5.0, 55.0, len(acc)))
    return acc, mag, tq, fct


def bench_survey_temp(b, vectors: int = 100, seed: int = 11) -> list[int]:
    """Bus cycles of survey_compute_temp (terms applied) per bench vector."""
    acc, mag, tq, fct = bench_inputs(vectors, seed)
    return timed(b, records(acc, mag, tq), setup=enc_setup(fct))


def bench(vectors: int = 100, seed: int = 11):
    """inclino.benchmarks.s08.bench() and the temperature path's figures (`inclino bench mcu
    --json`): survey_compute_temp's cycles on the same vectors with the
    typical temperature terms, the mean added to survey_compute's, and its
    target (max <= TARGET_SURVEY_CYCLES), which `passed` then includes."""
    import tempfile

    res = mcu_bench(vectors, seed)
    with tempfile.TemporaryDirectory(prefix="inclino-bench-temp-") as td:
        cyc = bench_survey_temp(build(td), vectors, seed)
    st = _stats(cyc)
    res.survey_temperature = st
    res.temperature_added_cycles = st.mean - res.survey.mean
    res.meets_temperature_cycle_target = st.max <= TARGET_SURVEY_CYCLES
    res.passed = res.passed and res.meets_temperature_cycle_target
    return res
