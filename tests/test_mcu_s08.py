"""The firmware core on the S08 (SDCC -ms08, ucsim shc08): bit for bit equal to
the golden model on >= 10 000 vectors, including every edge case of the host
bit-exact suite (inclino.engines.bitexact.edge_vectors and the saturating
calibrations of random_cals).  The SCI frame parser and encoder and the
calibration-image checker on the S08: the recorded byte streams of
tests/vectors/frames.json give exactly their events, and random and corrupted
streams and images give the host build's (inclino.engines._core) results."""
import json
import shutil
import pathlib

import numpy as np
import pytest

from inclino.engines import bitexact, golden
from inclino import fw_sources
from inclino.benchmarks import s08 as s08_bench
from inclino.s08 import harness as s08_harness
from inclino.s08 import simulator as s08_sim
from inclino.s08 import temperature as s08_temp
from inclino.s08 import toolchain as s08_toolchain

if s08_toolchain.tools_missing():
    pytest.skip(s08_toolchain.MISSING_REASON, allow_module_level=True)

I32 = (-(2**31), 2**31 - 1)


@pytest.fixture(scope="module")
def fw(tmp_path_factory):
    return s08_toolchain.build(tmp_path_factory.mktemp("s08"))


def _mismatch_report(got: dict, want: dict, keys) -> tuple[int, str]:
    n = len(next(iter(got.values())))
    bad = np.zeros(n, dtype=bool)
    per = {}
    for k in keys:
        d = np.asarray(got[k]) != np.asarray(want[k])
        d = d.reshape(n, -1).any(axis=1)
        per[k] = int(d.sum())
        bad |= d
    first = int(np.argmax(bad)) if bad.any() else None
    return int(bad.sum()), f"per field {per}, first at {first}"


@pytest.mark.heavy
def test_survey_bit_exact_on_s08(fw):
    rng = np.random.default_rng(2024)
    cals = bitexact.random_cals(rng, 8)  # identity, 4 random, 3 saturating/zero
    ea, em = bitexact.edge_vectors()
    ra, rm = bitexact.random_vectors(rng, 2000)
    acc = np.concatenate([ea, ra])
    mag = np.concatenate([em, rm])
    assert len(acc) >= 10_000
    got = s08_harness.survey(fw, acc, mag, cals)
    idx = np.arange(len(acc)) % len(cals)
    arr = [np.array([getattr(c, f) for c in cals], dtype=np.int64)[idx]
           for f in ("acc_m", "acc_b", "mag_m", "mag_b")]
    want = golden.survey_compute(acc, mag, *arr)
    keys = ("g", "b", "inc", "azi", "gtf", "mtf", "gt", "bt", "dip", "flags")
    bad, why = _mismatch_report(got, want, keys)
    assert bad == 0, f"{bad} of {len(acc)} surveys differ on the S08: {why}"
    # the run reached the saturation and degenerate paths, not only the easy ones
    flags = got["flags"]
    for bit in (golden.F_ARITH_SATURATED, golden.F_ZERO_GRAVITY, golden.F_ZERO_FIELD,
                golden.F_NEAR_VERTICAL, golden.F_MAG_SATURATED, golden.F_ACC_SATURATED):
        assert (flags & bit).any(), f"flag {bit:#x} never raised"


def _edges32():
    e = [0, 1, -1, 2, -2, 32767, -32768, 32768, -32769, 65535, 65536, -65536, -65537,
         2**29, -(2**29), 2**30, -(2**30), 2**31 - 1, -(2**31), -(2**31) + 1, -(2**31) + 65535,
         0x12345678, -0x12345678]
    return np.array(e, dtype=np.int64)


