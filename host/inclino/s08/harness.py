"""The harness's byte protocol (firmware/sim/s08/harness.c) on the host:
encoders and decoders of its records, and the core's functions on the
simulator with NumPy in and NumPy out, like inclino.engines.firmware --
survey(), the primitives, the frame parser and encoder, the calibration
image's parse and build, the float baseline's survey."""
from __future__ import annotations

import os
import numpy as np
from inclino.s08.simulator import run_streams
from inclino.s08.toolchain import McuBuild, McuError


# ------------------------------------------------------------------ encoders
def _be(a, dt):
    return np.ascontiguousarray(np.asarray(a, dtype=np.int64).astype(dt)).tobytes()


def enc_cal(cal) -> bytes:
    """'C' + the 24 int32 coefficients of a FixedCal."""
    words = list(cal.acc_m) + list(cal.acc_b) + list(cal.mag_m) + list(cal.mag_b)
    return b"C" + _be(words, ">i4")


def _records(tag: bytes, *cols) -> list[bytes]:
    """One command per row: tag + the row's fields packed big-endian."""
    n = len(cols[0][0])
    dt = np.dtype([("t", "u1")] + [(f"f{i}", d, np.shape(a)[1:]) for i, (a, d) in enumerate(cols)])
    rec = np.zeros(n, dtype=dt)
    rec["t"] = tag[0]
    for i, (a, _) in enumerate(cols):
        rec[f"f{i}"] = np.asarray(a, dtype=np.int64)
    raw = rec.tobytes()
    w = dt.itemsize
    return [raw[i * w:(i + 1) * w] for i in range(n)]


def _split(parts: list[bytes], chunks: int, head: bytes = b"") -> list[bytes]:
    k = max(1, min(chunks, len(parts)))
    bounds = np.linspace(0, len(parts), k + 1).astype(int)
    return [head + b"".join(parts[bounds[i]:bounds[i + 1]]) + b"E" for i in range(k)]


def _decode(outs: list[bytes], dt: np.dtype, n: int) -> np.ndarray:
    raw = b"".join(outs)
    if len(raw) != n * dt.itemsize:
        raise McuError(f"expected {n * dt.itemsize} result bytes, got {len(raw)}")
    return np.frombuffer(raw, dtype=dt)


ATT_DT = [("inc", ">i4"), ("azi", ">i4"), ("gtf", ">i4"), ("mtf", ">i4"), ("gt", ">i4"),
          ("bt", ">i4"), ("dip", ">i4"), ("flags", ">u2")]
SURVEY_DT = np.dtype([("g", ">i4", (3,)), ("b", ">i4", (3,))] + ATT_DT)


