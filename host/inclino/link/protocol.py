"""The probe's serial protocol on the host (docs/protocol.md): frames, the
byte-wise parser, and the payload records.  The firmware's C implementation
(firmware/src/proto_frame.c) is checked against the same byte vectors."""
from __future__ import annotations

import binascii
import struct
from dataclasses import asdict, dataclass

SOF = 0xA5
VERSION = 1
MAX_PAYLOAD = 200
OVERHEAD = 8
LINE_MAX = 32

NAK = 0x7F
STREAM_FRAME = 0x70
CMD = {
    "IDENTIFY": 0x01, "SURVEY": 0x02, "STREAM": 0x03, "STOP": 0x04, "RAW": 0x05,
    "QCREF_READ": 0x06, "QCREF_WRITE": 0x07, "SURVEY_RAW": 0x08, "SET_AVERAGE": 0x09, "CAL_READ": 0x10, "CAL_WRITE": 0x11,
    "CAL_ACTIVATE": 0x12, "RESET": 0x20, "BOOTLOADER": 0x21,
}
# the bootloader's commands (docs/protocol.md, "Bootloader"), named in the link's errors
BOOT_CMD = {"B_IDENTIFY": 0x40, "B_ERASE": 0x41, "B_PROGRAM": 0x42, "B_READ": 0x43, "B_CRC": 0x44,
            "B_COMMIT": 0x45, "B_RUN": 0x46}
CMD_NAMES = {code: name for name, code in {**CMD, **BOOT_CMD}.items()}
ERRORS = {
    1: "E_CRC", 2: "E_LENGTH", 3: "E_VERSION", 4: "E_COMMAND", 5: "E_ARGUMENT", 6: "E_BUSY",
    7: "E_SENSOR", 8: "E_FLASH", 9: "E_IMAGE", 10: "E_SERIAL", 11: "E_STATE",
    12: "E_PROTECTED",
}
BOOT_KEY = 0x424F4F54


def crc16(data: bytes) -> int:
    """CRC-16/CCITT-FALSE (poly 0x1021, init 0xFFFF)."""
    return binascii.crc_hqx(data, 0xFFFF)


def encode_frame(seq: int, cmd: int, payload: bytes = b"") -> bytes:
    if len(payload) > MAX_PAYLOAD:
        raise ValueError(f"payload of {len(payload)} bytes exceeds {MAX_PAYLOAD}")
    body = bytes([VERSION, seq & 0xFF, cmd & 0xFF]) + struct.pack(">H", len(payload)) + payload
    return bytes([SOF]) + body + struct.pack(">H", crc16(body))


@dataclass(frozen=True)
class Frame:
    ver: int
    seq: int
    cmd: int
    payload: bytes


@dataclass(frozen=True)
class Event:
    """One parser event: kind is 'frame', 'bad_crc', 'bad_len' or 'line'."""

    kind: str
    frame: Frame | None = None
    line: str = ""


class FrameParser:
    """Byte-wise parser with the firmware's semantics (proto_frame_feed)."""

    def __init__(self) -> None:
        self.reset()

    def reset(self) -> None:
        self._state = "idle"
        self._hdr = bytearray()
        self._payload = bytearray()
        self._len = 0
        self._line = bytearray()

    def idle(self) -> bool:
        """The line went silent: drop an incomplete frame (PROTO_IDLE_MS)."""
        dropped = self._state != "idle"
        self._state = "idle"
        return dropped

    @property
    def in_frame(self) -> bool:
        return self._state != "idle"

    def feed(self, data: bytes) -> list[Event]:
        out = []
        for b in data:
            ev = self._byte(b)
            if ev is not None:
                out.append(ev)
        return out

    def _byte(self, b: int) -> Event | None:
        st = self._state
        if st == "idle":
            if b == SOF:
                self._state, self._hdr, self._line = "hdr", bytearray(), bytearray()
            elif b in (0x0D, 0x0A):
                if self._line:
                    line, self._line = self._line.decode("ascii"), bytearray()
                    return Event("line", line=line)
            elif 0x20 <= b <= 0x7E and len(self._line) < LINE_MAX:
                self._line.append(b)
            return None
        if st == "hdr":
            self._hdr.append(b)
            if len(self._hdr) == 5:
                self._len = struct.unpack(">H", self._hdr[3:5])[0]
                if self._len > MAX_PAYLOAD:
                    self._state = "idle"
                    return Event("bad_len")
                self._payload = bytearray()
                self._state = "payload" if self._len else "crc"
                self._crc = bytearray()
            return None
        if st == "payload":
            self._payload.append(b)
            if len(self._payload) == self._len:
                self._state, self._crc = "crc", bytearray()
            return None
        self._crc.append(b)  # st == "crc"
        if len(self._crc) < 2:
            return None
        self._state = "idle"
        body = bytes(self._hdr) + bytes(self._payload)
        f = Frame(self._hdr[0], self._hdr[1], self._hdr[2], bytes(self._payload))
        if struct.unpack(">H", self._crc)[0] != crc16(body):
            return Event("bad_crc", frame=f)
        return Event("frame", frame=f)


# ------------------------------------------------------------------ records
Q16 = 65536.0


