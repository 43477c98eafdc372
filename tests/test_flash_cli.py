"""`inclino flash --port P IMAGE.s19` as the technician runs it: a separate
process on the emulated probe's pseudo-terminal.  Exit statuses: 0 flashed
and verified, 2 bad image (nothing erased, nothing sent), 4 port or probe
problem; every error one line, never a traceback; a progress bar on a
terminal."""
import fcntl
import json
import os
import re
import select
import struct
import subprocess
import sys
import termios
import time
import zlib

import pytest

from bootimg import decode_descriptor, expected_ranges, random_chunks, write_srec
from inclino_emu.runner import Emulator


@pytest.fixture
def emu():
    e = Emulator("ideal", control_port=0, realtime=False).start()
    yield e
    e.stop()


def run(*args, **kw):
    return subprocess.run([sys.executable, "-m", "inclino", "flash", *args], capture_output=True, text=True,
                          timeout=120, **kw)


def test_flash_prints_every_range_and_exits_0(emu, tmp_path):
    chunks = random_chunks(7, [(0x7C0000, 700), (0x700100, 40)])
    img = write_srec(tmp_path / "app.s19", chunks, entry=0x7C0000)
    r = run("--port", emu.path, img)
    assert r.returncode == 0, r.stderr
    # no terminal: no bar, a progress line at the start and the end of each phase
    assert "Traceback" not in r.stderr
    assert [ln.split(":")[1].strip() for ln in r.stderr.splitlines()] == [
        f"flash {p}" for p in ("erase", "erase", "program", "program", "verify", "verify")]
    rows = [ln for ln in r.stdout.splitlines() if re.match(r"0x[0-9A-F]{6}-0x", ln)]
    want = expected_ranges(chunks)
    assert len(rows) == 2
    for ln, (a, d) in zip(rows, want):
        assert ln.startswith(f"0x{a:06X}") and ln.split()[2] == ln.split()[3] == f"{zlib.crc32(d):08X}"
        assert ln.endswith("pass")
    assert r.stdout.splitlines()[-1].startswith("flashed and verified: 740 bytes in 2 range(s)")
    assert "application running" in r.stdout
    with emu._lock:
        assert decode_descriptor(emu.probe.flash)["ranges"] == [(a, len(d), zlib.crc32(d)) for a, d in want]
        assert emu.probe.mode == "app"


def test_flash_json(emu, tmp_path):
    chunks = random_chunks(8, [(0x7E0000, 64)])
    r = run("--port", emu.path, "--json", "--no-run", write_srec(tmp_path / "a.s19", chunks))
    assert r.returncode == 0, r.stderr
    d = json.loads(r.stdout)
    assert d["ok"] is True and d["committed"] is True and d["app_running"] is False
    assert d["ranges"] == [{"address": "0x7E0000", "length": 64, "crc_expected": f"{zlib.crc32(chunks[0][1]):08X}",
                            "crc_probe": f"{zlib.crc32(chunks[0][1]):08X}", "readback_ok": True, "passed": True}]
    assert d["serial"] == emu.probe.scenario.serial and d["bytes_on_wire"] > 64
    with emu._lock:
        assert emu.probe.mode == "boot"   # --no-run: left in the bootloader, with a valid application


def _bad_checksum(tmp_path):
    p = write_srec(tmp_path / "ok.s19", random_chunks(1, [(0x7C0000, 64)]))
    lines = open(p).read().splitlines()
    lines[2] = lines[2][:-2] + ("00" if lines[2][-2:] != "00" else "01")
    (tmp_path / "bad.s19").write_text("\n".join(lines) + "\n")
    return str(tmp_path / "bad.s19")


@pytest.mark.parametrize("make, message", [
    (_bad_checksum, r"line 3: bad S-record: expected crc"),
    (lambda t: write_srec(t / "s1.s19", random_chunks(1, [(0xC000, 32)]), address_bits=16),
     r"0x00C000-0x00C01F are outside the P-Flash"),
    (lambda t: write_srec(t / "v.s19", random_chunks(1, [(0x7C0000, 32), (0x7FFF80, 128)])),
     r"0x7FFF80-0x7FFFFF are inside the bootloader \(protected"),
    (lambda t: write_srec(t / "c.s19", random_chunks(1, [(0x7A0400, 120)])),
     r"inside the probe's data sectors"),
    (lambda t: str(t / "missing.s19"), r"no such file"),
    (lambda t: (t / "bin.s19").write_bytes(b"\x00\xff\xfe") and str(t / "bin.s19"), r"not an S-record file"),
])
def test_refused_image_exits_2_and_nothing_is_touched(emu, tmp_path, make, message):
    img = make(tmp_path)
    with emu._lock:
        mem0, ops0 = bytes(emu.probe.flash.mem), emu.probe.flash.ops
        sent0 = emu.pty.bytes_to_probe
    r = run("--port", emu.path, img)
    assert r.returncode == 2, (r.stdout, r.stderr)
    assert r.stdout == "" and r.stderr.count("\n") == 1 and "Traceback" not in r.stderr
    assert r.stderr.startswith("inclino: error: ") and re.search(message, r.stderr), r.stderr
    time.sleep(0.05)
    with emu._lock:
        assert bytes(emu.probe.flash.mem) == mem0 and emu.probe.flash.ops == ops0
        assert emu.pty.bytes_to_probe == sent0 and emu.probe.mode == "app"


def test_missing_port_and_silent_port_exit_4(tmp_path):
    img = write_srec(tmp_path / "a.s19", random_chunks(1, [(0x7C0000, 16)]))
    r = run("--port", str(tmp_path / "no-such-port"), img)
    assert r.returncode == 4 and r.stderr.count("\n") == 1 and "cannot open port" in r.stderr, r.stderr
    master, slave = os.openpty()      # a line with nothing behind it
    try:
        r = run("--port", os.ttyname(slave), "--timeout", "0.1", img)
    finally:
        os.close(master)
        os.close(slave)
    assert r.returncode == 4 and r.stderr.count("\n") == 1 and "no answer from the probe" in r.stderr, r.stderr


def test_progress_bar_on_a_terminal(emu, tmp_path):
    img = write_srec(tmp_path / "a.s19", random_chunks(3, [(0x7C0000, 3000)]))
    master, slave = os.openpty()
    fcntl.ioctl(slave, termios.TIOCSWINSZ, struct.pack("HHHH", 24, 100, 0, 0))  # a terminal's size
    proc = subprocess.Popen([sys.executable, "-m", "inclino", "flash", "--port", emu.path, img],
                            stdout=subprocess.PIPE, stderr=slave, text=True)
    os.close(slave)
    err = b""
    try:
        while True:
            r, _, _ = select.select([master], [], [], 60)
            if not r:
                break
            try:
                chunk = os.read(master, 4096)
            except OSError:
                break
            if not chunk:
                break
            err += chunk
    finally:
        out, _ = proc.communicate(timeout=60)
        os.close(master)
    assert proc.returncode == 0, err
    text = err.decode(errors="replace")
    for phase in ("erase", "program", "verify"):
        assert phase in text
    assert "100%" in text and "Traceback" not in text
    assert "flashed and verified" in out