def _jobs(n):
    return max(1, min(os.cpu_count() or 1, 8, n // 200 + 1))


def survey(b: McuBuild, acc, mag, cals: list) -> dict:
    """survey_compute on the S08 for each row (acc, mag in Q6 counts); vector
    i uses cals[i % len(cals)] (as inclino.engines.firmware.survey).  Returns int64 arrays: g, b (n, 3) and ATT_COLS."""
    acc = np.clip(np.asarray(acc, dtype=np.int64), -(2**31), 2**31 - 1)
    mag = np.clip(np.asarray(mag, dtype=np.int64), -(2**31), 2**31 - 1)
    n = len(acc)
    idx = np.arange(n) % len(cals)
    order = np.argsort(idx, kind="stable")  # group by calibration: one 'C' each
    recs = _records(b"V", (acc[order], ">i4"), (mag[order], ">i4"))
    parts = []
    for k, c in enumerate(cals):
        sel = np.nonzero(idx[order] == k)[0]
        if len(sel):
            parts.append([enc_cal(c)] + [recs[i] for i in sel])
    streams = []
    jobs = _jobs(n)
    for p in parts:  # each calibration's block split over the jobs
        head, body = p[0], p[1:]
        streams += _split(body, max(1, jobs * len(body) // n), head)
    outs = run_streams(b, streams, jobs)
    res = _decode(outs, SURVEY_DT, n)
    inv = np.empty(n, dtype=np.int64)
    inv[order] = np.arange(n)
    res = res[inv]
    out = {k: res[k].astype(np.int64) for k in SURVEY_DT.names}
    return out


def _prim(b: McuBuild, tag: bytes, cols, out_dt) -> np.ndarray:
    n = len(cols[0][0])
    recs = _records(tag, *cols)
    outs = run_streams(b, _split(recs, _jobs(n // 20)), None)
    return _decode(outs, np.dtype(out_dt), n)


def mul32_q31(b, x, y):
    r = _prim(b, b"M", [(x, ">i4"), (y, ">i4")], [("r", ">i4"), ("sat", "u1")])
    return r["r"].astype(np.int64), r["sat"].astype(bool)


def dot3_q31(b, x, y=None):
    """fx_dot3_q31 of the rows of x and y (n, 3); y None: of x with itself,
    the same array passed twice (the port's path for squares)."""
    if y is None:
        r = _prim(b, b"W", [(np.asarray(x, dtype=np.int64), ">i4")], [("r", ">i4"), ("sat", "u1")])
        return r["r"].astype(np.int64), r["sat"].astype(bool)
    xy = np.concatenate([np.asarray(x, dtype=np.int64), np.asarray(y, dtype=np.int64)], axis=1)
    r = _prim(b, b"3", [(xy, ">i4")], [("r", ">i4"), ("sat", "u1")])
    return r["r"].astype(np.int64), r["sat"].astype(bool)


def norm3(b, v):
    """att_norm3 of the rows of v (n, 3): (out (n, 3), s (n,))."""
    r = _prim(b, b"N", [(np.asarray(v, dtype=np.int64), ">i4")], [("out", ">i4", (3,)), ("s", "i1")])
    return r["out"].astype(np.int64), r["s"].astype(np.int64)


def asr32(b, x, n, rnd: bool = False):
    """fx_asr32 (or fx_asr32_rnd) of x by n (arrays)."""
    return _prim(b, b"U" if rnd else b"S", [(x, ">i4"), (n, "u1")], [("r", ">i4")])["r"].astype(np.int64)


def add32_sat(b, x, y, sub: bool = False):
    """fx_add32_sat (or fx_sub32_sat): (result, saturated)."""
    r = _prim(b, b"-" if sub else b"+", [(x, ">i4"), (y, ">i4")], [("r", ">i4"), ("sat", "u1")])
    return r["r"].astype(np.int64), r["sat"].astype(bool)


def div_frac_q20(b, num, den):
    return _prim(b, b"D", [(num, ">u4"), (den, ">u4")], [("r", ">u4")])["r"].astype(np.int64)


def sqrt_u32_q8(b, x):
    return _prim(b, b"Q", [(x, ">u4")], [("r", ">u4")])["r"].astype(np.int64)


def isqrt_u32(b, x):
    return _prim(b, b"R", [(x, ">u4")], [("r", ">u2")])["r"].astype(np.int64)


def atan2_q16(b, y, x):
    return _prim(b, b"A", [(y, ">i4"), (x, ">i4")], [("r", ">i4")])["r"].astype(np.int64)


def mul16(b, x, y):
    return _prim(b, b"P", [(x, ">i2"), (y, ">i2")], [("r", ">i4")])["r"].astype(np.int64)


def att_compute(b, g, bv):
    g = np.asarray(g, dtype=np.int64)
    r = _prim(b, b"T", [(np.concatenate([g, np.asarray(bv, dtype=np.int64)], axis=1), ">i4")], ATT_DT)
    return {k: r[k].astype(np.int64) for k, _ in ATT_DT}


def corr_triad(b, x, cal, which: int):
    """corr_triad with cal's accelerometer (which=0) or fluxgate (1) triad."""
    x = np.asarray(x, dtype=np.int64)
    n = len(x)
    recs = _records(b"K", (np.full(n, which), "u1"), (x, ">i4"))
    outs = run_streams(b, _split(recs, _jobs(n // 20), enc_cal(cal)), None)
    r = _decode(outs, np.dtype([("out", ">i4", (3,)), ("sat", "u1")]), n)
    return r["out"].astype(np.int64), r["sat"].astype(bool)


# ------------------------------------------------------------------ frames and images
FEED_CHUNK = 256  # the harness's HBUF_SIZE: longer segments go as several 'F'
PF_KINDS = {1: "frame", 2: "bad_crc", 3: "bad_len", 4: "line"}


def _u16(n: int) -> bytes:
    return int(n).to_bytes(2, "big")


def enc_frame_case(segments) -> bytes:
    """'I', then per segment 'F' n bytes (in chunks of FEED_CHUNK) or, for
    the marker "idle", 'L' (the layout of tests/vectors/frames.json)."""
    out = [b"I"]
    for seg in segments:
        if isinstance(seg, str):
            if seg != "idle":
                raise ValueError(f"unknown stream marker {seg!r}")
            out.append(b"L")
            continue
        seg = bytes(seg)
        for i in range(0, len(seg), FEED_CHUNK):
            out.append(b"F" + _u16(len(seg[i:i + FEED_CHUNK])) + seg[i:i + FEED_CHUNK])
    return b"".join(out)


def _dec_events(out: bytes, pos: int, events: list) -> int:
    """Event records of one 'F' up to its 0x00; appends dicts in the
    vectors' format; returns the new position."""
    while True:
        k = out[pos]
        pos += 1
        if k == 0:
            return pos
        kind = PF_KINDS.get(k)
        if kind == "frame":
            ver, seq, cmd = out[pos:pos + 3]
            n = int.from_bytes(out[pos + 3:pos + 5], "big")
            pl = out[pos + 5:pos + 5 + n]
            if len(pl) != n:
                raise McuError("truncated frame event")
            pos += 5 + n
            events.append({"kind": kind, "ver": ver, "seq": seq, "cmd": cmd, "payload": pl.hex()})
        elif kind == "bad_crc":
            events.append({"kind": kind, "seq": out[pos], "cmd": out[pos + 1]})
            pos += 2
        elif kind == "bad_len":
            events.append({"kind": kind})
        elif kind == "line":
            n = out[pos]
            events.append({"kind": kind, "line": out[pos + 1:pos + 1 + n].decode("ascii")})
            pos += 1 + n
        else:
            raise McuError(f"unknown parser event {k} at byte {pos - 1}")


def frame_events(b: McuBuild, cases: list) -> list[dict]:
    """proto_frame_feed on the S08: each case is a list of segments (bytes,
    or "idle" for proto_parser_idle), run from a fresh parser.  Returns per
    case {"events": [...] in the format of tests/vectors/frames.json,
    "idle": [proto_parser_idle's result, ...]}."""
    enc = [enc_frame_case(c) for c in cases]
    n = len(cases)
    k = max(1, min(n, _jobs(sum(map(len, enc)) // 50)))
    bounds = np.linspace(0, n, k + 1).astype(int)
    groups = [list(range(bounds[i], bounds[i + 1])) for i in range(k) if bounds[i] < bounds[i + 1]]
    outs = run_streams(b, [b"".join(enc[i] for i in g) + b"E" for g in groups])
    res = []
    for g, out in zip(groups, outs):
        pos = 0
        for i in g:
            ev, idle = [], []
            for seg in cases[i]:
                if isinstance(seg, str):
                    idle.append(out[pos])
                    pos += 1
                    continue
                for j in range(0, len(seg), FEED_CHUNK):
                    pos = _dec_events(out, pos, ev)
            res.append({"events": ev, "idle": idle})
        if pos != len(out):
            raise McuError(f"{len(out) - pos} result bytes left over")
    return res


def enc_frame_encode(seq: int, cmd: int, payload: bytes, cap: int = FEED_CHUNK) -> bytes:
    return b"G" + bytes([seq & 0xFF, cmd & 0xFF]) + _u16(len(payload)) + bytes(payload) + _u16(cap)


def frame_encode(b: McuBuild, frames: list) -> list[bytes]:
    """proto_frame_encode on the S08 for each (seq, cmd, payload[, cap]);
    b"" where it refuses.  payload and cap at most FEED_CHUNK bytes."""
    cmds = [enc_frame_encode(*f) for f in frames]
    outs = run_streams(b, _split(cmds, _jobs(len(cmds) // 4)))
    raw = b"".join(outs)
    res, pos = [], 0
    for _ in frames:
        m = int.from_bytes(raw[pos:pos + 2], "big")
        res.append(raw[pos + 2:pos + 2 + m])
        pos += 2 + m
    if pos != len(raw):
        raise McuError(f"{len(raw) - pos} result bytes left over")
    return res


CALIMG_DT = np.dtype([("status", "u1"), ("acc_m", ">i4", (9,)), ("acc_b", ">i4", (3,)),
                      ("mag_m", ">i4", (9,)), ("mag_b", ">i4", (3,)), ("serial", ">u4"),
                      ("time", ">u4"), ("method", "u1")])
CALIMG_UNTOUCHED = (0x25A5A5A5, 0xA5A5A5A5, 0xA5)  # the harness's fill: coefficient, serial/time, method


def enc_calimg_parse(data: bytes) -> bytes:
    return b"X" + _u16(len(data)) + bytes(data)


def calimg_parse(b: McuBuild, images: list) -> np.ndarray:
    """calimg_parse on the S08 of each byte string (at most FEED_CHUNK bytes):
    a CALIMG_DT record each: the status and the decoded fields (on an error
    the harness's fill, CALIMG_UNTOUCHED, which the parser must not touch)."""
    cmds = [enc_calimg_parse(d) for d in images]
    outs = run_streams(b, _split(cmds, _jobs(len(cmds) // 2)))
    return _decode(outs, CALIMG_DT, len(images)).copy()


def enc_calimg_build(cal, serial: int, time: int, method: int) -> bytes:
    words = list(cal.acc_m) + list(cal.acc_b) + list(cal.mag_m) + list(cal.mag_b)
    return (b"B" + _be(words, ">i4") + int(serial).to_bytes(4, "big") + int(time).to_bytes(4, "big")
            + bytes([method & 0xFF]))


def calimg_build(b: McuBuild, items: list) -> list[bytes]:
    """calimg_build on the S08 for each (FixedCal, serial, time, method code)."""
    cmds = [enc_calimg_build(*it) for it in items]
    outs = run_streams(b, _split(cmds, _jobs(len(cmds) // 2)))
    raw = b"".join(outs)
    if len(raw) != 120 * len(items):
        raise McuError(f"expected {120 * len(items)} image bytes, got {len(raw)}")
    return [raw[i * 120:(i + 1) * 120] for i in range(len(items))]


# ------------------------------------------------------------------ float baseline
FLOAT_DT = np.dtype([("inc", ">f4"), ("azi", ">f4"), ("gtf", ">f4"), ("mtf", ">f4"),
                     ("gt", ">f4"), ("bt", ">f4"), ("dip", ">f4"), ("flags", ">u2")])


def enc_float_cal(cal) -> bytes:
    """'C' + the float coefficients (M unitless, acc bias g, mag bias nT) of
    the fixed calibration, dequantised."""
    m = 2.0**29
    w = ([v / m for v in cal.acc_m] + [v / 2.0**29 for v in cal.acc_b]
         + [v / m for v in cal.mag_m] + [v / 2.0**10 for v in cal.mag_b])
    return b"C" + np.asarray(w, dtype=">f4").tobytes()


def survey_float(b: McuBuild, acc, mag, cal) -> dict:
    """The float baseline (tools/s08/survey_float.c) on the S08; degrees, g, nT."""
    acc = np.asarray(acc, dtype=np.int64)
    mag = np.asarray(mag, dtype=np.int64)
    recs = _records(b"V", (acc, ">i4"), (mag, ">i4"))
    outs = run_streams(b, _split(recs, _jobs(len(acc)), enc_float_cal(cal)))
    r = _decode(outs, FLOAT_DT, len(acc))
    return {k: r[k].astype(np.float64) for k in FLOAT_DT.names}
