"""`inclino bench mcu --json`: the fixed-point core on the S08 simulator --
cycles per call and per survey, against the float baseline, the frame
parser's share of the bus, the image's code and RAM, with the targets."""
from __future__ import annotations

import os
import subprocess
import tempfile
from dataclasses import asdict, dataclass
from pathlib import Path
import numpy as np
from inclino.s08.harness import _records, _u16, enc_cal, enc_calimg_build, enc_calimg_parse, enc_float_cal, enc_frame_encode, survey_float
from inclino.s08.simulator import stack_bytes, timed
from inclino.s08.sizes import McuSizes, sizes
from inclino.s08.toolchain import BUS_HZ, CFLAGS, McuError, TARGET_FLOAT_RATIO, TARGET_PARSER_CPU, TARGET_SURVEY_CYCLES, build, tools_missing
from inclino.formats.jsonout import dumps


# ------------------------------------------------------------------ bench
@dataclass
class CycleStats:
    calls: int
    mean: float
    min: int
    max: int


def _stats(c) -> CycleStats:
    c = np.asarray(c)
    return CycleStats(int(len(c)), float(c.mean()), int(c.min()), int(c.max()))


@dataclass
class McuBench:
    target: str
    compiler: str
    cflags: list
    functions: dict  # name -> CycleStats (bus cycles per call)
    survey: CycleStats  # whole survey_compute
    survey_float: CycleStats  # the same survey in float (SDCC software float)
    fixed_to_float_ratio: float  # mean cycles, fixed / float
    survey_ms_at_20mhz: float  # mean survey time at a 20 MHz bus
    survey_stack_bytes: int  # deepest stack use of survey_compute (--stack-auto: its RAM)
    sizes: McuSizes
    float_sizes: dict
    float_max_abs_err_deg: float  # float baseline vs the golden model (sanity)
    frame_parser_cycles_per_byte: CycleStats  # proto_frame_feed, one call per byte of traffic_stream()
    frame_parser_cpu_at_115200_baud: float  # mean cycles per byte / bus cycles per byte time (20 MHz)
    calimg_parse_cycles: int  # calimg_parse of one good 120-byte image (the whole check, CRC included)
    targets: dict
    meets_cycle_target: bool
    meets_ratio_target: bool
    passed: bool
    meets_parser_target: bool = False  # frame_parser_cpu_at_115200_baud <= TARGET_PARSER_CPU
    # what survey_compute is timed on: the acquisition's means with 6 fraction bits
    survey_inputs: str = "int32 Q6 counts (1/64 count) for both triads, fractional means of the bench vectors"
    # survey_compute_temp with the typical temperature terms (image version 2), -5..55 degC
    # (bench_survey_temp); its target is counted in `passed`
    survey_temperature: CycleStats | None = None
    temperature_added_cycles: float = 0.0  # mean, survey_temperature - survey
    meets_temperature_cycle_target: bool = False  # survey_temperature.max <= TARGET_SURVEY_CYCLES

    def to_json(self) -> str:
        return dumps(asdict(self))


def _sdcc_version() -> str:
    try:
        r = subprocess.run(["sdcc", "--version"], capture_output=True, text=True, timeout=30)
        return r.stdout.splitlines()[0].split()[-3] if r.stdout else "?"
    except (OSError, IndexError, subprocess.SubprocessError):
        return "?"


def bench_vectors(n: int = 200, seed: int = 11):
    """Physically plausible readings for the timing runs: random poses with
    I in [1, 179] degrees, fields of 20 000 to 70 000 nT, the typical
    calibration's raw readings (what a probe sees)."""
    from inclino.model import typical_probe as hbench
    from inclino.engines import reference

    rng = np.random.default_rng(seed)
    cal = hbench.typical_calibration()
    inc = rng.uniform(1.0, 179.0, n)
    azi = rng.uniform(0.0, 360.0, n)
    tf = rng.uniform(0.0, 360.0, n)
    dip = rng.uniform(-80.0, 80.0, n)
    F = rng.uniform(20000.0, 70000.0, n)
    g = np.empty((n, 3))
    bb = np.empty((n, 3))
    for i in range(n):
        g[i], bb[i] = reference.body_vectors(inc[i:i + 1], azi[i:i + 1], tf[i:i + 1], F[i], dip[i])
    ga, bm = hbench._raw_for(cal, g, bb)
    # averaged readings as the acquisition passes them on (Q6 counts)
    return reference.readings_acc(ga), reference.readings_mag(bm), cal.to_fixed()


def traffic_stream() -> bytes:
    """Link traffic for the parser's figure: a request and its 36-byte survey
    answer, a text line, the largest frame (200-byte payload)."""
    from inclino.link import protocol

    return (protocol.encode_frame(7, 0x05, b"") + protocol.encode_frame(7, 0x85, bytes(range(36)))
            + b"status ok\r\n" + protocol.encode_frame(8, 0x11, bytes(range(200))))


