"""Calibration storage: the flash model's MC9S12XEP100 semantics, the slot
layout as docs/flash.md describes it (decoded here independently), and the
power-cut guarantee -- a cut at every single program or erase step of a
calibration write and activation leaves the probe on the old or the new
calibration, never a mixed or corrupt one, and reporting the right slot."""
import binascii
import struct

import pytest

from inclino.formats.calimage import CalImage
from inclino.engines.firmware import FixedCal, FixedTemp
from inclino_emu import flash as fl
from inclino_emu.probe import (PROBE_CAL_A_ADDR, PROBE_CAL_B_ADDR, PROBE_ID_ADDR, PROBE_QC_A_ADDR,
                               EmulatedProbe)

CALSTORE_E_PAYLOAD, CALSTORE_E_NOT_PENDING = 0x42, 0x46
PROBE_E_SERIAL, PROBE_E_IMAGE = 0x52, 0x54
OPS_PER_CAL = 1 + 1 + 15 + 1          # erase, header, 15 payload phrases, commit (version 1)
OPS_PER_CAL_V2 = 1 + 1 + 24 + 1       # version 2: 24 payload phrases


def image(k, serial=1, method="ren2014", temp=False):
    """A valid, distinct calibration image number k (version 2 with
    temperature terms when temp)."""
    one = 2**29
    acc_m = (one + 1000 * k, 3 * k, -5 * k, 7, one - 2000 * k, 11 * k, -13, 17 * k, one + 300 * k)
    mag_m = (one - 700 * k, -k, 2 * k, 5 * k, one + 900 * k, -3, 4, k, one - 100 * k)
    t = None
    if temp:
        t = FixedTemp(t_ref=25 * 128 + k, order=2, acc_c1=(k, -2 * k, 3), acc_c2=(k, 0, -k),
                      acc_r1=(-k, 5, 7 * k), acc_r2=(2, -k, 3), mag_c1=(11 * k, 13, -k), mag_c2=(-3, k, 1),
                      mag_r1=(k, k, -k), mag_r2=(-1, 2, k))
    cal = FixedCal(acc_m, (k * 12345, -k * 999, 4242), mag_m, (k * 1024 * 150, -k * 1024 * 40, 77), t)
    return CalImage(cal, serial, 1_700_000_000 + k, method).pack()


def ops_per_cal(img):
    return 3 + len(img) // 8


def expected_active(img):
    c = CalImage.unpack(img).cal
    t = c.temp
    temp = (0, 0) + ([0, 0, 0],) * 8 if t is None else (t.order, t.t_ref) + tuple(
        list(getattr(t, f"{tri}_{k}")) for tri in ("acc", "mag") for k in ("c1", "c2", "r1", "r2"))
    return (list(c.acc_m), list(c.acc_b), list(c.mag_m), list(c.mag_b)) + temp


def active(p):
    return tuple(p.active_cal()) + p.active_temp()


IDENTITY = expected_active(CalImage(FixedCal.identity(), 0, 0, "identity").pack())


def decode_slot(flash, base, plen=120):
    """The slot layout of docs/flash.md, decoded without the firmware."""
    raw = flash.peek(base, 16 + plen)
    magic, seq = struct.unpack_from(">II", raw, 0)
    payload = raw[8:8 + plen]
    cmagic, crc, cseq = struct.unpack_from(">HHI", raw, 8 + plen)
    ok = (magic == 0x49534C54 and cmagic == 0x434D and cseq == seq
          and crc == binascii.crc_hqx(raw[:8 + plen], 0xFFFF))
    return ok, seq, payload


# ---- the flash model ---------------------------------------------------------
def test_flash_erased_program_erase():
    f = fl.S12XFlash()
    a = 0x7A0400
    assert f.read(a, 8) == b"\xff" * 8
    assert f.program(a, b"\x01\x02\x03\x04\x05\x06\x07\x08") == 0
    assert f.read(a, 8) == bytes(range(1, 9))
    assert f.erase(a + 104) == 0                  # any phrase address inside the sector
    assert f.read(a, 1024) == b"\xff" * 1024
    assert f.ops == 2


