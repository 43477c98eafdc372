"""The SCI framing: the firmware's C parser/encoder and the host's Python ones
against the same byte vectors (tests/vectors/frames.json, built with
binascii.crc_hqx by tools/gen_frame_vectors.py), and against each other on
random and corrupted streams."""
import json
import pathlib

import numpy as np
import pytest

from inclino.link import protocol
from inclino.engines._core import ffi, lib

VECTORS = json.loads((pathlib.Path(__file__).parent / "vectors" / "frames.json").read_text())["cases"]
PF = {1: "frame", 2: "bad_crc", 3: "bad_len", 4: "line"}


def c_events(segments):
    p = ffi.new("proto_parser_t *")
    lib.proto_parser_init(p)
    out = []
    for seg in segments:
        if seg == "idle":
            lib.proto_parser_idle(p)
            continue
        for b in seg:
            r = lib.proto_frame_feed(p, b)
            if r == 0:
                continue
            kind = PF[r]
            if kind == "frame":
                out.append({"kind": kind, "ver": p.ver, "seq": p.seq, "cmd": p.cmd,
                            "payload": bytes(p.payload[0:p.len]).hex()})
            elif kind == "bad_crc":
                out.append({"kind": kind, "seq": p.seq, "cmd": p.cmd})
            elif kind == "line":
                out.append({"kind": kind, "line": ffi.string(ffi.cast("char *", p.line)).decode()})
            else:
                out.append({"kind": kind})
    return out


def py_events(segments):
    parser = protocol.FrameParser()
    out = []
    for seg in segments:
        if seg == "idle":
            parser.idle()
            continue
        for e in parser.feed(seg):
            if e.kind == "frame":
                f = e.frame
                out.append({"kind": "frame", "ver": f.ver, "seq": f.seq, "cmd": f.cmd, "payload": f.payload.hex()})
            elif e.kind == "bad_crc":
                out.append({"kind": "bad_crc", "seq": e.frame.seq, "cmd": e.frame.cmd})
            elif e.kind == "line":
                out.append({"kind": "line", "line": e.line})
            else:
                out.append({"kind": e.kind})
    return out


def _segments(case):
    return [s if s == "idle" else bytes.fromhex(s) for s in case["stream"]]


@pytest.mark.parametrize("case", VECTORS, ids=[c["name"] for c in VECTORS])
def test_vectors_c(case):
    assert c_events(_segments(case)) == case["events"]


@pytest.mark.parametrize("case", VECTORS, ids=[c["name"] for c in VECTORS])
def test_vectors_python(case):
    assert py_events(_segments(case)) == case["events"]


def c_encode(seq, cmd, payload, cap=256):
    out = ffi.new("uint8_t[]", cap)
    n = lib.proto_frame_encode(seq, cmd, ffi.new("uint8_t[]", payload or b"\0"), len(payload), out, cap)
    return bytes(out[0:n])


def test_encoders_agree_with_vectors():
    for case in VECTORS:
        for ev in case["events"]:
            if ev["kind"] != "frame" or ev["ver"] != 1:
                continue
            pl = bytes.fromhex(ev["payload"])
            want = protocol.encode_frame(ev["seq"], ev["cmd"], pl)
            assert c_encode(ev["seq"], ev["cmd"], pl) == want
            assert want.hex() in "".join(s for s in case["stream"] if s != "idle")


def test_encoder_refuses_oversize_and_small_buffer():
    assert c_encode(1, 2, bytes(201), cap=300) == b""
    assert c_encode(1, 2, bytes(10), cap=17) == b""
    with pytest.raises(ValueError):
        protocol.encode_frame(1, 2, bytes(201))