def test_primitives_bit_exact_on_s08(fw):
    rng = np.random.default_rng(7)
    e = _edges32()
    ex, ey = [a.ravel() for a in np.meshgrid(e, e)]
    n = 1500

    # fx_mul32_q31: all edge pairs (incl. the saturating corner) + random
    a = np.concatenate([ex, rng.integers(*I32, n, endpoint=True)])
    b = np.concatenate([ey, rng.integers(*I32, n, endpoint=True)])
    r, s = s08_harness.mul32_q31(fw, a, b)
    gr, gs = golden.fx_mul32_q31(a, b)
    assert (r != gr).sum() == 0 and (s != gs).sum() == 0
    assert s.any() and not s.all()

    # fx_dot3_q31 (the port's assembly): edge triples, zero first operands
    # (skipped by the port), saturating products and sums + random
    t = rng.choice(e, (2000, 6))
    t[:200, 0] = 0
    t[200:400, :3] = 2**31 - 1
    t[200:300, 3:] = 2**31 - 1
    t[300:400, 3:] = -(2**31)
    t[400:450] = -(2**31)
    t = np.concatenate([t, rng.integers(*I32, (n, 6), endpoint=True)])
    r, s = s08_harness.dot3_q31(fw, t[:, :3], t[:, 3:])
    gr, gs = golden.fx_dot3_q31(t[:, :3], t[:, 3:])
    assert (r != gr).sum() == 0 and (s != gs).sum() == 0
    assert s.any() and not s.all()
    # ... and of a vector with itself (the port's path for squares)
    r, s = s08_harness.dot3_q31(fw, t[:, :3])
    gr, gs = golden.fx_dot3_q31(t[:, :3], t[:, :3])
    assert (r != gr).sum() == 0 and (s != gs).sum() == 0
    assert s.any() and not s.all()

    # att_norm3 (the port's assembly): zero, the rails, every leading-bit
    # position of the largest component (s from -2 to 29), both signs + random
    k = np.arange(32)
    top = np.concatenate([(2**k) - 1, 2**k, 2**k + 1]).clip(0, 2**31 - 1)
    v = rng.integers(-1, 2, (len(top), 3)) * (top[:, None] >> rng.integers(0, 3, (len(top), 3)))
    v[:, 0] = top * np.where(np.arange(len(top)) % 2, 1, -1)
    v = np.concatenate([v, [[0, 0, 0], [-(2**31), 0, 0], [2**31 - 1, -(2**31), 1], [0, 0, -1]],
                        rng.integers(*I32, (n, 3), endpoint=True),
                        rng.integers(-2**20, 2**20, (n, 3))])
    out, sh = s08_harness.norm3(fw, v)
    gout, gsh = golden.att_norm3(v)
    assert (out != gout).sum() == 0 and (sh != gsh).sum() == 0
    assert set(range(-2, 30)) <= set(sh.tolist())

    # fx_asr32, fx_asr32_rnd, fx_add32_sat, fx_sub32_sat (the port's assembly):
    # every shift count, the rails, ties, both saturations + random
    x = np.concatenate([np.repeat(e, 32), rng.integers(*I32, n, endpoint=True)])
    k = np.concatenate([np.tile(np.arange(32), len(e)), rng.integers(0, 32, n)])
    assert (s08_harness.asr32(fw, x, k) != golden.fx_asr32(x, k)).sum() == 0
    assert (s08_harness.asr32(fw, x, k, rnd=True) != golden.fx_asr32_rnd(x, k)).sum() == 0
    a = np.concatenate([ex, rng.integers(*I32, n, endpoint=True)])
    b = np.concatenate([ey, rng.integers(*I32, n, endpoint=True)])
    for sub, fn in ((False, golden.fx_add32_sat), (True, golden.fx_sub32_sat)):
        r, s = s08_harness.add32_sat(fw, a, b, sub=sub)
        gr, gs = fn(a, b)
        assert (r != gr).sum() == 0 and (s != gs).sum() == 0 and s.any()

    # fx_atan2_q16: axes, diagonals, zero, rails + random
    y = np.concatenate([ey, rng.integers(*I32, n, endpoint=True), [5, -5, 5, -5, 0]])
    x = np.concatenate([ex, rng.integers(*I32, n, endpoint=True), [5, 5, -5, -5, 0]])
    assert (s08_harness.atan2_q16(fw, y, x) != golden.fx_atan2_q16(y, x)).sum() == 0

    # fx_sqrt_u32_q8 and fx_isqrt_u32: 0, 1, squares and their neighbours,
    # every normalisation shift, the top of the range + random
    sq = np.arange(0, 65536, 97, dtype=np.int64) ** 2
    u = np.concatenate([[0, 1, 2, 3, 2**32 - 1, 2**30, 2**30 - 1, 2**31], sq, sq + 1,
                        np.maximum(sq - 1, 0), 2 ** np.arange(32, dtype=np.int64),
                        rng.integers(0, 2**32, n)])
    assert (s08_harness.sqrt_u32_q8(fw, u) != golden.fx_sqrt_u32_q8(u)).sum() == 0
    assert (s08_harness.isqrt_u32(fw, u) != golden.fx_isqrt_u32(u)).sum() == 0

    # fx_div_frac_q20: num >= den, den = 0, the top bit set, ties + random
    den = rng.integers(1, 2**32, n)
    num = (den * rng.uniform(0, 1, n)).astype(np.int64)
    num2 = np.array([0, 1, 5, 2**32 - 2, 2**32 - 1, 7, 2**31, 3], dtype=np.int64)
    den2 = np.array([0, 0, 5, 2**32 - 1, 2**32 - 1, 3, 2**32 - 1, 2**21], dtype=np.int64)
    num = np.concatenate([num, num2])
    den = np.concatenate([den, den2])
    assert (s08_harness.div_frac_q20(fw, num, den) != golden.fx_div_frac_q20(num, den)).sum() == 0

    # fx_mul16: the int16 rails (the S08 port's assembly helper)
    h = np.array([0, 1, -1, 255, 256, -256, 32767, -32768, 12345, -12345], dtype=np.int64)
    hx, hy = [v.ravel() for v in np.meshgrid(h, h)]
    hx = np.concatenate([hx, rng.integers(-32768, 32768, n)])
    hy = np.concatenate([hy, rng.integers(-32768, 32768, n)])
    assert (s08_harness.mul16(fw, hx, hy) != hx * hy).sum() == 0