def test_flash_misaligned_and_outside_fail_with_accerr_and_change_nothing():
    f = fl.S12XFlash()
    before = f.peek(0x7A0400, 32)
    assert f.program(0x7A0404, b"\0" * 8) == fl.ACCERR
    assert f.program(0x6FFFF8, b"\0" * 8) == fl.ACCERR
    assert f.program(0x7FFFFC, b"\0" * 8) == fl.ACCERR
    assert f.erase(0x800000) == fl.ACCERR
    assert f.peek(0x7A0400, 32) == before


def test_flash_program_on_non_erased_phrase_fails_like_the_part():
    f = fl.S12XFlash()
    a = 0x7A0800
    assert f.program(a, bytes([0xF0] * 8)) == 0
    st = f.program(a, bytes([0x0F] * 8))
    assert st & fl.MGSTAT1 and st & fl.MGSTAT0
    assert f.peek(a, 8) == bytes([0x00] * 8)      # cells hold old AND new
    assert f.program(a, bytes([0x00] * 8)) == 0   # the very same data again: nothing changes
    st = f.program(a + 8, bytes([0x12] * 8))
    assert st == 0


def test_flash_protection_fpviol():
    f = fl.S12XFlash(protected=[(0x7F8000, 0x800000)])
    assert f.program(0x7F8000, b"\0" * 8) == fl.FPVIOL
    assert f.erase(0x7FFC00) == fl.FPVIOL
    assert f.peek(0x7F8000, 8) == b"\xff" * 8


@pytest.mark.parametrize("mode", ["none", "full", "random"])
def test_flash_power_cut_modes(mode):
    f = fl.S12XFlash(seed=5)
    a = 0x7A0400
    f.cut_power_at(2, mode)
    assert f.program(a, b"\x00" * 8) == 0
    assert f.program(a + 8, b"\x00" * 8) is None  # power lost during this one
    got = f.peek(a + 8, 8)
    if mode == "none":
        assert got == b"\xff" * 8
    elif mode == "full":
        assert got == b"\x00" * 8
    else:
        assert got != b"\x00" * 8 or got != b"\xff" * 8
    assert f.program(a + 16, b"\x00" * 8) is None and f.read(a, 8) is None
    assert f.peek(a + 16, 8) == b"\xff" * 8       # nothing after the cut
    f.restore_power()
    assert f.read(a, 8) == b"\x00" * 8


def test_flash_partial_erase_leaves_a_mix():
    f = fl.S12XFlash(seed=11)
    a = 0x7A0400
    for o in range(0, 1024, 8):
        f.program(a + o, b"\x00" * 8)
    f.cut_power_at(1, "random")
    assert f.erase(a) is None
    cells = f.peek(a, 1024)
    assert cells != b"\xff" * 1024 and cells != b"\x00" * 1024


# ---- the slot layout and the firmware's storage --------------------------------
def test_write_activate_layout_and_identity():
    p = EmulatedProbe("ideal")
    img = image(1)
    assert p.identity()["cal_slot"] == "none"
    ops0 = p.flash.ops
    assert p.cal_write(img).status == 0
    assert p.flash.ops - ops0 == OPS_PER_CAL - 1
    ok, seq, payload = decode_slot(p.flash, PROBE_CAL_A_ADDR)
    assert not ok and payload == img               # written, not committed
    assert p.identity()["cal_slot"] == "none"      # not in use before activation
    assert p.cal_activate().status == 0
    assert p.flash.ops - ops0 == OPS_PER_CAL
    ok, seq, payload = decode_slot(p.flash, PROBE_CAL_A_ADDR)
    assert ok and seq == 1 and payload == img
    ident = p.identity()
    assert (ident["cal_slot"], ident["cal_seq"]) == ("A", 1)
    assert ident["cal_crc"] == struct.unpack_from(">H", img, 116)[0]
    assert ident["cal_time"] == 1_700_000_001 and ident["cal_method"] == 1
    assert active(p) == expected_active(img)
    assert p.cal_read("active") == (0, img) and p.cal_read("A") == (0, img)
    # the next one goes to B with the next sequence; A stays untouched
    img2 = image(2)
    assert p.cal_write(img2).status == 0 and p.cal_activate().status == 0
    assert decode_slot(p.flash, PROBE_CAL_B_ADDR)[:2] == (True, 2)
    assert decode_slot(p.flash, PROBE_CAL_A_ADDR) == (True, 1, img)
    assert p.identity()["cal_slot"] == "B"
    # and it survives a power cycle
    p.power_cycle()
    assert (p.identity()["cal_slot"], p.identity()["cal_seq"]) == ("B", 2)
    assert active(p) == expected_active(img2)
    # the third goes back to A
    assert p.cal_write(image(3)).status == 0 and p.cal_activate().status == 0
    assert decode_slot(p.flash, PROBE_CAL_A_ADDR)[:2] == (True, 3)


