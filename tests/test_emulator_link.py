"""The emulator's serial pseudo-terminal (byte timing, link faults) and its
JSON-lines control channel, on a loopback device that returns every byte it
receives (the port is under test here, not the probe)."""
import json
import os
import socket
import time

import pytest
import serial

from inclino_emu.control import ControlClient, ControlServer
from inclino_emu.serial_pty import LinkFaults, PtyLink


class Loopback:
    def __init__(self):
        self.buf = bytearray()

    def sci_write(self, data):
        self.buf += data

    def sci_read(self):
        out, self.buf = bytes(self.buf), bytearray()
        return out


def _roundtrip(link, dev, data, dt=0.001, steps=2000):
    with serial.Serial(link.path, 115200, timeout=0) as s:
        s.write(data)
        got = bytearray()
        for _ in range(steps):
            link.pump(dev, dt)
            got += s.read(4096)
            if len(got) >= len(data):
                break
        return bytes(got)


def test_pty_passes_bytes_unchanged_and_keeps_a_symlink(tmp_path):
    lp = str(tmp_path / "probe")
    link = PtyLink(link_path=lp, throttle=False)
    try:
        assert os.path.realpath(lp) == os.path.realpath(link.path)
        data = bytes(range(256)) * 4
        assert _roundtrip(link, Loopback(), data) == data
    finally:
        link.close()
    assert not os.path.exists(lp)


def test_byte_timing_limits_the_rate():
    link = PtyLink(baud=9600, throttle=True)
    dev = Loopback()
    try:
        with serial.Serial(link.path, 9600, timeout=0) as s:
            s.write(bytes(500))
            time.sleep(0.05)
            link.pump(dev, 0.1)  # 0.1 s at 9600 baud: 96 bytes each way
            time.sleep(0.05)
            got = s.read(4096)
        assert link.bytes_to_probe == 96 and len(got) == 96
    finally:
        link.close()


def test_faults_are_applied_at_their_rates():
    f = LinkFaults(bit_error_rate=1e-2, seed=3)
    data = bytes(100_000)
    out = f.apply(data)
    flipped = sum(bin(b).count("1") for b in out)
    assert flipped == f.counts["bit_errors"]
    assert 0.8 * 8000 < flipped < 1.2 * 8000  # 800 000 bits at 1e-2
    g = LinkFaults(drop_rate=0.1, dup_rate=0.05, seed=4)
    out = g.apply(bytes(range(256)) * 100)
    assert len(out) == 25600 - g.counts["dropped"] + g.counts["duplicated"]
    assert 2200 < g.counts["dropped"] < 2900 and 900 < g.counts["duplicated"] < 1500
    assert LinkFaults(disconnected=True).apply(b"abc") == b""


def test_control_channel_json_lines():
    state = {}
    srv = ControlServer({"move": lambda r: state.update(pose=(r["inc"], r["azi"], r["tf"])),
                         "truth": lambda r: {"pose": state.get("pose")}})
    try:
        c = ControlClient(port=srv.port)
        c._sock.sendall(b'{"cmd": "move", "inc": 30, "azi": 120, "tf": 45}\n{"cmd": "truth"}\n')
        answers = []
        buf = b""
        deadline = time.time() + 5
        while len(answers) < 2 and time.time() < deadline:
            srv.poll(0.01)
            c._sock.settimeout(0.01)
            try:
                buf += c._sock.recv(4096)
            except socket.timeout:
                pass
            while b"\n" in buf:
                line, _, buf = buf.partition(b"\n")
                answers.append(json.loads(line))
        assert answers == [{"ok": True}, {"ok": True, "pose": [30, 120, 45]}]
        for bad, err in ((b"{oops\n", "not JSON"), (b'{"cmd": "fly"}\n', "unknown command"),
                         (b'{"cmd": "move", "inc": 1}\n', "bad arguments"), (b"[1,2]\n", "string 'cmd'")):
            c._sock.sendall(bad)
            line = b""
            while not line.endswith(b"\n") and time.time() < deadline:
                srv.poll(0.01)
                try:
                    line += c._sock.recv(4096)
                except socket.timeout:
                    pass
            ans = json.loads(line)
            assert ans["ok"] is False and err in ans["error"]
        c.close()
    finally:
        srv.close()


def test_control_binds_loopback_only():
    srv = ControlServer({})
    try:
        assert srv._srv.getsockname()[0] == "127.0.0.1"
    finally:
        srv.close()
