"""The image a flash writes: the MC9S12XEP100 flash map (what the
bootloader reports and refuses to write), and an S-record file (bincopy)
read into the ranges the bootloader takes, with every refusal one DataError
line naming the file and record."""
from __future__ import annotations

import string
import zlib
from dataclasses import dataclass
from typing import Optional

from inclino.errors import DataError

MAX_RANGES = 8  # the bootloader keeps at most this many ranges (boot.h)
NO_ENTRY = 0xFFFFFFFF


@dataclass(frozen=True)
class FlashMap:
    flash_start: int = 0x700000
    flash_end: int = 0x800000            # exclusive
    phrase: int = 8
    sector: int = 1024
    max_data: int = 192                  # data bytes per PROGRAM / READ
    loader: tuple = (0x7FF000, 0x800000)  # the bootloader (protected)
    descriptor: tuple = (0x7FEC00, 0x7FF000)
    data: tuple = (0x7A0000, 0x7A2000)    # identity, calibration, QC reference

    def refused(self):
        return [(*self.loader, "the bootloader (protected)"),
                (*self.descriptor, "the application descriptor (written by the bootloader only)"),
                (*self.data, "the probe's data sectors (identity, calibration, QC reference)")]

    def check(self, start: int, end: int) -> Optional[str]:
        """Why [start, end) may not be written, or None."""
        if start < self.flash_start or end > self.flash_end:
            return (f"outside the P-Flash (0x{self.flash_start:06X}-0x{self.flash_end - 1:06X}); "
                    "S-records must carry global addresses")
        for s, e, name in self.refused():
            if start < e and s < end:
                return f"inside {name}, 0x{s:06X}-0x{e - 1:06X}"
        return None


DEFAULT_MAP = FlashMap()


@dataclass
class Range:
    addr: int
    data: bytes      # phrase-aligned; bytes the file does not give are 0xFF

    @property
    def end(self) -> int:
        return self.addr + len(self.data)

    @property
    def crc(self) -> int:
        return zlib.crc32(self.data) & 0xFFFFFFFF


@dataclass
class Image:
    path: str
    ranges: list
    entry: int
    data_bytes: int   # bytes the records carry

    def to_binfile(self):
        import bincopy

        bf = bincopy.BinFile()
        for r in self.ranges:
            bf.add_binary(r.data, address=r.addr)
        if self.entry != NO_ENTRY:
            bf.execution_start_address = self.entry
        return bf


def _merge(spans: list, fmap: FlashMap) -> list:
    """Merge [start, end, bytearray] spans that share a phrase, then, while
    there are more than MAX_RANGES, the two closest ones that may be joined
    (the gap between them is writable: it becomes 0xFF)."""
    out = []
    for s, e, d in sorted(spans, key=lambda x: x[0]):
        if out and s <= out[-1][1]:
            ps, pe, pd = out[-1]
            ne = max(pe, e)
            nd = pd + b"\xff" * (ne - pe)
            for i, b in enumerate(d):
                if b != 0xFF:
                    nd[s - ps + i] = b
            out[-1] = [ps, ne, nd]
        else:
            out.append([s, e, bytearray(d)])
    while len(out) > MAX_RANGES:
        gaps = [(out[i + 1][0] - out[i][1], i) for i in range(len(out) - 1)
                if fmap.check(out[i][0], out[i + 1][1]) is None]
        if not gaps:
            raise DataError(f"the image needs {len(out)} separate ranges; the bootloader keeps at most "
                            f"{MAX_RANGES}")
        _, i = min(gaps)
        a, b = out[i], out[i + 1]
        out[i:i + 2] = [[a[0], b[1], a[2] + b"\xff" * (b[0] - a[1]) + b[2]]]
    return out