def test_version_2_slot_and_version_1_beside_it():
    """A version 2 image (temperature terms) takes a 192-byte slot; a version
    1 image keeps its 120-byte slot beside it; each loads after a power
    cycle with its own terms (none for version 1) and reads back as sent."""
    p = EmulatedProbe("ideal")
    v1, v2 = image(1), image(2, temp=True)
    assert len(v1) == 120 and len(v2) == 192
    assert p.cal_write(v1).status == 0 and p.cal_activate().status == 0
    ops0 = p.flash.ops
    assert p.cal_write(v2).status == 0 and p.cal_activate().status == 0
    assert p.flash.ops - ops0 == OPS_PER_CAL_V2
    assert decode_slot(p.flash, PROBE_CAL_B_ADDR, 192) == (True, 2, v2)
    assert decode_slot(p.flash, PROBE_CAL_A_ADDR) == (True, 1, v1)
    p.power_cycle()
    ident = p.identity()
    assert (ident["cal_slot"], ident["cal_seq"]) == ("B", 2)
    assert ident["cal_crc"] == struct.unpack_from(">H", v2, 188)[0]
    assert active(p) == expected_active(v2) and p.active_temp()[0] == 2
    assert p.cal_read("active") == (0, v2) and p.cal_read("A") == (0, v1)
    # back to a version 1 image: no terms
    assert p.cal_write(image(3)).status == 0 and p.cal_activate().status == 0
    p.power_cycle()
    assert p.identity()["cal_slot"] == "A" and active(p) == expected_active(image(3))
    assert p.active_temp()[0] == 0


def test_refused_images_write_nothing():
    p = EmulatedProbe("ideal")                    # probe serial 1
    ops = p.flash.ops
    bad_crc = bytearray(image(1))
    bad_crc[30] ^= 1
    assert p.cal_write(bytes(bad_crc)).status == PROBE_E_IMAGE
    zero_diag = bytearray(image(1))
    struct.pack_into(">i", zero_diag, 20, 0)       # acc M[0,0] = 0: out of range
    struct.pack_into(">H", zero_diag, 116, binascii.crc_hqx(bytes(zero_diag[:116]), 0xFFFF))
    assert p.cal_write(bytes(zero_diag)).status == PROBE_E_IMAGE
    assert p.cal_write(image(1, serial=77)).status == PROBE_E_SERIAL
    assert p.flash.ops == ops
    assert p.cal_activate().status == CALSTORE_E_NOT_PENDING
    assert p.cal_write(image(1, serial=77), force=True).status == 0
    assert p.cal_activate().status == 0
    assert p.identity()["cal_serial"] == 77


