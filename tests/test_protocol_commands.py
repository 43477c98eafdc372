"""The firmware's SCI command layer (proto_cmd.c) driven by the host's Python
protocol implementation: answers, negative answers, the retry cache, the
survey stream and the text console.  The application side is a small
recording application written here with cffi callbacks."""
import struct

import pytest

from inclino.link import protocol
from inclino.engines._core import ffi, lib
from inclino.link.protocol import CMD, Identity, SurveyRecord


class App:
    def __init__(self):
        self.sent = bytearray()
        self.calls = []
        self.survey_n = 0
        self.qcref = bytes(24)
        self.sensor_ok = True
        ftypes = dict(ffi.typeof("proto_app_t").fields)

        def cb(_signature, fn):  # the signature is documentation; cffi takes the field type
            return fn

        self._cbs = dict(
            identity=cb("uint8_t(uint8_t *)", self.identity),
            survey=cb("uint8_t(uint8_t *)", self.survey),
            survey_raw=cb("uint8_t(uint8_t *)", self.survey_raw),
            raw=cb("uint8_t(uint8_t *)", self.raw),
            qcref_read=cb("uint8_t(uint8_t *)", self.qcref_read),
            qcref_write=cb("uint8_t(const uint8_t *)", self.qcref_write),
            set_average=cb("uint8_t(uint8_t)", lambda n: 0 if 1 <= n <= 64 else 5),
            cal_read=cb("uint8_t(uint8_t, uint8_t *)", self.cal_read),
            cal_write=cb("uint16_t(const uint8_t *, uint8_t, uint8_t *)", self.cal_write),
            cal_activate=cb("uint8_t(uint8_t, uint32_t, uint8_t *)", self.cal_activate),
            reset=cb("void(void)", lambda: self.calls.append("reset")),
            bootloader=cb("void(void)", lambda: self.calls.append("bootloader")),
            text_identity=cb("void(char *)", self.text_identity),
            text_survey=cb("void(char *)", self.text_survey),
            send=cb("void(const uint8_t *, uint16_t)", self.send),
        )
        self._cbs = {k: ffi.callback(ftypes[k].type, fn) for k, fn in self._cbs.items()}
        self.app = ffi.new("proto_app_t *", self._cbs)
        self.p = ffi.new("proto_t *")
        lib.proto_init(self.p, self.app)
        self.parser = protocol.FrameParser()

    # the application's side
    def identity(self, out):
        ffi.memmove(out, Identity("INCLINO-PROBE", (1, 0, 0), 1, 123456, 0, 7, 0xBEEF, 4, 0).pack(), 34)
        return 0

    def survey(self, out):
        if not self.sensor_ok:
            return 7
        self.survey_n += 1
        rec = SurveyRecord(self.survey_n, 30 << 16, 120 << 16, 45 << 16, 165 << 16, 1 << 27, 50000 << 8,
                           60 << 16, 0, 0, 8)
        ffi.memmove(out, rec.pack(), 36)
        return 0

    def survey_raw(self, out):
        if self.survey(out) != 0:
            return 7
        ffi.memmove(out + 36, protocol.RawRecord(1, -2, 16384 * 64 + 5, 100, -200, 40000, 2512, 8).pack(), 27)
        return 0

    def raw(self, out):
        ffi.memmove(out, protocol.RawRecord(1, -2, 16384 * 64 + 5, 100, -200, 40000, 2512, 8).pack(), 27)
        return 0

    def qcref_read(self, out):
        ffi.memmove(out, self.qcref, 24)
        return 0

    def qcref_write(self, data):
        self.qcref = bytes(ffi.buffer(data, 24))
        return 0

    def cal_read(self, slot, out):
        ffi.memmove(out, bytes([slot, 1]) + struct.pack(">I", 7) + bytes(range(120)), 126)
        return 0

    def cal_write(self, image, force, out):
        self.calls.append(("cal_write", bytes(ffi.buffer(image, 120)), force))
        if bytes(ffi.buffer(image, 4)) != b"ICAL":
            return 9 | (2 << 8)  # E_IMAGE, CALIMG_E_MAGIC
        ffi.memmove(out, struct.pack(">BIH", 1, 8, 0x1234), 7)
        return 0

    def cal_activate(self, slot, seq, out):
        self.calls.append(("activate", slot, seq))
        ffi.memmove(out, struct.pack(">BI", slot, seq), 5)
        return 0

    def text_identity(self, out):
        s = b"INCLINO-PROBE serial 123456\0"
        ffi.memmove(out, s, len(s))

    def text_survey(self, out):
        s = b"INC 30.0000 AZI 120.0000\0"
        ffi.memmove(out, s, len(s))

    def send(self, data, n):
        self.sent += ffi.buffer(data, n)

    # the host's side
    def rx(self, data: bytes):
        lib.proto_rx(self.p, ffi.new("uint8_t[]", data), len(data))

    def events(self):
        ev = self.parser.feed(bytes(self.sent))
        self.sent.clear()
        return ev

    def ask(self, seq, cmd, payload=b""):
        self.rx(protocol.encode_frame(seq, CMD[cmd] if isinstance(cmd, str) else cmd, payload))
        ev = self.events()
        assert len(ev) == 1 and ev[0].kind == "frame", ev
        return ev[0].frame