def test_att_and_triad_bit_exact_on_s08(fw):
    rng = np.random.default_rng(9)
    g = rng.integers(-(2**28), 2**28, (300, 3))
    b = rng.integers(-(2**25), 2**25, (300, 3))
    g[:5] = [[0, 0, 0], [0, 0, 1], [2**31 - 1] * 3, [-(2**31)] * 3, [1, -1, 0]]
    got = s08_harness.att_compute(fw, g, b)
    want = golden.att_compute(g, b)
    bad, why = _mismatch_report(got, want, golden.att_compute(g[:1], b[:1]).keys())
    assert bad == 0, why
    cal = bitexact.random_cals(rng, 6)[1]
    x = rng.integers(-(2**31), 2**31, (300, 3))
    for which, (m, bias) in enumerate(((cal.acc_m, cal.acc_b), (cal.mag_m, cal.mag_b))):
        out, sat = s08_harness.corr_triad(fw, x, cal, which)
        gout, gsat = golden.corr_triad(x, np.array(m), np.array(bias))
        assert (out != gout).sum() == 0 and (sat != gsat).sum() == 0


def test_cycle_counts_are_exact_and_repeatable(fw):
    acc, mag, fc = s08_bench.bench_vectors(3)
    recs = s08_harness._records(b"V", (acc, ">i4"), (mag, ">i4"))
    c1 = s08_sim.timed(fw, recs, setup=s08_harness.enc_cal(fc))
    c2 = s08_sim.timed(fw, recs[::-1], setup=s08_harness.enc_cal(fc))
    assert c1 == c2[::-1]
    assert all(c > 1000 for c in c1)


def test_stack_use_is_measured_and_repeatable(fw):
    """With --stack-auto the core's locals live on the stack: its depth is
    measured by filling the free stack with a pattern (a figure of the
    bench, not a budget checked here)."""
    acc, mag, fc = s08_bench.bench_vectors(2)
    recs = s08_harness._records(b"V", (acc, ">i4"), (mag, ">i4"))
    d = [s08_sim.stack_bytes(fw, r, setup=s08_harness.enc_cal(fc)) for r in recs]
    assert d[0] > 16 and d[0] == s08_sim.stack_bytes(fw, recs[0], setup=s08_harness.enc_cal(fc))
    z = s08_sim.stack_bytes(fw, b"Z")
    assert z < d[0]


def test_build_refuses_helper_libraries_with_stack_auto(tmp_path):
    """SDCC's shipped helpers are not reentrant: a --stack-auto image that
    links one (here __mullong, from a 32 x 32 product) is refused."""
    src = tmp_path / "firmware"
    (src / "src").mkdir(parents=True)
    root = s08_toolchain.repo_root()
    import shutil
    shutil.copytree(root / "firmware" / "include", src / "include")
    shutil.copytree(root / "firmware" / "port", src / "port")
    shutil.copytree(root / "firmware" / "sim", src / "sim")
    shutil.copy(root / "firmware" / "sources.txt", src / "sources.txt")
    for f in fw_sources.sources("s08_core", root):
        if f.parent.name == "src":
            shutil.copy(f, src / "src" / f.name)
    with open(src / "src" / "survey.c", "a") as fh:
        fh.write("\nint32_t survey_mul_for_test(int32_t a, int32_t b) { return a * b; }\n")
    with pytest.raises(s08_toolchain.McuError, match="helper modules"):
        s08_toolchain.build(tmp_path / "b", root=tmp_path)