def test_boot_takes_the_newest_valid_slot_and_falls_back():
    p = EmulatedProbe("ideal")
    for k in (1, 2):
        assert p.cal_write(image(k)).status == 0 and p.cal_activate().status == 0
    assert p.identity()["cal_slot"] == "B"
    # corrupt one payload byte of the newer slot: the older one is used
    cell = p.flash.peek(PROBE_CAL_B_ADDR + 8 + 40, 1)
    p.flash.load(PROBE_CAL_B_ADDR + 8 + 40, bytes([cell[0] ^ 0x04]))
    p.power_cycle()
    assert (p.identity()["cal_slot"], p.identity()["cal_seq"]) == ("A", 1)
    assert active(p) == expected_active(image(1))
    # corrupt the commit record of the older one too: identity, slot none
    p.flash.load(PROBE_CAL_A_ADDR + 8 + 120, b"\x00")
    p.power_cycle()
    assert p.identity()["cal_slot"] == "none" and p.identity()["cal_crc"] == 0
    assert active(p) == IDENTITY
    assert p.cal_read("active")[0] == 0x53
    # a new write goes to A (none active) with sequence 1 and works
    assert p.cal_write(image(5)).status == 0 and p.cal_activate().status == 0
    assert (p.identity()["cal_slot"], p.identity()["cal_seq"]) == ("A", 1)


def test_pending_write_is_lost_by_a_restart():
    p = EmulatedProbe("ideal")
    assert p.cal_write(image(1)).status == 0
    p.power_cycle()
    assert p.cal_activate().status == CALSTORE_E_NOT_PENDING
    assert p.identity()["cal_slot"] == "none"


def test_flash_failure_is_a_status():
    """The target sector is protected: the write reports the flash error
    and the old calibration stays."""
    p = EmulatedProbe("ideal")
    assert p.cal_write(image(1)).status == 0 and p.cal_activate().status == 0
    p.flash.protected.append((PROBE_CAL_B_ADDR, PROBE_CAL_B_ADDR + 1024))
    assert p.cal_write(image(2)).status == 0x43
    assert p.identity()["cal_slot"] == "A"


# ---- power cuts at every step ------------------------------------------------
def _base_flash(with_old: bool):
    p = EmulatedProbe("ideal")
    if with_old:
        assert p.cal_write(image(1)).status == 0 and p.cal_activate().status == 0
    return p.flash


def _run_cut(base, n, mode, seed, new):
    f = fl.S12XFlash(seed=seed)
    f.mem[:] = base.mem
    p = EmulatedProbe("ideal", flash=f)
    before = p.identity()
    p.cut_power_at(n, mode)
    r = p.cal_write(new)
    cut = r.power_cut
    if not cut:
        assert r.status == 0
        r = p.cal_activate()
        cut = r.power_cut
    assert cut and p.power_cuts == 1 and not p.flash.armed
    return p, before


@pytest.mark.parametrize("new_temp", [False, True], ids=["v1", "v2"])
@pytest.mark.parametrize("with_old", [True, False], ids=["over-old", "first"])
@pytest.mark.parametrize("mode", ["random", "none", "full"])
def test_power_cut_at_every_flash_step_never_mixes(with_old, mode, new_temp):
    """Over a version 1 image (the v2 case: the first download of
    temperature terms onto a probe calibrated before them)."""
    base = _base_flash(with_old)
    old = image(1) if with_old else None
    new = image(2, temp=new_temp)
    OPS_PER_CAL = ops_per_cal(new)
    outcomes = []
    for n in range(1, OPS_PER_CAL + 1):
        for seed in ((n, 1, 2) if mode == "random" else (n,)):
            p, before = _run_cut(base, n, mode, seed, new)
            ident = p.identity()
            got = active(p)
            if got == expected_active(new):
                assert (ident["cal_slot"], ident["cal_seq"]) == (("B", 2) if with_old else ("A", 1))
                assert p.cal_read("active") == (0, new)
                outcomes.append("new")
            elif with_old:
                assert got == expected_active(old), f"mixed calibration after a cut at step {n}"
                assert (ident["cal_slot"], ident["cal_seq"]) == ("A", 1)
                assert p.cal_read("active") == (0, old)
                assert decode_slot(p.flash, PROBE_CAL_A_ADDR) == (True, 1, old)
                outcomes.append("old")
            else:
                assert got == IDENTITY, f"corrupt calibration after a cut at step {n}"
                assert ident["cal_slot"] == "none"
                outcomes.append("identity")
            # only the commit (the last step) may bring the new calibration in
            if n < OPS_PER_CAL:
                assert outcomes[-1] != "new"
            # and the probe recovers: a retry succeeds and activates the new one
            if n in (1, OPS_PER_CAL - 1, OPS_PER_CAL):
                assert p.cal_write(new).status == 0 and p.cal_activate().status == 0
                assert active(p) == expected_active(new)
    if mode == "full":
        assert outcomes[-1] == "new"
    if mode == "none":
        assert "new" not in outcomes


