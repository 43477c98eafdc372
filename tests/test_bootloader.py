"""The serial bootloader (firmware/src/boot*.c, docs/bootloader.md) and the
host's flash-and-verify (host/inclino/boot/flashing.py): the C on the emulated
probe directly, then end to end over the emulator's pseudo-terminal --
flash and verify, refusals, a power cut at every single program/erase step
of a flash in each cut mode, and a disconnect in the middle."""
import struct
import threading
import zlib

import pytest

from bootimg import (DATA, DESC, LOADER, decode_descriptor, expected_ranges, random_chunks, snapshot,
                     write_srec)
from inclino.boot import flashing
from inclino.boot import image as boot_image
from inclino.errors import DataError
from inclino.link.serial_link import ProbeError, ProbeLink, ProbeNak
from inclino_emu.control import ControlClient
from inclino_emu.probe import EmulatedProbe, bootloader_placeholder, factory_app_image
from inclino_emu.runner import Emulator

E_ARGUMENT, E_IMAGE, E_STATE, E_PROTECTED = 5, 9, 11, 12


# ---------------------------------------------------------------- the C directly
def test_crc32_is_zlibs():
    p = EmulatedProbe("ideal")
    import random

    rng = random.Random(3)
    for n in (0, 1, 7, 8, 100, 1000):
        d = bytes(rng.randrange(256) for _ in range(n))
        assert p.lib.crc32_update(0, d, n) == zlib.crc32(d)
        assert p.lib.crc32_update(zlib.crc32(b"abc"), d, n) == zlib.crc32(b"abc" + d)
    assert p.lib.crc32_update(0, b"123456789", 9) == 0xCBF43926


def test_flash_map_areas():
    lib = EmulatedProbe("ideal").lib
    APP, OUT, PROT = 0, 1, 2
    cases = [(0x700000, 8, APP), (0x6FFFF8, 8, OUT), (0x7FFFF8, 16, OUT), (0x7C0000, 0, OUT),
             (0x79FFF8, 8, APP), (0x79FFF8, 9, PROT), (0x7A1FF8, 8, PROT), (0x7A2000, 8, APP),
             (0x7FEBF8, 8, APP), (0x7FEBF8, 9, PROT), (0x7FEC00, 8, PROT), (0x7FF000, 8, PROT),
             (0x700000, 0x100000, PROT), (0xFFFFFFF8, 16, OUT)]
    for addr, n, want in cases:
        assert lib.boot_area(addr, n) == want, (hex(addr), n)


def test_fresh_probe_runs_its_factory_application():
    p = EmulatedProbe("ideal")
    assert p.mode == "app"
    d = decode_descriptor(p.flash)
    img = factory_app_image()
    assert d == {"entry": 0x7C0000, "total": len(img), "ranges": [(0x7C0000, len(img), zlib.crc32(img))]}
    assert p.flash.peek(*LOADER[:1], LOADER[1] - LOADER[0]) == bootloader_placeholder()
    assert LOADER in p.flash.protected   # the part's FPROT covers the bootloader


@pytest.mark.parametrize("damage, status", [
    (None, 1),                                   # no application at all
    ((0x7C0000 + 100, b"\x00"), 4),              # one byte of the image changed
    ((DESC + 14, b"\x00"), 2),                   # the header's total changed: header CRC fails
    ((DESC + 0x3F8, b"\x00"), 1),                # commit phrase damaged
])
def test_without_a_valid_application_the_bootloader_runs(damage, status):
    p = EmulatedProbe("ideal", factory_app=damage is not None)
    if damage is not None:
        assert p.mode == "app"
        addr, b = damage
        p.flash.mem[addr - 0x700000] &= b[0]     # program-like damage: ones to zeros
        p.power_cycle()
    assert p.mode == "boot" and p.boot_status == status
    assert decode_descriptor(p.flash) is None