def test_float_baseline_computes_the_same_survey(tmp_path):
    fl = s08_toolchain.build(tmp_path, program="float")
    acc, mag, fc = s08_bench.bench_vectors(12)
    r = s08_harness.survey_float(fl, acc, mag, fc)
    g = golden.survey_compute(acc, mag, *fc.arrays())
    assert np.abs(r["inc"] - g["inc"] / 65536).max() < 0.01
    assert np.abs((r["azi"] - g["azi"] / 65536 + 180) % 360 - 180).max() < 0.01
    assert np.abs(r["gt"] / (g["gt"] / 2**27) - 1).max() < 1e-4
    assert (r["flags"] == g["flags"]).all()


# ------------------------------------------------------------------ frame parser
FRAME_VECTORS = json.loads((pathlib.Path(__file__).parent / "vectors" / "frames.json")
                           .read_text())["cases"]


def _segments(case):
    return [s if s == "idle" else bytes.fromhex(s) for s in case["stream"]]


def host_events(segments):
    """The host build of the same C (as tests/test_protocol_frames.py), with
    proto_parser_idle's results."""
    from inclino.engines._core import ffi, lib

    p = ffi.new("proto_parser_t *")
    lib.proto_parser_init(p)
    out, idle = [], []
    for seg in segments:
        if isinstance(seg, str):
            idle.append(lib.proto_parser_idle(p))
            continue
        for byte in seg:
            r = lib.proto_frame_feed(p, byte)
            kind = s08_harness.PF_KINDS.get(r)
            if kind == "frame":
                out.append({"kind": kind, "ver": p.ver, "seq": p.seq, "cmd": p.cmd,
                            "payload": bytes(p.payload[0:p.len]).hex()})
            elif kind == "bad_crc":
                out.append({"kind": kind, "seq": p.seq, "cmd": p.cmd})
            elif kind == "line":
                out.append({"kind": kind, "line": ffi.string(ffi.cast("char *", p.line)).decode()})
            elif kind is not None:
                out.append({"kind": kind})
    return {"events": out, "idle": idle}


def test_frame_vectors_on_s08(fw):
    got = s08_harness.frame_events(fw, [_segments(c) for c in FRAME_VECTORS])
    bad = [c["name"] for c, g in zip(FRAME_VECTORS, got) if g["events"] != c["events"]]
    assert not bad, f"{len(bad)} of {len(FRAME_VECTORS)} recorded streams differ on the S08: {bad}"


def _random_streams(rng, n):
    """Frames with bit errors, dropped and duplicated bytes; byte soup rich in
    0xA5, CR, LF and text; long lines; oversize length fields; other
    versions; silences (idle) anywhere, also inside frames."""
    from inclino.link import protocol

    def frame():
        pl = rng.integers(0, 256, int(rng.choice([0, 1, 5, 36, 60, 200])), dtype=np.uint8).tobytes()
        f = bytearray(protocol.encode_frame(int(rng.integers(0, 256)), int(rng.integers(0, 256)), pl))
        if rng.random() < 0.1:  # another version, CRC made to match
            f[1] = int(rng.integers(0, 256))
            f[-2:] = protocol.crc16(bytes(f[1:-2])).to_bytes(2, "big")
        if rng.random() < 0.1:  # a length beyond PROTO_MAX_PAYLOAD
            f[4:6] = int(rng.integers(201, 65536)).to_bytes(2, "big")
        return bytes(f)

    def soup():
        alphabet = np.array([0xA5, 0x0D, 0x0A, 0x00, 0x7F, 0x20, 0x41, 0x7E, 0xFF, 0x1F], dtype=np.uint8)
        k = int(rng.integers(1, 80))
        if rng.random() < 0.5:
            return rng.choice(alphabet, k).tobytes()
        return rng.integers(0, 256, k, dtype=np.uint8).tobytes()

    def text():
        k = int(rng.integers(0, 45))
        return bytes(rng.integers(0x20, 0x7F, k, dtype=np.uint8)) + rng.choice([b"\r", b"\n", b"\r\n", b""])

    streams = []
    for _ in range(n):
        buf = bytearray()
        for _ in range(int(rng.integers(1, 7))):
            buf += (frame, soup, text)[int(rng.choice(3, p=[0.6, 0.2, 0.2]))]()
        for _ in range(int(rng.integers(0, 4))):  # bit errors
            if buf:
                i = int(rng.integers(0, len(buf)))
                buf[i] ^= 1 << int(rng.integers(0, 8))
        if rng.random() < 0.3 and len(buf) > 3:  # a dropped byte
            del buf[int(rng.integers(0, len(buf)))]
        if rng.random() < 0.3 and buf:  # a duplicated byte
            i = int(rng.integers(0, len(buf)))
            buf.insert(i, buf[i])
        cuts = sorted(int(c) for c in rng.integers(0, len(buf) + 1, int(rng.integers(0, 3))))
        segs, last = [], 0
        for c in cuts:
            segs += [bytes(buf[last:c]), "idle"]
            last = c
        segs.append(bytes(buf[last:]))
        streams.append(segs)
    return streams