def test_random_corrupted_streams_same_events():
    rng = np.random.default_rng(42)
    for trial in range(300):
        frames = b"".join(protocol.encode_frame(int(s), int(c), rng.integers(0, 256, int(n), dtype=np.uint8).tobytes())
                          for s, c, n in zip(rng.integers(0, 256, 5), rng.integers(0, 256, 5),
                                             rng.integers(0, 60, 5)))
        buf = bytearray(frames)
        for _ in range(int(rng.integers(0, 4))):  # bit errors
            i = int(rng.integers(0, len(buf)))
            buf[i] ^= 1 << int(rng.integers(0, 8))
        if rng.random() < 0.3 and len(buf) > 3:  # a dropped byte
            del buf[int(rng.integers(0, len(buf)))]
        if rng.random() < 0.3:  # a duplicated byte
            i = int(rng.integers(0, len(buf)))
            buf.insert(i, buf[i])
        segs = [bytes(buf[: len(buf) // 2]), "idle", bytes(buf[len(buf) // 2:])] if trial % 3 == 0 else [bytes(buf)]
        c, p = c_events(segs), py_events(segs)
        assert c == p
        # every reported frame is one that was sent (a CRC-16 collision is possible in principle,
        # vanishingly unlikely with these few corruptions)
        for e in c:
            if e["kind"] == "frame":
                assert protocol.encode_frame(e["seq"], e["cmd"], bytes.fromhex(e["payload"])).hex() in frames.hex()


def test_table_crc_equals_bitwise_for_every_byte_and_register(rng):
    """crc16.c's table step against an independent bitwise CRC-16/CCITT
    (binascii.crc_hqx): every byte value from 64 register values, so every
    table entry is reached from many registers, and a few long buffers."""
    import binascii

    regs = [0x0000, 0xFFFF, 0x8000, 0x00FF] + [int(x) for x in rng.integers(0, 1 << 16, 60)]
    one = ffi.new("uint8_t[1]")
    for r in regs:
        for b in range(256):
            one[0] = b
            assert lib.crc16_update(r, one, 1) == binascii.crc_hqx(bytes([b]), r), (r, b)
    for n in (2, 255, 256, 1000):
        d = rng.integers(0, 256, n, dtype=np.uint8).tobytes()
        r = int(rng.integers(0, 1 << 16))
        assert lib.crc16_update(r, ffi.new("uint8_t[]", d), n) == binascii.crc_hqx(d, r)


def test_survey_record_units_are_the_documented_fixed_point_formats():
    """docs/protocol.md's survey record: t in ms, inclination, azimuth, both
    toolfaces and dip i32 Q16 degrees, G total i32 Q27 g, B total Q8 nT;
    to_units divides by exactly those; a payload one byte short or long is
    refused (never read by position)."""
    rec = protocol.SurveyRecord(t_ms=123456, inc=int(30.5 * 65536), azi=int(-12.25 * 65536), gtf=int(270.0 * 65536),
                                mtf=int(1.0 * 65536) + 1, gt=int(1.001 * 2**27), bt=48123 * 256 + 128,
                                dip=int(-64.5 * 65536), flags=5, qc=3, count=16)
    u = protocol.SurveyRecord.unpack(rec.pack()).to_units()
    assert u == {"t_s": 123.456, "inc_deg": 30.5, "azi_deg": -12.25, "tf_deg": 270.0, "mtf_deg": 1.0 + 2**-16,
                 "gt_g": int(1.001 * 2**27) / 2**27, "bt_nT": 48123.5, "dip_deg": -64.5, "flags": 5, "qc": 3}
    data = rec.pack()
    for bad in (data[:-1], data + b"\x00"):
        with pytest.raises(ValueError, match="survey record of"):
            protocol.SurveyRecord.unpack(bad)


def test_raw_record_counts_are_the_q6_means():
    """RawRecord's readings are Q6 counts (acquire.h acq_avg_q6): the
    fractional counts are value / 64; the whole-count record of older
    firmware is scaled up to Q6; a record of any other length is refused."""
    r = protocol.RawRecord(ax=64 * 100 + 32, ay=-64 * 3, az=1, mx=-64 * 40000 - 16, my=0, mz=64 * 7, temp_centi_c=2512,
                           count=16, temp_q6=85184)
    back = protocol.RawRecord.unpack(r.pack())
    assert back == r
    assert back.acc_counts == (100.5, -3.0, 1 / 64) and back.mag_counts == (-40000.25, 0.0, 7.0)
    whole = protocol.RawRecord.FMT_WHOLE.pack(100, -3, 1, -400, 0, 7, 2512, 16)
    assert protocol.RawRecord.unpack(whole).acc_counts == (100.0, -3.0, 1.0)
    for bad in (r.pack()[:-1], r.pack() + b"\x00"):
        with pytest.raises(ValueError, match="raw record of"):
            protocol.RawRecord.unpack(bad)