def test_bootloader_request_from_the_application_and_run():
    """BOOTLOADER answered by the application starts the bootloader even with
    a valid application; RUN starts the application again."""
    p = EmulatedProbe("ideal", baud=None)
    p.poll = p.lib.app_main_poll
    seq = [0]

    def ask(cmd, payload=b""):
        from inclino.link import protocol

        seq[0] += 1
        p.sci_push(protocol.encode_frame(seq[0], cmd, payload))
        p.step(0.05)
        ev = protocol.FrameParser().feed(p.sci_pull())
        assert ev and ev[0].kind == "frame"
        return ev[0].frame

    f = ask(0x40)
    assert f.cmd == 0x7F and f.payload[1] == 4          # the application does not know 0x40
    f = ask(0x21, struct.pack(">I", 0x424F4F54))
    assert f.cmd == 0xA1 and p.mode == "boot"
    f = ask(0x40)
    ident = flashing.BootIdentity.unpack(f.payload)
    assert ident.product == "INCLINO-BOOT" and ident.app_status == 0 and ident.serial == p.scenario.serial
    assert f.cmd == 0xC0 and ident.fmap == boot_image.DEFAULT_MAP
    f = ask(0x01)
    assert f.cmd == 0x7F and f.payload[1] == E_STATE    # the application's commands: not here
    f = ask(0x46)
    assert f.cmd == 0xC6 and p.mode == "app"


# ---------------------------------------------------------------- over the pseudo-terminal
@pytest.fixture
def emu():
    e = Emulator("ideal", control_port=0, realtime=False).start()
    yield e
    e.stop()


def _flash_state(emu, ranges):
    with emu._lock:
        f = emu.probe.flash
        return {"desc": decode_descriptor(f), "data": [f.peek(a, len(d)) for a, d in ranges],
                "protected": snapshot(f), "ops": f.ops, "mode": emu.probe.mode}


def test_flash_a_valid_image_and_verify_every_range(emu, tmp_path):
    chunks = random_chunks(1, [(0x700003, 300), (0x7A2000, 1500), (0x7C4010, 77), (0x7FEB00, 256)])
    img = write_srec(tmp_path / "app.s19", chunks, entry=0x7C4010)
    want = expected_ranges(chunks)
    before = _flash_state(emu, want)
    calls = []
    with ProbeLink(emu.path, timeout=0.5) as link:
        r = flashing.flash(link, img, progress=lambda *a: calls.append(a),
                           readback_path=str(tmp_path / "back.s19"))
    assert r.ok and r.committed and r.app_running and r.attempts == 1 and r.retries == 0
    assert [(x.addr, x.length) for x in r.ranges] == [(a, len(d)) for a, d in want]
    for x, (a, d) in zip(r.ranges, want):
        assert x.passed and x.readback_ok and x.crc_probe == x.crc_expected == zlib.crc32(d)
    assert r.bytes_image == sum(len(d) for _, d in chunks)
    assert r.sectors_erased == 1 + 2 + 1 + 1      # 300 B, 1500 B over two sectors, 77 B, 256 B
    after = _flash_state(emu, want)
    assert after["data"] == [d for _, d in want]
    assert after["protected"] == before["protected"]         # bootloader and data untouched
    assert after["desc"] == {"entry": 0x7C4010, "total": sum(len(d) for _, d in want),
                             "ranges": [(a, len(d), zlib.crc32(d)) for a, d in want]}
    assert after["mode"] == "app"
    # the factory image's sector was not in this image: it is still there, not described
    # progress: every phase reached its total, never went back
    for phase in ("erase", "program", "verify"):
        seen = [(d, t) for p, d, t in calls if p == phase]
        assert seen and seen[-1][0] == seen[-1][1] and [d for d, _ in seen] == sorted(d for d, _ in seen)
    j = flashing.FlashResult(**{**r.__dict__}).to_json()
    assert '"passed": true' in j and '"ok": true' in j
    # what was read back, written with bincopy, is the image
    import bincopy

    back = bincopy.BinFile(str(tmp_path / "back.s19"))
    assert [(s.minimum_address, bytes(s.data)) for s in back.segments] == want
    assert back.execution_start_address == 0x7C4010


@pytest.mark.parametrize("layout, why", [
    ([(0x7FF100, 16)], "bootloader"),
    ([(0x7C0000, 16), (0x7FEC00, 8)], "descriptor"),
    ([(0x7A0400, 8)], "data sectors"),
    ([(0x600000, 8)], "outside the P-Flash"),
    ([(0x7FFFF0, 32)], "outside the P-Flash"),
])
def test_refused_images_leave_the_flash_untouched(emu, tmp_path, layout, why):
    img = write_srec(tmp_path / "bad.s19", random_chunks(2, layout))
    with emu._lock:
        mem0, ops0 = bytes(emu.probe.flash.mem), emu.probe.flash.ops
    with ProbeLink(emu.path, timeout=0.5) as link:
        with pytest.raises(DataError, match=why):
            flashing.flash(link, img)
        assert link.stats.bytes_out == 0        # refused before the port was even used
    with emu._lock:
        assert bytes(emu.probe.flash.mem) == mem0 and emu.probe.flash.ops == ops0
        assert emu.probe.mode == "app"