def bench_image() -> bytes:
    """The typical calibration as a calibration image (CalImage.pack)."""
    from inclino.model import typical_probe as hbench
    from inclino.formats.calimage import CalImage

    return CalImage(hbench.typical_calibration().to_fixed(), 123456, 1795000000, "joint").pack()


def bench_inputs(vectors: int, seed: int):
    """The bench vectors (bench_vectors), the typical calibration with the
    typical scenario's temperature terms (benchmarks.temperature.typical_block)
    and temperatures drawn in -5..55 degC (the acceptance range)."""
    from inclino.benchmarks.temperature import typical_block
    from inclino.formats import caltemp

    acc, mag, fc = bench_vectors(vectors, seed)
    fct = type(fc)(fc.acc_m, fc.acc_b, fc.mag_m, fc.mag_b, caltemp.to_fixed(typical_block()))
    rng = np.random.default_rng(seed)
    tq = caltemp.temp_c_to_q6(rng.uniform(-5.0, 55.0, len(acc)))
    return acc, mag, tq, fct


def bench_survey_temp(b, vectors: int = 100, seed: int = 11) -> list[int]:
    """Bus cycles of survey_compute_temp (terms applied) per bench vector."""
    from inclino.s08 import temperature as s08_temp

    acc, mag, tq, fct = bench_inputs(vectors, seed)
    return timed(b, s08_temp.records(acc, mag, tq), setup=s08_temp.enc_setup(fct))


def bench_temp_functions(b, vectors: int = 100, seed: int = 11) -> dict:
    """Bus cycles of corr_temp_eval (the accelerometer's terms, then the
    fluxgate's, at each bench temperature's dT) and of corr_triad_temp (the
    accelerometer's input of each bench vector, the terms at the first dT)."""
    from inclino.engines import golden
    from inclino.s08 import temperature as s08_temp

    acc, mag, tq, fct = bench_inputs(vectors, seed)
    dt, _ = golden.corr_temp_dt(tq, fct.temp.t_ref)
    setup = s08_temp.enc_setup(fct)
    ev = timed(b, [s08_temp.enc_temp_eval(w, int(d)) for w in (0, 1) for d in dt], setup=setup)
    x = golden.corr_in_acc(np.clip(acc, -(2**21), 2**21 - 64))
    tr = timed(b, [s08_temp.enc_triad_temp(0, r) for r in x], setup=setup + s08_temp.enc_temp_eval(0, int(dt[0])))
    return {"corr_temp_eval": ev, "corr_triad_temp": tr}


