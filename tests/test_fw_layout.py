"""Firmware layout rules that keep one copy of each thing: big-endian fields
only through be_bytes.h (firmware/STYLE.md), one identity-record reader, one
CRC-32, one transmit queue, one command dispatch."""
from __future__ import annotations

import re
from pathlib import Path

ROOT = Path(__file__).resolve().parents[1]
SRC = ROOT / "firmware" / "src"

# a byte of a buffer shifted into a wider value, or a wider value's byte
# stored into a buffer: a big-endian field assembled by hand
_READ = re.compile(r"\(\s*\(\s*uint(?:16|32)_t\s*\)\s*\w+\s*\[[^\]]*\]\s*<<\s*(?:8|16|24)\s*\)")
_WRITE = re.compile(r"\w+\s*\[[^\]]*\]\s*=\s*\(\s*uint8_t\s*\)\s*\(?[^;]*>>\s*(?:8|16|24)")


def hand_assembled(code: str) -> list[str]:
    return [m.group(0) for m in (*_READ.finditer(code), *_WRITE.finditer(code))]


# crc16.c shifts each data byte into the CRC register (the algorithm, not a
# field).  proto_frame.c's encoder writes LEN and CRC by hand because it is
# in the S08 image: SDCC emits every static inline function of be_bytes.h
# into each module that includes it (+589 bytes of S08 code for the two
# fields, `inclino bench mcu --json`: sizes.per_module.proto_frame).
EXEMPT = {"crc16.c", "proto_frame.c"}


def test_no_hand_assembled_big_endian_field_in_firmware_src():
    bad = {p.name: hand_assembled(p.read_text()) for p in SRC.glob("*.c") if p.name not in EXEMPT}
    assert {k: v for k, v in bad.items() if v} == {}


def test_the_check_catches_the_old_forms():
    # the forms probe.c and calstore.c used before be_bytes.h
    assert hand_assembled("x = (uint16_t)(((uint16_t)b[14] << 8) | b[15]);")
    assert hand_assembled("buf[8] = (uint8_t)(hw_rev >> 8);")
    assert hand_assembled("if ((((uint16_t)com[0] << 8) | com[1]) != M) {")
    assert not hand_assembled("be_put_u16(buf + 8, hw_rev);")


def _defines(name: str) -> list[str]:
    """Files under firmware/src that define function NAME."""
    pat = re.compile(rf"^\w[\w \*]*\b{name}\s*\([^;]*$", re.M)
    return sorted(p.name for p in SRC.glob("*.c") if pat.search(p.read_text()))


def test_one_copy_each():
    assert _defines("crc32_update") == ["crc32.c"]
    assert _defines("id_record_read") == ["id_record.c"]
    assert _defines("tx_queue_put") == ["tx_queue.c"]
    assert _defines("proto_dispatch") == ["proto_dispatch.c"]
    code = {p.name: p.read_text() for p in SRC.glob("*.c")}
    # nobody else reads the identity record or keeps a CRC-32 table / a ring
    assert [n for n, c in code.items() if "PROBE_ID_ADDR" in c] == ["id_record.c"]
    assert [n for n, c in code.items() if "0xEDB88320" in c] == ["crc32.c"]
    assert [n for n, c in code.items() if "switch (cmd)" in c] == []
