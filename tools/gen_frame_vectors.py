#!/usr/bin/env python3
"""Write tests/vectors/frames.json: byte streams for the SCI framing and the
events a correct parser reports for them (docs/protocol.md).

The frames are built here with struct and binascii.crc_hqx, not with either
implementation under test (firmware/src/proto_frame.c, host/inclino/link/protocol.py).
A stream is a list of segments: hex bytes, or "idle" (20 ms of silence).
Run from the repository root: python3 tools/gen_frame_vectors.py
"""
import binascii
import json
import pathlib
import struct


def frame(seq, cmd, payload=b"", ver=1, crc_xor=0, len_override=None):
    n = len(payload) if len_override is None else len_override
    body = bytes([ver, seq, cmd]) + struct.pack(">H", n) + payload
    return bytes([0xA5]) + body + struct.pack(">H", binascii.crc_hqx(body, 0xFFFF) ^ crc_xor)


def ev_frame(seq, cmd, payload=b"", ver=1):
    return {"kind": "frame", "ver": ver, "seq": seq, "cmd": cmd, "payload": payload.hex()}


def ev_bad_crc(seq, cmd):
    return {"kind": "bad_crc", "seq": seq, "cmd": cmd}


survey = bytes(range(36))
big = bytes((7 * i) & 0xFF for i in range(200))
cases = []


def case(name, segments, events):
    cases.append({"name": name, "stream": [s if s == "idle" else s.hex() for s in segments], "events": events})


case("identify, empty payload", [frame(1, 0x01)], [ev_frame(1, 0x01)])
case("survey answer, 36 bytes", [frame(200, 0x82, survey)], [ev_frame(200, 0x82, survey)])
case("largest payload, 200 bytes", [frame(9, 0x11, big)], [ev_frame(9, 0x11, big)])
case("payload containing 0xA5 and CR LF", [frame(3, 0x07, b"\xa5\x0d\x0a\xa5")],
     [ev_frame(3, 0x07, b"\xa5\x0d\x0a\xa5")])
case("other protocol version is still a frame", [frame(4, 0x01, ver=2)], [ev_frame(4, 0x01, ver=2)])
case("length 201 is refused", [frame(5, 0x11, b"", len_override=201)[:6]], [{"kind": "bad_len"}])
case("one bit of the CRC flipped", [frame(6, 0x02, b"", crc_xor=0x0001)], [ev_bad_crc(6, 0x02)])
case("one payload byte flipped",
     [frame(7, 0x07, b"\x00\x01\x02\x03")[:7] + b"\x09" + frame(7, 0x07, b"\x00\x01\x02\x03")[8:]],
     [ev_bad_crc(7, 0x07)])
case("binary noise before a frame", [b"\x00\xff\x81\x13\x7f", frame(8, 0x01)], [ev_frame(8, 0x01)])
case("two frames back to back", [frame(10, 0x01) + frame(11, 0x02)], [ev_frame(10, 0x01), ev_frame(11, 0x02)])
case("text line", [b"ID\r"], [{"kind": "line", "line": "ID"}])
case("CR LF ends one line, empty lines are nothing", [b"\r\nsv\r\n\r\n"], [{"kind": "line", "line": "sv"}])
case("text line cut at 32 characters", [b"A" * 40 + b"\n"], [{"kind": "line", "line": "A" * 32}])
case("a frame ends a partial text line", [b"SV" + frame(12, 0x01) + b"\r"], [ev_frame(12, 0x01)])
case("text after a frame", [frame(13, 0x01) + b"HELP\n"], [ev_frame(13, 0x01), {"kind": "line", "line": "HELP"}])
case("noise 0xA5 swallows a frame, silence recovers, the retry gets through",
     [b"\xa5\x01\x00\x00\x00\x20" + frame(14, 0x01), "idle", frame(14, 0x01)],
     [ev_frame(14, 0x01)])
case("silence inside a frame drops it", [frame(15, 0x02, survey)[:20], "idle", frame(16, 0x01)],
     [ev_frame(16, 0x01)])

out = pathlib.Path(__file__).resolve().parent.parent / "tests" / "vectors" / "frames.json"
out.write_text(json.dumps({"format": "docs/protocol.md frames, version 1", "cases": cases}, indent=1) + "\n")
print(f"wrote {out} ({len(cases)} cases)")