def bench(vectors: int = 100, seed: int = 11, workdir: str | os.PathLike | None = None) -> McuBench:
    """Cycles, sizes and the fixed/float ratio on the S08 (ucsim's cycle
    counter: exact and repeatable).  `vectors` plausible survey inputs
    (bench_vectors) are timed through survey_compute and through the float
    baseline; each core function is timed on the arguments the survey gives
    it (from the golden model's intermediate values of the same vectors).
    Targets: a whole survey <= 60 000 bus cycles (the max over the vectors)
    and mean fixed/float <= 0.25.  `inclino bench mcu --json` prints
    bench().to_json()."""
    from inclino.engines import golden

    if tools_missing():
        raise McuError(tools_missing())
    with tempfile.TemporaryDirectory(prefix="inclino-bench-") as td:
        wd = Path(workdir) if workdir else Path(td)
        fx = build(wd / "fixed")
        fl = build(wd / "float", program="float")
        acc, mag, fc = bench_vectors(vectors, seed)
        recs = _records(b"V", (acc, ">i4"), (mag, ">i4"))
        cyc_s = timed(fx, recs, setup=enc_cal(fc))
        cyc_f = timed(fl, recs, setup=enc_float_cal(fc))
        # per-function inputs: what the survey passes them
        arrs = fc.arrays()
        gs = golden.survey_compute(acc, mag, *arrs)
        G, _ = golden.att_norm3(gs["g"])
        B, _ = golden.att_norm3(gs["b"])
        x_acc = golden.corr_in_acc(acc)
        funcs = {}
        funcs["fx_mul16"] = timed(fx, _records(b"P", ((G[:, 0] >> 16), ">i2"), ((B[:, 1] >> 16), ">i2")))
        funcs["fx_mul32_q31"] = timed(fx, _records(b"M", (G[:, 0], ">i4"), (B[:, 1], ">i4")))
        funcs["fx_dot3_q31"] = timed(fx, _records(b"3", (np.concatenate([G, B], 1), ">i4")))
        funcs["fx_dot3_q31 (a, a)"] = timed(fx, _records(b"W", (B, ">i4")))
        funcs["fx_div_frac_q20"] = timed(fx, _records(
            b"D", (np.minimum(np.abs(G[:, 0]), np.abs(G[:, 2])), ">u4"),
            (np.maximum(np.abs(G[:, 0]), np.abs(G[:, 2])), ">u4")))
        sq = np.abs(G[:, 0]) * 2 + np.abs(G[:, 1])
        funcs["fx_isqrt_u32"] = timed(fx, _records(b"R", (sq, ">u4")))
        funcs["fx_sqrt_u32_q8"] = timed(fx, _records(b"Q", (sq, ">u4")))
        funcs["fx_atan2_q16"] = timed(fx, _records(b"A", (G[:, 1], ">i4"), (-G[:, 0], ">i4")))
        funcs["att_norm3"] = timed(fx, _records(b"N", (gs["b"], ">i4")))
        funcs["corr_triad"] = timed(fx, _records(b"K", (np.zeros(len(acc)), "u1"), (x_acc, ">i4")),
                                    setup=enc_cal(fc))
        funcs["att_compute"] = timed(fx, _records(b"T", (np.concatenate([gs["g"], gs["b"]], 1), ">i4")))
        # the frame parser: each byte of the traffic timed alone (per-byte cost,
        # by parser state), and the image check on a good image
        traffic = traffic_stream()
        cyc_feed = timed(fx, [b"F" + _u16(1) + bytes([x]) for x in traffic], setup=b"I")
        funcs["proto_frame_feed (per byte)"] = cyc_feed
        funcs["proto_frame_encode (36-byte payload)"] = timed(fx, [enc_frame_encode(7, 0x85, bytes(range(36)))])
        img = bench_image()
        cyc_img = timed(fx, [enc_calimg_parse(img)])
        funcs["calimg_parse"] = cyc_img
        funcs["calimg_build"] = timed(fx, [enc_calimg_build(fc, 123456, 1795000000, 4)])
        res_f = survey_float(fl, acc, mag, fc)
        err = 0.0
        for k in ("inc", "dip"):
            err = max(err, float(np.abs(res_f[k] - gs[k] / 65536.0).max()))
        for k in ("azi", "gtf", "mtf"):
            d = (res_f[k] - gs[k] / 65536.0 + 180.0) % 360.0 - 180.0
            err = max(err, float(np.abs(d).max()))
        stack = max(stack_bytes(fx, r, setup=enc_cal(fc)) for r in recs[:3])
        cyc_t = bench_survey_temp(fx, vectors, seed)
        funcs.update(bench_temp_functions(fx, vectors, seed))
        sz = sizes(fx)
        fsz = sizes(fl)
    s = _stats(cyc_s)
    f = _stats(cyc_f)
    ratio = s.mean / f.mean
    meets_c = s.max <= TARGET_SURVEY_CYCLES
    meets_r = ratio <= TARGET_FLOAT_RATIO
    parser_cpu = float(np.mean(cyc_feed)) / (BUS_HZ * 10 / 115_200)
    meets_p = parser_cpu <= TARGET_PARSER_CPU
    st = _stats(cyc_t)
    meets_t = st.max <= TARGET_SURVEY_CYCLES
    return McuBench(
        target="Freescale S08 (ucsim shc08 -t HCS08), bus cycles",
        compiler=f"SDCC {_sdcc_version()}",
        cflags=list(CFLAGS),
        functions={k: _stats(v) for k, v in funcs.items()},
        survey=s,
        survey_float=f,
        fixed_to_float_ratio=ratio,
        survey_ms_at_20mhz=s.mean / BUS_HZ * 1e3,
        survey_stack_bytes=stack,
        sizes=sz,
        float_sizes={"image_code_bytes": fsz.image_code_bytes, "image_ram_bytes": fsz.image_ram_bytes},
        float_max_abs_err_deg=err,
        frame_parser_cycles_per_byte=_stats(cyc_feed),
        frame_parser_cpu_at_115200_baud=parser_cpu,
        calimg_parse_cycles=int(cyc_img[0]),
        targets={"survey_max_cycles": TARGET_SURVEY_CYCLES, "fixed_to_float_ratio": TARGET_FLOAT_RATIO,
                 "frame_parser_cpu_at_115200_baud": TARGET_PARSER_CPU},
        meets_cycle_target=meets_c,
        meets_ratio_target=meets_r,
        passed=meets_c and meets_r and meets_p and meets_t,
        meets_parser_target=meets_p,
        survey_temperature=st,
        temperature_added_cycles=st.mean - s.mean,
        meets_temperature_cycle_target=meets_t,
    )