@dataclass
class SurveyRecord:
    t_ms: int
    inc: int
    azi: int
    gtf: int
    mtf: int
    gt: int
    bt: int
    dip: int
    flags: int
    qc: int
    count: int

    FMT = struct.Struct(">I7iHBB")

    def pack(self) -> bytes:
        return self.FMT.pack(self.t_ms, self.inc, self.azi, self.gtf, self.mtf, self.gt, self.bt,
                             self.dip, self.flags, self.qc, self.count)

    @classmethod
    def unpack(cls, data: bytes) -> "SurveyRecord":
        if len(data) != cls.FMT.size:
            raise ValueError(f"survey record of {len(data)} bytes, expected {cls.FMT.size}")
        return cls(*cls.FMT.unpack(data))

    def to_units(self) -> dict:
        return {"t_s": self.t_ms / 1000.0, "inc_deg": self.inc / Q16, "azi_deg": self.azi / Q16,
                "tf_deg": self.gtf / Q16, "mtf_deg": self.mtf / Q16, "gt_g": self.gt / 2**27,
                "bt_nT": self.bt / 256.0, "dip_deg": self.dip / Q16, "flags": self.flags, "qc": self.qc}


@dataclass
class RawRecord:
    """The acquisition's means as the correction sees them: ax..mz in Q6
    counts (FRAC_BITS fraction bits: 64 per ADIS16210 count of 2^-14 g, 64
    per fluxgate count of 1 nT; acquire.h acq_avg_q6).  `unpack` also reads
    the 21-byte record of firmware that sent whole counts (i16 acc), whose
    values it scales to Q6."""
    ax: int
    ay: int
    az: int
    mx: int
    my: int
    mz: int
    temp_centi_c: int
    count: int
    temp_q6: int | None = None  # TEMP_OUT mean, Q6 counts (what the temperature terms use); None: older firmware

    FRAC_BITS = 6
    FMT = struct.Struct(">3i3ihBi")
    FMT_V1 = struct.Struct(">3i3ihB")     # before the temperature at the firmware's resolution
    FMT_WHOLE = struct.Struct(">3h3ihB")  # before the Q6 readings

    def pack(self) -> bytes:
        v = list(asdict(self).values())
        if self.temp_q6 is None:
            return self.FMT_V1.pack(*v[:-1])
        return self.FMT.pack(*v)

    @classmethod
    def unpack(cls, data: bytes) -> "RawRecord":
        if len(data) == cls.FMT_WHOLE.size:
            v = list(cls.FMT_WHOLE.unpack(data))
            return cls(*[x << cls.FRAC_BITS for x in v[:6]], *v[6:])
        if len(data) == cls.FMT_V1.size:
            return cls(*cls.FMT_V1.unpack(data))
        if len(data) != cls.FMT.size:
            raise ValueError(f"raw record of {len(data)} bytes, expected {cls.FMT.size}")
        return cls(*cls.FMT.unpack(data))

    @property
    def acc_counts(self) -> tuple:
        """The accelerometer means in (fractional) counts."""
        return tuple(v / (1 << self.FRAC_BITS) for v in (self.ax, self.ay, self.az))

    @property
    def mag_counts(self) -> tuple:
        """The fluxgate means in (fractional) counts."""
        return tuple(v / (1 << self.FRAC_BITS) for v in (self.mx, self.my, self.mz))


@dataclass
class Identity:
    product: str
    fw_version: tuple
    proto_version: int
    serial: int
    cal_slot: int
    cal_sequence: int
    cal_crc: int
    cal_method: int
    selftest: int

    FMT = struct.Struct(">16s3BBIBIHBH")

    def pack(self) -> bytes:
        return self.FMT.pack(self.product.encode("ascii"), *self.fw_version, self.proto_version, self.serial,
                             self.cal_slot, self.cal_sequence, self.cal_crc, self.cal_method, self.selftest)

    @classmethod
    def unpack(cls, data: bytes) -> "Identity":
        if len(data) != cls.FMT.size:
            raise ValueError(f"identity record of {len(data)} bytes, expected {cls.FMT.size}")
        v = cls.FMT.unpack(data)
        return cls(v[0].rstrip(b"\0").decode("ascii", "replace"), tuple(v[1:4]), *v[4:])


QCREF = struct.Struct(">6i")

# The answer payload lengths of each application command (docs/protocol.md,
# "Commands"): a set of lengths, or a (min, max) range.  Any other length of
# a valid frame is a link error, never a record read by position.
_RAW_SIZES = {RawRecord.FMT.size, RawRecord.FMT_V1.size, RawRecord.FMT_WHOLE.size}
ANSWER_SIZES = {
    "IDENTIFY": {Identity.FMT.size},
    "SURVEY": {SurveyRecord.FMT.size},
    "RAW": _RAW_SIZES,
    "SURVEY_RAW": {SurveyRecord.FMT.size + n for n in _RAW_SIZES},
    "QCREF_READ": {QCREF.size},
    "QCREF_WRITE": {0},
    "SET_AVERAGE": {1},
    "STREAM": {0},
    "STOP": {2},
    "RESET": {0},
    "BOOTLOADER": {0},
    "CAL_READ": (6, MAX_PAYLOAD),
    "CAL_WRITE": {7},
    "CAL_ACTIVATE": {5},
}
