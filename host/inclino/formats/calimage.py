"""The calibration image (firmware/include/inclino/calimg.h) on the host:
pack a FixedCal into the bytes the probe stores, and unpack/check them.
Version 1 (120 bytes): M and b.  Version 2 (192 bytes): also the
temperature terms (FixedCal.temp; inclino.formats.caltemp), written whenever a
FixedCal has them; both versions unpack.

The CRC is CRC-16/CCITT-FALSE, which Python's binascii.crc_hqx(data, 0xFFFF)
computes; the firmware's crc16_update is checked against it in the tests."""
from __future__ import annotations

import binascii
import struct
from dataclasses import dataclass

from inclino.engines.firmware import FixedCal, FixedTemp
from inclino.errors import CalibrationError

MAGIC = 0x4943414C
VERSION = 2
SIZE = 192
CRC_OFFSET = 188
VERSION_1 = 1
SIZE_V1 = 120
CRC_OFFSET_V1 = 116
SIZES = {VERSION_1: SIZE_V1, VERSION: SIZE}
T_REF_MIN, T_REF_MAX = -40 * 128, 125 * 128  # Q7 degC
_TC = struct.Struct(">3i3h3i3h")  # c1, c2, r1, r2 of one triad
METHODS = {"identity": 0, "ren2014": 1, "li2021": 2, "guo2009": 3, "joint": 4}
_HEAD = struct.Struct(">IHHIIB3x")
_COEF = struct.Struct(">24i")
BIAS_LIMIT = 2**30
DIAG_MIN = 2**27


@dataclass(frozen=True)
class CalImage:
    cal: FixedCal
    serial: int
    time: int
    method: str

    def pack(self) -> bytes:
        if self.method not in METHODS:
            raise CalibrationError(f"unknown calibration method {self.method!r}")
        if not (0 <= self.serial < 2**32 and 0 <= self.time < 2**32):
            raise CalibrationError("probe serial and time must fit 32 bits")
        c = self.cal
        t = c.temp
        if t is None:
            body = _HEAD.pack(MAGIC, VERSION_1, SIZE_V1, self.serial, self.time, METHODS[self.method])
        else:
            body = _HEAD.pack(MAGIC, VERSION, SIZE, self.serial, self.time, METHODS[self.method])
            body = body[:17] + struct.pack(">Bh", t.order, t.t_ref)
        body += _COEF.pack(*c.acc_m, *c.acc_b, *c.mag_m, *c.mag_b)
        if t is not None:
            for tri in ("acc", "mag"):
                body += _TC.pack(*(v for k in ("c1", "c2", "r1", "r2") for v in getattr(t, f"{tri}_{k}")))
        return body + struct.pack(">H", binascii.crc_hqx(body, 0xFFFF)) + b"\xff\xff"

    @staticmethod
    def unpack(data: bytes) -> "CalImage":
        """Check and decode, in the firmware's order; CalibrationError names
        the first defect."""
        n = struct.unpack_from(">H", data, 6)[0] if len(data) >= 8 else 0
        if n not in (SIZE, SIZE_V1) or len(data) < n:
            raise CalibrationError("calibration image has the wrong length")
        magic, ver, _, serial, t, method = _HEAD.unpack_from(data)
        if magic != MAGIC:
            raise CalibrationError("not a calibration image (bad magic)")
        if ver != (VERSION if n == SIZE else VERSION_1):
            raise CalibrationError(f"calibration image format {ver} with {n} bytes is not one this host reads "
                                   f"({VERSION_1}: {SIZE_V1} bytes, {VERSION}: {SIZE} bytes)")
        crc_off = n - 4
        if binascii.crc_hqx(data[:crc_off], 0xFFFF) != struct.unpack_from(">H", data, crc_off)[0]:
            raise CalibrationError("calibration image CRC mismatch")
        v = _COEF.unpack_from(data, _HEAD.size)
        temp = None
        if n == SIZE:
            order, t_ref = struct.unpack_from(">Bh", data, 17)
            tc = [_TC.unpack_from(data, 116 + 36 * i) for i in range(2)]
            kw = {f"{tri}_{k}": tuple(tc[i][3 * j:3 * j + 3]) for i, tri in enumerate(("acc", "mag"))
                  for j, k in enumerate(("c1", "c2", "r1", "r2"))}
            ok = order <= 2 and T_REF_MIN <= t_ref <= T_REF_MAX
            for tri in ("acc", "mag"):
                c1, c2, r1, r2 = (kw[f"{tri}_{k}"] for k in ("c1", "c2", "r1", "r2"))
                ok = ok and max(map(abs, c1 + r1)) <= 2**30 and -(2**15) not in c2 + r2
                ok = ok and not (order < 2 and any(c2 + r2)) and not (order == 0 and any(c1 + r1))
            if not ok:
                raise CalibrationError("calibration image temperature term out of range")
            if order:
                temp = FixedTemp(t_ref=t_ref, order=order, **kw)
        cal = FixedCal(tuple(v[0:9]), tuple(v[9:12]), tuple(v[12:21]), tuple(v[21:24]), temp)
        for m, b in ((cal.acc_m, cal.acc_b), (cal.mag_m, cal.mag_b)):
            if any(abs(x) >= BIAS_LIMIT for x in b) or any(m[4 * i] < DIAG_MIN for i in range(3)):
                raise CalibrationError("calibration image coefficient out of range")
        names = {v: k for k, v in METHODS.items()}
        return CalImage(cal, serial, t, names.get(method, f"method-{method}"))
