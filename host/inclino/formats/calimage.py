"""The calibration image (firmware/include/inclino/calimg.h) on the host:
pack a FixedCal into the 120 bytes the probe stores, and unpack/check them.

The CRC is CRC-16/CCITT-FALSE, which Python's binascii.crc_hqx(data, 0xFFFF)
computes; the firmware's crc16_update is checked against it in the tests."""
from __future__ import annotations

import binascii
import struct
from dataclasses import dataclass

from inclino.engines.firmware import FixedCal
from inclino.errors import CalibrationError

MAGIC = 0x4943414C
VERSION = 1
SIZE = 120
CRC_OFFSET = 116
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
        body = _HEAD.pack(MAGIC, VERSION, SIZE, self.serial, self.time, METHODS[self.method])
        body += _COEF.pack(*c.acc_m, *c.acc_b, *c.mag_m, *c.mag_b)
        return body + struct.pack(">H", binascii.crc_hqx(body, 0xFFFF)) + b"\xff\xff"

    @staticmethod
    def unpack(data: bytes) -> "CalImage":
        """Check and decode, in the firmware's order; CalibrationError names
        the first defect."""
        if len(data) < SIZE or struct.unpack_from(">H", data, 6)[0] != SIZE:
            raise CalibrationError("calibration image has the wrong length")
        magic, ver, _, serial, t, method = _HEAD.unpack_from(data)
        if magic != MAGIC:
            raise CalibrationError("not a calibration image (bad magic)")
        if ver != VERSION:
            raise CalibrationError(f"calibration image format {ver} is not {VERSION}")
        if binascii.crc_hqx(data[:CRC_OFFSET], 0xFFFF) != struct.unpack_from(">H", data, CRC_OFFSET)[0]:
            raise CalibrationError("calibration image CRC mismatch")
        v = _COEF.unpack_from(data, _HEAD.size)
        cal = FixedCal(tuple(v[0:9]), tuple(v[9:12]), tuple(v[12:21]), tuple(v[21:24]))
        for m, b in ((cal.acc_m, cal.acc_b), (cal.mag_m, cal.mag_b)):
            if any(abs(x) >= BIAS_LIMIT for x in b) or any(m[4 * i] < DIAG_MIN for i in range(3)):
                raise CalibrationError("calibration image coefficient out of range")
        names = {v: k for k, v in METHODS.items()}
        return CalImage(cal, serial, t, names.get(method, f"method-{method}"))