def test_bootloader_refuses_what_the_host_must_not_ask(emu):
    """Defence in depth: the bootloader itself refuses protected, outside and
    misaligned targets, programming over old bits, a COMMIT whose CRCs the
    flash does not hold, RUN without a valid application -- without a
    single flash command -- and runs a retried request only once."""
    with ProbeLink(emu.path, timeout=0.5) as link:
        link.request(0x21, struct.pack(">I", 0x424F4F54))
        ops0 = emu.probe.flash.ops

        def refused(cmd, payload, code):
            with pytest.raises(ProbeNak) as e:
                link.request(cmd, payload)
            assert e.value.code == code, (hex(cmd), payload.hex())

        refused(0x41, struct.pack(">I", 0x7FF000), E_PROTECTED)
        refused(0x41, struct.pack(">I", 0x7FEC00), E_PROTECTED)
        refused(0x41, struct.pack(">I", 0x7A0000), E_PROTECTED)
        refused(0x42, struct.pack(">I", 0x7A1FF8) + bytes(16), E_PROTECTED)
        refused(0x42, struct.pack(">I", 0x7FEBF8) + bytes(16), E_PROTECTED)
        refused(0x41, struct.pack(">I", 0x6FFC00), E_ARGUMENT)
        refused(0x41, struct.pack(">I", 0x7C0200), E_ARGUMENT)     # not a sector start
        refused(0x42, struct.pack(">I", 0x7C0004) + bytes(8), E_ARGUMENT)
        refused(0x42, struct.pack(">I", 0x7C0000) + bytes(7), 2)   # not whole phrases
        refused(0x43, struct.pack(">IH", 0x7FFFF0, 32), E_ARGUMENT)
        assert emu.probe.flash.ops == ops0
        # reading the bootloader is allowed
        p = link.request(0x43, struct.pack(">IH", LOADER[0], 64))
        assert p[4:] == bootloader_placeholder()[:64]
        # programming over the factory image (not erased): refused, nothing changed
        refused(0x42, struct.pack(">I", 0x7C0000) + bytes(8), E_STATE)
        assert emu.probe.flash.peek(0x7C0000, 8) == factory_app_image()[:8]
        # ... but that first change of the application area erased the descriptor first
        assert emu.probe.flash.ops == ops0 + 1 and decode_descriptor(emu.probe.flash) is None
        refused(0x46, b"", E_STATE)                           # nothing valid to run
        img = factory_app_image()
        bad = struct.pack(">IB", 0x7C0000, 1) + struct.pack(">III", 0x7C0000, len(img), zlib.crc32(img) ^ 1)
        refused(0x45, bad, E_IMAGE)
        assert emu.probe.flash.peek(DESC, 1024) == b"\xff" * 1024
        # the right CRCs: committed; the same request again (same SEQ) is not run twice
        good = struct.pack(">IB", 0x7C0000, 1) + struct.pack(">III", 0x7C0000, len(img), zlib.crc32(img))
        ops1 = emu.probe.flash.ops
        seq = link.next_seq()
        from inclino.link import protocol

        frame = protocol.encode_frame(seq, 0x45, good)
        link._write(frame)
        link._write(frame)
        ev = [link._events(__import__("time").monotonic() + 1.0) for _ in range(2)]
        assert all(e.frame.cmd == 0xC5 and e.frame.payload == ev[0].frame.payload for e in ev)
        assert emu.probe.flash.ops - ops1 == 5  # header (32 bytes: 4 phrases) and commit phrase, once
        assert decode_descriptor(emu.probe.flash)["ranges"] == [(0x7C0000, len(img), zlib.crc32(img))]
        link.request(0x46)
        assert link.request(0x01)[:13] == b"INCLINO-PROBE"


def test_bootloader_text_console(emu):
    import serial

    with ProbeLink(emu.path, timeout=0.5) as link:
        link.request(0x21, struct.pack(">I", 0x424F4F54))
    with serial.Serial(emu.path, 115200, timeout=1.0) as s:
        s.write(b"id\r")
        assert s.readline() == f"INCLINO-BOOT bl 1.0 serial {emu.probe.scenario.serial} app valid\r\n".encode()
        s.write(b"SV\r")
        assert s.readline().startswith(b"? bootloader")