def test_frame_parser_random_and_corrupted_streams_on_s08(fw):
    rng = np.random.default_rng(77)
    streams = _random_streams(rng, 400)
    got = s08_harness.frame_events(fw, streams)
    want = [host_events(s) for s in streams]
    bad = [i for i, (g, w) in enumerate(zip(got, want)) if g != w]
    assert not bad, f"{len(bad)} of {len(streams)} streams differ from the host build, first {bad[:5]}"
    # the streams reached every event, chunking past 256 bytes and both idle results
    kinds = {e["kind"] for w in want for e in w["events"]}
    assert kinds == {"frame", "bad_crc", "bad_len", "line"}
    assert {0, 1} <= {x for w in want for x in w["idle"]}
    assert max(sum(len(x) for x in s if not isinstance(x, str)) for s in streams) > s08_harness.FEED_CHUNK


def test_frame_encoder_on_s08(fw):
    from inclino.link import protocol
    from inclino.engines._core import ffi, lib

    rng = np.random.default_rng(78)
    frames = [(int(rng.integers(0, 256)), int(rng.integers(0, 256)),
               rng.integers(0, 256, int(n), dtype=np.uint8).tobytes(), 256)
              for n in list(rng.integers(0, 201, 60)) + [0, 1, 200]]
    frames += [(1, 2, bytes(201), 256), (1, 2, bytes(10), 17), (1, 2, bytes(10), 18), (3, 4, b"", 7),
               (3, 4, b"", 8)]
    got = s08_harness.frame_encode(fw, frames)
    for (seq, cmd, pl, cap), g in zip(frames, got):
        out = ffi.new("uint8_t[]", 256)
        n = lib.proto_frame_encode(seq, cmd, ffi.new("uint8_t[]", pl or b"\0"), len(pl), out, cap)
        assert g == bytes(out[0:n]), (seq, cmd, len(pl), cap)
        if len(pl) <= 200 and cap >= len(pl) + 8:
            assert g == protocol.encode_frame(seq, cmd, pl)
        else:
            assert g == b""


# ------------------------------------------------------------------ calibration image
def _rand_fixed_cal(rng):
    from inclino.engines.firmware import FixedCal

    def triad():
        m = rng.integers(-(2**31), 2**31, 9)
        m[[0, 4, 8]] = rng.integers(2**27, 2**31, 3)
        b = rng.integers(-(2**30) + 1, 2**30, 3)
        return tuple(int(x) for x in m), tuple(int(x) for x in b)

    am, ab = triad()
    mm, mb = triad()
    return FixedCal(am, ab, mm, mb)


def host_calimg_parse(data: bytes):
    """calimg_parse of the host build, outputs filled as the harness fills them."""
    from inclino.engines._core import ffi, lib

    cal = ffi.new("corr_cal_t *")
    info = ffi.new("calimg_info_t *")
    fill, fill32, fill8 = s08_harness.CALIMG_UNTOUCHED
    for t in (cal.acc, cal.mag):
        for i in range(9):
            t.m[i] = fill
        for i in range(3):
            t.bias[i] = fill
    info.serial, info.time, info.method = fill32, fill32, fill8
    st = lib.calimg_parse(ffi.new("uint8_t[]", data or b"\0"), len(data), cal, info)
    return (st, list(cal.acc.m), list(cal.acc.bias), list(cal.mag.m), list(cal.mag.bias),
            info.serial, info.time, info.method)


def _rec(r):
    return (int(r["status"]), r["acc_m"].tolist(), r["acc_b"].tolist(), r["mag_m"].tolist(),
            r["mag_b"].tolist(), int(r["serial"]), int(r["time"]), int(r["method"]))


def _crc_fixed(img: bytearray) -> bytes:
    import binascii
    img[116:118] = binascii.crc_hqx(bytes(img[:116]), 0xFFFF).to_bytes(2, "big")
    return bytes(img)