def _srec_fault(line: str, e: Exception) -> str:
    """What is wrong with one S-record line, in the file's own terms (a
    character and its column, a count that disagrees with the length)
    rather than the parser's (bincopy's fromhex error names no character)."""
    body = line[2:]
    bad = next((i for i, c in enumerate(body) if c not in string.hexdigits), None)
    if line[:1] != "S" or len(line) < 2:
        return str(e)
    if bad is not None:
        return f"character {body[bad]!r} at column {bad + 3} is not a hexadecimal digit"
    if len(body) >= 2 and len(body) != 2 + 2 * int(body[:2], 16):
        return (f"{len(body) - 2} hex digits follow its count byte, which says {int(body[:2], 16)} "
                f"bytes ({2 * int(body[:2], 16)} digits)")
    return str(e)


def load_image(path: str, fmap: FlashMap = DEFAULT_MAP) -> Image:
    """Parse and check an S-record file (bincopy).  Raises DataError with one
    clear line; nothing here touches a probe."""
    import bincopy

    try:
        with open(path, "r", encoding="ascii", errors="strict", newline=None) as f:
            lines = f.read().splitlines()
    except FileNotFoundError:
        raise DataError(f"{path}: no such file") from None
    except UnicodeDecodeError:
        raise DataError(f"{path}: not an S-record file (not ASCII text)") from None
    except OSError as e:
        raise DataError(f"{path}: cannot read: {e.strerror}") from None
    bf = bincopy.BinFile()
    records = 0
    for no, line in enumerate(lines, 1):
        line = line.strip()
        if not line:
            continue
        try:
            bf.add_srec(line)
        except bincopy.AddDataError:
            raise DataError(f"{path} line {no}: the record overlaps data given by an earlier record") from None
        except (bincopy.Error, ValueError, IndexError) as e:
            fix = ("the file is damaged or cut short: get the image again" if line[:1] == "S"
                   else "not an S-record file (IMAGE.s19)?")
            raise DataError(f"{path} line {no}: bad S-record: {_srec_fault(line, e)}; {fix} "
                            f"(nothing was erased)") from None
        records += 1
    segs = list(bf.segments)
    if not segs:
        raise DataError(f"{path}: no data records (S1/S2/S3) in {records} records")
    spans, total = [], 0
    for seg in segs:
        lo, hi = seg.minimum_address, seg.maximum_address
        why = fmap.check(lo, hi)
        if why:
            raise DataError(f"{path}: bytes 0x{lo:06X}-0x{hi - 1:06X} are {why}; nothing was erased")
        total += hi - lo
        s = lo - lo % fmap.phrase
        e = -(-hi // fmap.phrase) * fmap.phrase
        d = bytearray(b"\xff" * (e - s))
        d[lo - s:hi - s] = bytes(seg.data)
        spans.append([s, e, d])
    ranges = [Range(s, bytes(d)) for s, e, d in _merge(spans, fmap)]
    for r in ranges:   # phrase padding or gap filling never reaches a refused area
        why = fmap.check(r.addr, r.end)
        if why:
            raise DataError(f"{path}: bytes 0x{r.addr:06X}-0x{r.end - 1:06X} are {why}; nothing was erased")
    entry = bf.execution_start_address
    return Image(path, ranges, NO_ENTRY if entry is None else int(entry) & 0xFFFFFFFF, total)


def check_entry(image: Image, fmap: FlashMap = DEFAULT_MAP) -> None:
    """The image's entry point (the S-record file's start address, S7/S8/S9)
    must be given and lie in bytes the image programs in the application
    area -- never in the bootloader, the descriptor or the data sectors: the
    bootloader jumps there after every reset.  DataError otherwise."""
    e = image.entry
    if e == NO_ENTRY:
        raise DataError(f"{image.path}: no entry point (an S7/S8/S9 start address naming the application's "
                        "start-up code, the file's last record: a file cut short has lost it; get the image "
                        "again, or link it with one); nothing was erased")
    why = fmap.check(e, e + 1)
    if why:
        raise DataError(f"{image.path}: the entry point 0x{e:06X} is {why}; nothing was erased")
    if not any(r.addr <= e < r.end and r.data[e - r.addr] != 0xFF for r in image.ranges):
        raise DataError(f"{image.path}: the entry point 0x{e:06X} is not in the image's code (no record "
                        "programs it); nothing was erased")
