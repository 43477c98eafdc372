"""Helpers of the bootloader and flash tests (not a test module): S-record
images written with bincopy, an independent decoder of the application
descriptor as docs/bootloader.md lays it out, and the flash areas a
firmware update must never touch."""
from __future__ import annotations

import random
import struct
import zlib

import bincopy

DESC = 0x7FEC00
COMMIT_OFF = 0x3F8
LOADER = (0x7FF000, 0x800000)
DATA = (0x7A0000, 0x7A2000)


def write_srec(path, chunks, entry="code", address_bits=24) -> str:
    """chunks: [(address, bytes)]; returns the path.  entry: the start
    address (S7/S8/S9); "code" (default): the first byte of the chunks, in
    address order, that is not 0xFF (inclino flash wants an entry point in
    the image's code); None: no start address."""
    if entry == "code":
        entry = next((a + i for a, d in sorted(chunks) for i, b in enumerate(d) if b != 0xFF), None)
    bf = bincopy.BinFile()
    for addr, data in chunks:
        bf.add_binary(bytes(data), address=addr)
    if entry is not None:
        bf.execution_start_address = entry
    with open(path, "w", encoding="ascii") as f:
        f.write(bf.as_srec(number_of_data_bytes=32, address_length_bits=address_bits))
    return str(path)


def random_chunks(seed, layout):
    """layout: [(address, length)] -> [(address, random bytes)]."""
    rng = random.Random(seed)
    return [(a, bytes(rng.randrange(256) for _ in range(n))) for a, n in layout]


def expected_ranges(chunks, phrase=8):
    """The phrase-aligned ranges the flash must hold for these chunks (one
    range per chunk here: the tests keep chunks phrases apart), 0xFF padding."""
    out = []
    for a, d in sorted(chunks):
        s = a - a % phrase
        e = -(-(a + len(d)) // phrase) * phrase
        buf = bytearray(b"\xff" * (e - s))
        buf[a - s:a - s + len(d)] = d
        out.append((s, bytes(buf)))
    return out


def decode_descriptor(flash):
    """The application descriptor in `flash` (an S12XFlash), checked the way
    the documentation says: commit phrase, header CRC-32, then each range's
    CRC-32 over the flash.  Returns {entry, total, ranges: [(addr, len, crc)]}
    or None when no valid application is described."""
    commit = flash.peek(DESC + COMMIT_OFF, 8)
    magic, ccrc = struct.unpack(">4sI", commit)
    if magic != b"ICMT":
        return None
    head = flash.peek(DESC, 16)
    m, ver, n, pad, entry, total = struct.unpack(">4sBBHII", head)
    if m != b"IAPP" or ver != 1 or not 1 <= n <= 8 or pad != 0xFFFF:
        return None
    body = flash.peek(DESC, 16 + 12 * n + 4)
    if zlib.crc32(body[:-4]) != struct.unpack(">I", body[-4:])[0] or ccrc != zlib.crc32(body[:-4]):
        return None
    ranges = [struct.unpack(">III", body[16 + 12 * i:28 + 12 * i]) for i in range(n)]
    if sum(r[1] for r in ranges) != total:
        return None
    for a, ln, crc in ranges:
        if zlib.crc32(flash.peek(a, ln)) != crc:
            return None
    return {"entry": entry, "total": total, "ranges": ranges}


def snapshot(flash, areas=(LOADER, DATA)) -> list:
    return [flash.peek(s, e - s) for s, e in areas]