def test_calimg_parse_on_s08(fw):
    from inclino.formats.calimage import METHODS, CalImage

    rng = np.random.default_rng(79)
    good = [CalImage(_rand_fixed_cal(rng), int(rng.integers(0, 2**32)), int(rng.integers(0, 2**32)),
                     str(rng.choice(list(METHODS)))).pack() for _ in range(20)]
    base = bytearray(good[0])
    images = list(good)
    # every single-byte corruption of one image (the padding too: still OK)
    for i in range(120):
        for flip in (0x01, 0x80, 0xFF):
            bad = bytearray(base)
            bad[i] ^= flip
            images.append(bytes(bad))
            if i < 116:  # the same with the CRC made to match: the later checks
                images.append(_crc_fixed(bad))
    # truncated, erased, oversize buffer, the range limits with a good CRC
    images += [bytes(base[:k]) for k in (0, 1, 6, 8, 116, 119)] + [b"\xff" * 120, bytes(base) + b"\0" * 8]
    for off, val in ((20, 2**27), (20, 2**27 - 1), (20, 0), (20, -(2**27)), (68, 2**31 - 1),
                     (68, -(2**31)), (56, 2**30 - 1), (56, 2**30), (56, -(2**30) + 1), (56, -(2**30)),
                     (112, 2**30), (112, -(2**30) + 1)):
        im = bytearray(base)
        im[off:off + 4] = int(val).to_bytes(4, "big", signed=True)
        images.append(_crc_fixed(im))
    got = s08_harness.calimg_parse(fw, images)
    want = [host_calimg_parse(d) for d in images]
    bad = [i for i, (g, w) in enumerate(zip(got, want)) if _rec(g) != w]
    assert not bad, f"{len(bad)} of {len(images)} images differ from the host build, first {bad[:5]}"
    status = {int(s) for s in got["status"]}
    assert status == {0, 1, 2, 3, 4, 5}
    assert all(int(s) == 0 for s in got["status"][:20])
    for r, d in zip(got[:20], good):  # the decoded fields are the packer's
        im = CalImage.unpack(d)
        assert tuple(r["acc_m"].tolist()) == im.cal.acc_m and tuple(r["mag_b"].tolist()) == im.cal.mag_b
        assert int(r["serial"]) == im.serial and int(r["method"]) == METHODS[im.method]


def test_calimg_build_on_s08(fw):
    from inclino.engines._core import ffi, lib
    from inclino.formats.calimage import METHODS, CalImage

    rng = np.random.default_rng(80)
    items = []
    for k in range(24):
        fc = _rand_fixed_cal(rng)
        if k % 4 == 3:  # out of range and any method byte: build does not check
            from inclino.engines.firmware import FixedCal
            fc = FixedCal(*(tuple(int(x) for x in rng.integers(-(2**31), 2**31, n)) for n in (9, 3, 9, 3)))
        items.append((fc, int(rng.integers(0, 2**32)), int(rng.integers(0, 2**32)), int(rng.integers(0, 256))))
    got = s08_harness.calimg_build(fw, items)
    names = {v: k for k, v in METHODS.items()}
    for (fc, serial, t, method), g in zip(items, got):
        cal = ffi.new("corr_cal_t *")
        for t_, m, bias in ((cal.acc, fc.acc_m, fc.acc_b), (cal.mag, fc.mag_m, fc.mag_b)):
            t_.m[0:9] = list(m)
            t_.bias[0:3] = list(bias)
        info = ffi.new("calimg_info_t *", {"serial": serial, "time": t, "method": method})
        out = ffi.new("uint8_t[192]")
        n = lib.calimg_build(cal, info, out)  # version 1: no temperature terms
        assert n == 120 and g == bytes(out)[:n]
        if method in names:
            assert g == CalImage(fc, serial, t, names[method]).pack()


def test_survey_with_temperature_terms_bit_exact_on_s08(fw):
    """survey_compute_temp (image version 2's terms) on the S08 equals the
    golden model: random terms over their whole ranges, typical ones and the
    limits, at plausible, 12-bit and any-int32 temperature readings and the
    clamp edges; and a calibration without terms gives survey_compute's bits."""
    rng = np.random.default_rng(77)
    cals = bitexact.random_temp_cals(rng, bitexact.random_cals(rng, 7))
    keys = ("g", "b", "inc", "azi", "gtf", "mtf", "gt", "bt", "dip", "flags")
    total = 0
    for k, c in enumerate(cals):
        acc, mag = bitexact.random_vectors(rng, 300)
        t = bitexact.random_temps(rng, 300)
        got = s08_temp.survey_temp(fw, acc, mag, t, c)
        want = golden.survey_compute(acc, mag, *c.arrays(), temp=c.temp, temp_q6=t)
        bad, why = _mismatch_report(got, want, keys)
        assert bad == 0, f"calibration {k}: {bad} of {len(acc)} surveys differ on the S08: {why}"
        total += len(acc)
    assert total >= 2000
    plain = type(cals[1])(cals[1].acc_m, cals[1].acc_b, cals[1].mag_m, cals[1].mag_b)
    acc, mag = bitexact.random_vectors(rng, 200)
    got = s08_temp.survey_temp(fw, acc, mag, bitexact.random_temps(rng, 200), plain)
    want = golden.survey_compute(acc, mag, *plain.arrays())
    assert _mismatch_report(got, want, keys)[0] == 0