def test_identify_survey_raw_qcref():
    a = App()
    f = a.ask(1, "IDENTIFY")
    assert f.cmd == 0x81 and f.seq == 1 and Identity.unpack(f.payload).serial == 123456
    f = a.ask(2, "SURVEY")
    assert f.cmd == 0x82 and SurveyRecord.unpack(f.payload).azi == 120 << 16
    f = a.ask(3, "RAW")
    assert protocol.RawRecord.unpack(f.payload).mz == 40000
    f = a.ask(30, "SURVEY_RAW")
    assert f.cmd == 0x88 and SurveyRecord.unpack(f.payload[:36]).t_ms == 2
    assert protocol.RawRecord.unpack(f.payload[36:]).az == 16384 * 64 + 5
    ref = protocol.QCREF.pack(1 << 27, 335544, 50000 << 8, 76800, 60 << 16, 16384)
    assert a.ask(4, "QCREF_WRITE", ref).cmd == 0x87
    assert a.ask(5, "QCREF_READ").payload == ref


@pytest.mark.parametrize("cmd,payload,code", [
    ("SURVEY", b"\x00", 2), ("QCREF_WRITE", bytes(23), 2), ("CAL_READ", b"\x02", 5), ("CAL_WRITE", bytes(120), 2),
    ("STREAM", b"\x00\x00\x00\x01", 5), ("BOOTLOADER", b"BOOX", 5), (0x55, b"", 4),
    ("SET_AVERAGE", b"\x00", 5), ("SET_AVERAGE", b"\x41", 5), ("SET_AVERAGE", b"", 2),
])
def test_negative_answers(cmd, payload, code):
    a = App()
    f = a.ask(9, cmd, payload)
    want_cmd = CMD[cmd] if isinstance(cmd, str) else cmd
    assert f.cmd == protocol.NAK and f.payload[:2] == bytes([want_cmd, code])


def test_image_refusal_carries_the_detail():
    a = App()
    f = a.ask(3, "CAL_WRITE", b"\x00" + b"XXXX" + bytes(116))
    assert f.cmd == protocol.NAK and f.payload == bytes([0x11, 9, 2])


def test_version_and_crc_errors():
    a = App()
    body = bytes([2, 7, 0x01, 0, 0])
    a.rx(b"\xa5" + body + struct.pack(">H", protocol.crc16(body)))
    (ev,) = a.events()
    assert ev.frame.cmd == protocol.NAK and ev.frame.payload == bytes([1, 3])
    bad = bytearray(protocol.encode_frame(8, 0x02))
    bad[-1] ^= 0x40
    a.rx(bytes(bad))
    (ev,) = a.events()
    assert ev.frame.cmd == protocol.NAK and ev.frame.seq == 8 and ev.frame.payload == bytes([2, 1])
    assert a.survey_n == 0