@pytest.mark.parametrize("mode", ["random", "none", "full"])
def test_power_cut_at_every_flash_step(emu, tmp_path, mode):
    """Flash images A and B in turn; before flash k the power is cut at its
    k-th program/erase command, for every k until a flash runs through
    without reaching the cut.  After every cut the probe boots -- the
    bootloader, or the old application complete and valid, never anything
    else -- and the host says what happened and that its retry succeeded."""
    ctl = ControlClient(port=emu.control_port)
    p = emu.probe
    imgs, wants = [], []
    for seed in (11, 12):
        chunks = random_chunks(seed, [(0x7C0000, 48), (0x7D0004, 20)])
        imgs.append(write_srec(tmp_path / f"img{seed}.s19", chunks, entry=0x7C0000))
        wants.append(expected_ranges(chunks))
    boots = []
    real_cycle = p.power_cycle

    def spy_cycle():
        st = real_cycle()
        boots.append((p.mode, st, decode_descriptor(p.flash)))
        return st

    p.power_cycle = spy_cycle
    protected0 = snapshot(p.flash)
    link = ProbeLink(emu.path, timeout=0.2)
    assert flashing.flash(link, imgs[0]).ok
    ops_per_flash = None
    k, steps = 0, []
    while True:
        k += 1
        old, new = wants[(k + 1) % 2], wants[k % 2]
        boots.clear()
        with emu._lock:
            ops0 = p.flash.ops
            p.cut_power_at(k, mode)
        r = flashing.flash(link, imgs[k % 2])
        with emu._lock:
            cut = not p.flash.armed      # the k-th command came, and lost power
            if not cut:
                p.flash.disarm()
                ops_per_flash = p.flash.ops - ops0
        state = _flash_state(emu, new)
        assert r.ok and r.app_running and all(x.passed for x in r.ranges), (k, r.events)
        assert state["data"] == [d for _, d in new] and state["mode"] == "app"
        assert state["desc"]["ranges"] == [(a, len(d), zlib.crc32(d)) for a, d in new]
        assert state["protected"] == protected0
        if not cut:
            break
        assert len(boots) == 1, boots
        after_mode, _, desc = boots[0]
        which = None
        if after_mode == "app":       # only a complete application may run: the old, or the new one
            assert desc is not None   # (decode_descriptor checked every range's CRC over the flash)
            which = [name for name, w in (("old", old), ("new", new))
                     if desc["ranges"] == [(a, len(d), zlib.crc32(d)) for a, d in w]]
            assert len(which) == 1, desc
            which = which[0]
        else:
            assert after_mode == "boot"
        text = " ".join(r.events)
        assert r.restarts_detected >= 1 and "restarted" in text, (k, r.events)
        assert r.attempts == 1 and r.retries >= 1 or r.attempts == 2 and r.retry_succeeded \
            and "attempt 2 succeeded" in text, (k, r.events)
        steps.append((k, which or after_mode, r.attempts))
    link.close()
    ctl.close()
    # every step of a whole flash was cut once: descriptor erase, 2 sector erases, 9 data phrases,
    # 6 header phrases and the commit phrase
    assert ops_per_flash == 19 and len(steps) == 19
    # the new application can only come from a cut at the commit phrase, the last command
    assert all(m in ("boot", "old") for _, m, _ in steps[:-1]) and steps[-1][1] in ("boot", "new")
    if mode == "none":   # the descriptor erase undone: the old application runs; the commit undone: none
        assert steps[0][1] == "old" and steps[-1][1] == "boot"
    if mode == "full":   # the descriptor erase done: no application; the commit done: the new one
        assert steps[0][1] == "boot" and steps[-1][1] == "new"