def test_calimg_parse_temperature_fields_on_s08(fw):
    """A version 2 image's temperature fields decode on the S08 as in the
    host build; refused and version 1 images leave them / clear them alike."""
    from inclino.engines._core import ffi, lib
    from inclino.formats.calimage import CalImage

    rng = np.random.default_rng(5)
    cals = bitexact.random_temp_cals(rng, bitexact.random_cals(rng, 8))[:4]
    images = [CalImage(c, 1, 2, "joint").pack() for c in cals]
    images.append(CalImage(type(cals[0])(cals[0].acc_m, cals[0].acc_b, cals[0].mag_m, cals[0].mag_b),
                           1, 2, "joint").pack())  # version 1
    bad = bytearray(images[0])
    bad[130] ^= 0x10  # CRC mismatch
    images.append(bytes(bad))
    got = s08_temp.calimg_parse_temp(fw, images)
    for i, d in enumerate(images):
        cal = ffi.new("corr_cal_t *")
        info = ffi.new("calimg_info_t *")
        cal.t_order, cal.t_ref = 0xA5, 0x25A5
        for tc in (cal.acc_tc, cal.mag_tc):
            for k in range(3):
                tc.c1[k] = tc.r1[k] = 0x25A5A5A5
                tc.c2[k] = tc.r2[k] = 0x25A5
        st = lib.calimg_parse(ffi.new("uint8_t[]", d), len(d), cal, info)
        assert got["status"][i] == st and got["t_order"][i] == cal.t_order and got["t_ref"][i] == cal.t_ref
        for tri, tc in (("acc", cal.acc_tc), ("mag", cal.mag_tc)):
            for k in ("c1", "c2", "r1", "r2"):
                assert list(got[f"{tri}_{k}"][i]) == list(getattr(tc, k)), (i, tri, k)
    # the identity with whole-range terms loads, the version 1 image loads with no terms,
    # the corrupted one is refused (M of the random calibrations may be out of range: both agree)
    assert got["status"][0] == 0 and got["t_order"][0] in (1, 2)
    assert got["status"][4] == 0 and got["t_order"][4] == 0 and got["status"][5] == 4


# --------------------------------------------------------------- temperature terms, function by function
TEMP_EDGE_DT = (0, 1, -1, 2, -2, 3, -3, 32767, -32768, -32767, 7680, -7680, 3840, -3840, 255, -256)


def _temp_cases(rng):
    """(calibration, dT, x) per triad: the temperature calibrations of
    bitexact.random_temp_cals (terms over their whole ranges, typical ones,
    the limits; M and b from the identity to the saturating ones), dT over
    the whole int16 range with TEMP_EDGE_DT, x any int32 with the rails."""
    cals = bitexact.random_temp_cals(rng, bitexact.random_cals(rng, 7))
    out = []
    for c in cals:
        dt = np.concatenate([rng.integers(-(2**15), 2**15, 120), TEMP_EDGE_DT])
        x = rng.integers(-(2**31), 2**31, (len(dt), 3))
        x[:24] = rng.choice([-(2**31), 2**31 - 1, 0, 1, -1, 2**30, -(2**30)], (24, 3))
        out.append((c, dt, x))
    return out