def test_retry_is_answered_from_cache_and_not_executed_twice():
    a = App()
    img = b"ICAL" + bytes(116)
    req = protocol.encode_frame(40, CMD["CAL_WRITE"], b"\x00" + img)
    a.rx(req)
    first = a.events()
    a.rx(req)  # the host lost the answer and retries with the same SEQ
    second = a.events()
    assert first == second and first[0].frame.cmd == 0x91
    assert [c for c in a.calls if c[0] == "cal_write"] == [("cal_write", img, 0)]
    # the same SEQ with other bytes is a new request
    a.rx(protocol.encode_frame(40, CMD["CAL_ACTIVATE"], struct.pack(">BI", 1, 8)))
    assert a.events()[0].frame.cmd == 0x92 and ("activate", 1, 8) in a.calls
    # a corrupt copy of a request does not disturb the cache
    a.rx(protocol.encode_frame(41, CMD["SURVEY"]))
    a.events()
    bad = bytearray(protocol.encode_frame(41, CMD["SURVEY"]))
    bad[3] ^= 1
    a.rx(bytes(bad))
    a.events()
    a.rx(protocol.encode_frame(41, CMD["SURVEY"]))
    assert a.events()[0].frame.cmd == 0x82 and a.survey_n == 1


def test_stream_counts_stops_and_blocks_other_commands():
    a = App()
    assert a.ask(1, "STREAM", struct.pack(">HH", 10, 3)).cmd == 0x83
    assert a.ask(2, "SURVEY").payload[:2] == bytes([2, 6])  # E_BUSY
    frames = []
    for t in range(0, 100):
        lib.proto_tick(a.p, t)
        frames += [e.frame for e in a.events()]
    assert [f.cmd for f in frames] == [0x70] * 3
    assert [SurveyRecord.unpack(f.payload).t_ms for f in frames] == [1, 2, 3]
    assert [f.seq for f in frames] == [0, 1, 2]
    assert a.ask(3, "SURVEY").cmd == 0x82  # the stream ended by itself
    assert a.ask(4, "STREAM", struct.pack(">HH", 5, 0)).cmd == 0x83
    for t in range(1000, 1050):
        lib.proto_tick(a.p, t)
    n = len([e for e in a.events() if e.frame.cmd == 0x70])
    assert n == 10
    f = a.ask(5, "STOP")
    assert struct.unpack(">H", f.payload)[0] == 10
    lib.proto_tick(a.p, 5000)
    assert a.events() == []


def test_stream_stops_when_a_sensor_fails():
    a = App()
    a.ask(1, "STREAM", struct.pack(">HH", 1, 0))
    lib.proto_tick(a.p, 0)
    a.sensor_ok = False
    lib.proto_tick(a.p, 1)
    assert len(a.events()) == 1
    assert a.ask(2, "SURVEY").payload[:2] == bytes([2, 7])  # not busy any more: the sensor error


def test_text_console_and_reset_after_answer():
    a = App()
    a.rx(b"id\r\n")
    assert bytes(a.sent) == b"INCLINO-PROBE serial 123456\r\n"
    a.sent.clear()
    a.rx(b"SV\r")
    assert bytes(a.sent).startswith(b"INC 30.0000")
    a.sent.clear()
    a.rx(b"reboot\n")
    assert bytes(a.sent) == b"? HELP lists the commands\r\n"
    a.sent.clear()
    a.rx(protocol.encode_frame(1, CMD["RESET"]) + protocol.encode_frame(2, CMD["SURVEY"]))
    ev = a.events()
    assert [e.frame.cmd for e in ev] == [0xA0] and a.calls == ["reset"]  # bytes after a reset are lost