def test_disconnect_in_the_middle(emu, tmp_path):
    ctl = ControlClient(port=emu.control_port)
    chunks = random_chunks(5, [(0x7C0000, 2000), (0x7E0000, 500)])
    img = write_srec(tmp_path / "img.s19", chunks)
    want = expected_ranges(chunks)

    # a short break: the link's retries carry the flash through
    def hiccup(phase, done, total):
        if phase == "program" and not hiccup.done and done >= total // 3:
            hiccup.done = True
            ctl.call("faults", disconnected=True)
            threading.Timer(0.3, lambda: ControlClient(port=emu.control_port).call(
                "faults", disconnected=False)).start()

    hiccup.done = False
    with ProbeLink(emu.path, timeout=0.2, retries=6) as link:
        r = flashing.flash(link, img, progress=hiccup)
    assert hiccup.done and r.ok and r.retries >= 1 and r.attempts == 1
    assert any("sent" in e and "again" in e for e in r.events)

    # a break for good: one clear error, the probe keeps something that boots
    def cut_line(phase, done, total):
        if phase == "program" and done >= total // 2:
            ctl.call("faults", disconnected=True)

    with ProbeLink(emu.path, timeout=0.2, retries=2) as link:
        with pytest.raises(ProbeError) as e:
            flashing.flash(link, img, progress=cut_line)
    msg = str(e.value)
    assert "flash failed" in msg and "no answer" in msg and "run inclino flash again" in msg
    assert "\n" not in msg
    with emu._lock:
        assert emu.probe.mode == "boot" and decode_descriptor(emu.probe.flash) is None
    ctl.call("faults", disconnected=False)
    with ProbeLink(emu.path, timeout=0.5) as link:
        with pytest.raises(ProbeNak) as e:
            link.request(0x46)                 # RUN: no valid application
        assert e.value.code == E_STATE
        r = flashing.flash(link, img)
    assert r.ok and r.app_running
    assert any("no valid application" in e for e in r.events)
    assert _flash_state(emu, want)["data"] == [d for _, d in want]
    ctl.close()


def test_flash_while_the_application_streams(emu, tmp_path):
    """The application refuses everything but STOP while it streams surveys
    (E_BUSY): the host stops the stream, then asks for the bootloader."""
    chunks = random_chunks(9, [(0x7C0000, 100)])
    with ProbeLink(emu.path, timeout=0.5) as link:
        link.request(0x03, struct.pack(">HH", 20, 0))
        r = flashing.flash(link, write_srec(tmp_path / "s.s19", chunks))
    assert r.ok and r.app_running and r.events[0].startswith("the application was streaming surveys")
    assert _flash_state(emu, expected_ranges(chunks))["data"] == [d for _, d in expected_ranges(chunks)]


def test_image_checks_before_the_port(tmp_path):
    """load_image on its own: the merge of records into phrase-aligned ranges
    and the refusals, with no probe at all."""
    img = write_srec(tmp_path / "a.s19", [(0x7C0001, b"\x01\x02"), (0x7C0005, b"\x03"), (0x7C0100, b"\x04")],
                     entry=None)
    im = boot_image.load_image(img)
    assert [(r.addr, r.data) for r in im.ranges] == [
        (0x7C0000, b"\xff\x01\x02\xff\xff\x03\xff\xff"), (0x7C0100, b"\x04" + b"\xff" * 7)]
    assert im.entry == boot_image.NO_ENTRY and im.data_bytes == 4
    # nine records far apart become at most eight ranges, the closest pair merged
    many = [(0x7C0000 + 0x1000 * i, b"\x55" * 8) for i in range(8)] + [(0x7C7010, b"\x66" * 8)]
    im = boot_image.load_image(write_srec(tmp_path / "m.s19", many))
    assert len(im.ranges) == 8 and im.ranges[-1].addr == 0x7C7000 and len(im.ranges[-1].data) == 0x18
    text = (tmp_path / "a.s19").read_text().splitlines()
    text[1] = text[1][:-2] + ("00" if text[1][-2:] != "00" else "01")
    (tmp_path / "c.s19").write_text("\n".join(text) + "\n")
    with pytest.raises(DataError, match=r"line 2: bad S-record"):
        boot_image.load_image(str(tmp_path / "c.s19"))
    (tmp_path / "e.s19").write_text("S0030000FC\nS5030000FC\n")
    with pytest.raises(DataError, match="no data records"):
        boot_image.load_image(str(tmp_path / "e.s19"))
    write_srec(tmp_path / "d1.s19", [(0x7C0000, b"\x01" * 16)])
    (tmp_path / "d.s19").write_text((tmp_path / "d1.s19").read_text() * 2)
    with pytest.raises(DataError, match="overlaps"):
        boot_image.load_image(str(tmp_path / "d.s19"))
    with pytest.raises(DataError, match="outside the P-Flash"):
        boot_image.load_image(write_srec(tmp_path / "s1.s19", [(0xC000, b"\x01" * 4)], address_bits=16))
    with pytest.raises(DataError, match="no such file"):
        boot_image.load_image(str(tmp_path / "none.s19"))
    assert (DATA, DESC) == ((0x7A0000, 0x7A2000), 0x7FEC00)