def _temp_mismatches(fw, cases) -> tuple[int, dict]:
    """corr_temp_eval then corr_triad_temp on the S08 against the golden
    model: the number of rows that differ in any output word or flag, and
    what the rows covered."""
    bad = 0
    seen = {"dt<0": 0, "dt>0": 0, "dt odd": 0, "k2<0": 0, "k2>0": 0, "inner<0": 0, "inner>=0": 0,
            "terms saturated": 0, "triad saturated": 0, "triad clean": 0}
    for c, dt, x in cases:
        t = c.temp
        for which, tri in ((0, "acc"), (1, "mag")):
            got = s08_temp.triad_temp(fw, x, dt, c, which)
            k = {n: np.array(getattr(t, f"{tri}_{n}"), dtype=np.int64) for n in ("c1", "c2", "r1", "r2")}
            bias = np.array(c.acc_b if which == 0 else c.mag_b, dtype=np.int64)
            m = np.array(c.acc_m if which == 0 else c.mag_m, dtype=np.int64)
            beff, e, tsat = golden.corr_temp_eval(dt, bias, k["c1"], k["c2"], k["r1"], k["r2"])
            out, sat = golden.corr_triad_temp(x, m, beff, e)
            d = ((got["beff"] != beff).any(1) | (got["e"] != e).any(1) | (got["tsat"] != tsat)
                 | (got["out"] != out).any(1) | (got["sat"] != sat))
            bad += int(d.sum())
            inner = np.concatenate([k["c1"] + k["c2"] * dt[:, None], k["r1"] + k["r2"] * dt[:, None]], 1)
            kk = np.concatenate([k["c2"], k["r2"]])
            seen["dt<0"] += int((dt < 0).sum())
            seen["dt>0"] += int((dt > 0).sum())
            seen["dt odd"] += int((dt % 2 == 1).sum())
            seen["k2<0"] += int((kk < 0).sum())
            seen["k2>0"] += int((kk > 0).sum())
            seen["inner<0"] += int((inner < 0).sum())
            seen["inner>=0"] += int((inner >= 0).sum())
            seen["terms saturated"] += int(tsat.sum())
            seen["triad saturated"] += int(sat.sum())
            seen["triad clean"] += int((~sat).sum())
    return bad, seen


def test_temp_eval_and_triad_temp_bit_exact_on_s08(fw):
    """The port's corr_temp_eval and corr_triad_temp (corr_temp_s08.c) equal
    the golden model word for word, flags included, over every sign of dT,
    of the second-order terms and of the inner sums, odd and even dT, and
    the saturating paths (b_eff, e's clamp, the triad's sums)."""
    seed = int(np.random.SeedSequence().entropy % 2**32)  # drawn now; printed on a failure
    bad, seen = _temp_mismatches(fw, _temp_cases(np.random.default_rng(seed)))
    assert all(v > 0 for v in seen.values()), (seed, seen)
    assert bad == 0, f"{bad} rows differ on the S08 (seed {seed})"


# each: a wrong partial product, a lost carry or sign correction, a wrong
# scale; (pattern, replacement) in corr_temp_s08.c, the pattern unique
TEMP_MUTANTS = {
    "Q1*D0 read as Q1*D1": ("    lda     *(_ct_q + 1)        ; Q1 * D0, at bytes 1..2\n    ldx     *_ct_d\n",
                            "    lda     *(_ct_q + 1)        ; Q1 * D0, at bytes 1..2\n    ldx     *(_ct_d + 1)\n"),
    "lowest product of F dropped": ("    stx     *_ct_q\n", "    clr     *_ct_q\n"),
    "no correction for dT < 0 in ah dT": ("    lda     *_ct_d              ; dT < 0: P -= ah 2^16\n    bpl     19$\n",
                                          "    lda     *_ct_d              ; dT < 0: P -= ah 2^16\n    bra     19$\n"),
    "4 p: the first shift without its carries": ("    lsl     *(_fx_m_s + 1)      ; 4 p\n    rol     *_fx_m_s\n"
                           "    rol     *___SDCC_hc08_ret2\n    rol     *___SDCC_hc08_ret3\n",
                           "    lsl     *(_fx_m_s + 1)      ; 4 p\n"),
}


@pytest.mark.heavy
def test_temp_check_fails_on_broken_assembly(tmp_path):
    """The comparison above is not vacuous: copies of the tree whose
    corr_temp_s08.c has one partial product, carry, sign correction or
    shift wrong each give mismatches on the same kind of vectors."""
    root = pathlib.Path(s08_toolchain.repo_root())
    cases = _temp_cases(np.random.default_rng(5))[:4]
    objects = {}  # the other sources are the same in every copy: compiled for the first mutant only
    for i, (name, (pat, rep)) in enumerate(TEMP_MUTANTS.items()):
        tree = tmp_path / name.replace(" ", "_").replace("*", "x").replace("<", "lt")
        shutil.copytree(root / "firmware", tree / "firmware")
        src = tree / "firmware" / "port" / "s08" / "corr_temp_s08.c"
        text = src.read_text()
        assert text.count(pat) == 1, f"mutant {name!r}: pattern not found once"
        src.write_text(text.replace(pat, rep))
        b = s08_toolchain.build(tree / "build", root=tree, objects=objects)
        # each image has its own mutant, compiled from its copy, not an object of an earlier one
        assert "corr_temp_s08.c" in b.compiled and (i == 0 or b.compiled == ["corr_temp_s08.c"]), b.compiled
        bad, _ = _temp_mismatches(b, cases)
        assert bad > 0, f"mutant {name!r} passed the bit-exact check"