def test_repeated_generations_with_random_cuts():
    """Many writes A, B, A, ... each cut at a random step or not: after each,
    the probe runs the last successfully activated image."""
    import random
    rng = random.Random(2024)
    p = EmulatedProbe("ideal", flash_seed=9)
    current = None
    for k in range(1, 25):
        img = image(k)
        cut_at = rng.randint(1, OPS_PER_CAL + 6)
        if cut_at <= OPS_PER_CAL:
            p.cut_power_at(cut_at, "random")
        r = p.cal_write(img)
        if not r.power_cut and r.status == 0:
            r = p.cal_activate()
            if not r.power_cut and r.status == 0:
                current = img
        p.flash.disarm()
        if r.power_cut and cut_at == OPS_PER_CAL and active(p) == expected_active(img):
            current = img                           # the commit landed before the power went
        want = IDENTITY if current is None else expected_active(current)
        assert active(p) == want, k


# ---- the QC reference record ---------------------------------------------------
def test_qc_reference_persists_and_drives_the_verdict():
    p = EmulatedProbe("ideal")
    p.move_to(45.0, 30.0, 0.0)
    s = p.survey()
    assert s["status"] == 0 and s["qc"] == 0x80   # no reference: only G checked, flagged
    assert p.qc_get()[0] == 0x53
    ref = (2**27, 335544, 50000 * 256, 300 * 256, 60 * 65536, 16384)
    assert p.qc_set(*ref).status == 0
    assert decode_slot(p.flash, PROBE_QC_A_ADDR, 24)[0]
    assert p.survey()["qc"] == 0
    p.power_cycle()
    assert p.qc_get() == (0, ref) and p.identity()["qc_slot"] == "A"
    assert p.qc_set(2**27, 335544, 49000 * 256, 300 * 256, 60 * 65536, 16384).status == 0
    assert p.survey()["qc"] == 0x02                # B total off by 1000 nT
    assert p.identity()["qc_slot"] == "B"
    assert p.qc_set(2**27, -1, 0, 0, 0, 0).status == 0x51


def test_identity_record():
    p = EmulatedProbe("typical")
    assert p.identity()["serial"] == 1001
    rec = p.flash.peek(PROBE_ID_ADDR, 16)
    assert rec[:4] == b"INID" and struct.unpack_from(">I", rec, 4)[0] == 1001
    assert struct.unpack_from(">H", rec, 14)[0] == binascii.crc_hqx(rec[:14], 0xFFFF)
    q = EmulatedProbe("typical", serial=0)
    assert q.identity()["serial"] == 0


def test_power_cut_at_every_step_of_a_qc_reference_write():
    base = EmulatedProbe("ideal")
    old = (2**27, 335544, 50000 * 256, 76800, 60 * 65536, 16384)
    new = (2**27, 335544, 48000 * 256, 76800, 58 * 65536, 16384)
    assert base.qc_set(*old).status == 0
    snapshot = bytes(base.flash.mem)
    seen = set()
    for n in range(1, 1 + 1 + 3 + 1 + 1):          # erase, header, 3 payload phrases, commit
        for seed in (n, 100 + n):
            f = fl.S12XFlash(seed=seed)
            f.mem[:] = snapshot
            p = EmulatedProbe("ideal", flash=f)
            p.cut_power_at(n, "random")
            r = p.qc_set(*new)
            assert r.power_cut
            st, got = p.qc_get()
            assert st == 0 and got in (old, new), n
            assert p.identity()["qc_slot"] == ("A" if got == old else "B")
            seen.add(got)
    assert old in seen
