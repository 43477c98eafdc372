"""The S12X start-up in assembly (firmware/port/s12x/*.s, *.ld) assembled
and linked with Debian's binutils-m68hc1x: the application image goes
through `inclino flash`'s checks and onto the emulated probe; the
bootloader image is refused by them; every linked address is checked
against the flash maps of docs/bootloader.md and docs/flash.md and the
constants of boot.h; FPROT's protected region is the bootloader's 4 KiB;
the vectors point where they must; the bootloader's jump to the
application is executed instruction by instruction from the linked bytes
for entries in each kind of page.

The C of the firmware is not in these links (no S12X C compiler in
Debian): tests/s12x/c_standin.s gives its symbols, and nothing here
checks them."""
import re
import shutil
import struct
import subprocess
from pathlib import Path

import bincopy
import pytest

from inclino import cli
from inclino.boot import image as boot_image
from inclino.errors import DataError

ROOT = Path(__file__).resolve().parents[1]
PORT = ROOT / "firmware" / "port" / "s12x"
AS, LD, OBJCOPY, NM = ("m68hc11-as", "m68hc11-ld", "m68hc11-objcopy", "m68hc11-nm")


def _tools():
    if not all(shutil.which(t) for t in (AS, LD, OBJCOPY, NM)):
        pytest.skip("binutils-m68hc1x not installed (.ci/run installs it)")


def _run(*cmd):
    r = subprocess.run(cmd, capture_output=True, text=True)
    assert r.returncode == 0, f"{' '.join(map(str, cmd))}: {r.stderr}"
    return r.stdout


def _build(d: Path, edit=None) -> dict:
    """Assemble and link both images in d; edit(name, text) -> text may
    change a source first (the planted-error tests)."""
    objs = {}
    for name, src in (("boot_start", PORT / "boot_start.s"), ("app_start", PORT / "app_start.s"),
                      ("c", ROOT / "tests" / "s12x" / "c_standin.s")):
        if edit is not None:
            text = edit(name, src.read_text())
            src = d / src.name
            src.write_text(text)
        objs[name] = d / f"{name}.o"
        _run(AS, "-mm9s12x", f"-I{PORT}", "-o", str(objs[name]), str(src))
    out = {}
    for img, start, ld in (("boot", "boot_start", "boot.ld"), ("app", "app_start", "app.ld")):
        elf, s19 = d / f"{img}.elf", d / f"{img}.s19"
        _run(LD, "-m", "m68hc12elf", "-T", str(PORT / ld), "-o", str(elf), str(objs[start]), str(objs["c"]))
        _run(OBJCOPY, "-O", "srec", str(elf), str(s19))
        syms = {}
        for line in _run(NM, str(elf)).splitlines():
            v, _, name = line.split()
            syms[name] = int(v, 16)
        out[img] = {"s19": str(s19), "bin": bincopy.BinFile(str(s19)), "sym": syms}
    return out


@pytest.fixture(scope="module")
def build(tmp_path_factory):
    _tools()
    return _build(tmp_path_factory.mktemp("s12x"))


def _boot_h(name: str) -> int:
    text = (ROOT / "firmware" / "include" / "inclino" / "boot.h").read_text()
    return int(re.search(rf"#define {name} (0x[0-9A-F]+)UL", text).group(1), 16)


def _doc_rows(doc: str, what: str):
    """[(start, end_exclusive)] of the flash-map rows of docs/<doc> whose
    description starts with `what`."""
    rows = []
    for m in re.finditer(r"^\| (0x[0-9A-F]{6})–(0x[0-9A-F]{6}) \| ([^|]+)\|", (ROOT / "docs" / doc).read_text(), re.M):
        if m.group(3).strip().startswith(what):
            rows.append((int(m.group(1), 16), int(m.group(2), 16) + 1))
    return rows


def _global(local: int) -> int:
    """Local address in the fixed pages 0xFD / 0xFF -> P-Flash global address."""
    assert 0x4000 <= local < 0x8000 or 0xC000 <= local <= 0xFFFF
    return 0x7F0000 + local


def test_application_image_passes_inclino_flash_checks(build):
    app = build["app"]
    im = boot_image.load_image(app["s19"])
    boot_image.check_entry(im)
    assert im.entry == _global(app["sym"]["_app_start"])
    app_rows = _doc_rows("bootloader.md", "application (")
    assert app_rows == [(0x700000, 0x7A0000), (0x7A2000, 0x7FEC00)]
    for seg in app["bin"].segments:
        assert any(s <= seg.minimum_address and seg.maximum_address <= e for s, e in app_rows), hex(seg.minimum_address)
        assert seg.maximum_address <= _boot_h("BOOT_DESC_ADDR")
    # the data sectors of docs/flash.md are never in the image
    data = [(int(a, 16), int(a, 16) + 1024) for a in
            re.findall(r"^\| (0x7A[0-9A-F]{4}) \| 1 sector \|", (ROOT / "docs" / "flash.md").read_text(), re.M)]
    assert len(data) == 5
    assert not any(seg.minimum_address < e and s < seg.maximum_address for seg in app["bin"].segments for s, e in data)
    # block 0 of docs/flash.md holds the fixed pages
    blk0 = re.search(r"0: (0x[0-9A-F]+)–(0x[0-9A-F]+)", (ROOT / "docs" / "flash.md").read_text())
    assert int(blk0.group(1), 16) <= im.entry <= int(blk0.group(2), 16)


def test_application_vectors_are_relocated_below_the_descriptor(build):
    app = build["app"]
    code = app["bin"].as_binary(minimum_address=0x7FC000, maximum_address=0x7FC040)
    ivbr = code[code.index(bytes([0x18, 0x0B])) + 2]               # movb #IVBR, 0x0121
    assert code[code.index(bytes([0x18, 0x0B])) + 3:][:2] == b"\x01\x21"
    base = _global(ivbr << 8)
    assert base + 0x10 >= 0x7FEB00 and base + 0x100 <= _boot_h("BOOT_DESC_ADDR")
    table = app["bin"].as_binary(minimum_address=base + 0x10, maximum_address=base + 0x100)
    vec = {0x10 + 2 * i: struct.unpack(">H", table[2 * i:2 * i + 2])[0] for i in range(120)}
    assert vec[0x7A] == app["sym"]["hal_s12x_pit0_isr"] and vec[0xD6] == app["sym"]["hal_s12x_sci0_isr"]
    others = {v for k, v in vec.items() if k not in (0x7A, 0xD6, 0xFE)}
    assert others == {app["sym"]["_app_unexpected"]}


def test_bootloader_image_is_placed_protected_and_refused_by_flash(build):
    boot = build["boot"]
    lo, hi = _boot_h("BOOT_LOADER_START"), _boot_h("BOOT_LOADER_END")
    assert (lo, hi) == boot_image.DEFAULT_MAP.loader
    assert _doc_rows("bootloader.md", "bootloader") == [(lo, hi)]
    for seg in boot["bin"].segments:
        assert lo <= seg.minimum_address and seg.maximum_address <= hi
    with pytest.raises(DataError, match="inside the bootloader"):
        boot_image.load_image(boot["s19"])
    assert _protected(boot) == [(lo, hi)]
    fsec = boot["bin"].as_binary(minimum_address=0x7FFF0F, maximum_address=0x7FFF10)[0]
    assert fsec & 0x03 == 0x02                         # SEC = 10: unsecured
    assert boot["bin"].execution_start_address == _global(boot["sym"]["_boot_reset"])
    vec = boot["bin"].as_binary(minimum_address=0x7FFFFA, maximum_address=0x800000)
    assert struct.unpack(">HHH", vec) == (boot["sym"]["_boot_reset"],) * 3
    assert boot["sym"]["boot_start_app"] >= 0xF000
    # the BOOTLOADER request word is at the same RAM address in both images, outside what
    # either start-up clears or copies
    app = build["app"]["sym"]
    assert boot["sym"]["boot_request"] == app["boot_request"] == 0x2000
    for s in (boot["sym"], app):
        assert s["__bss_start"] >= 0x2010 and s["__data_start"] >= 0x2010


def _protected(boot) -> list:
    """The P-Flash regions FPROT (0x7FFF0C) protects: [(start, end)]."""
    fprot = boot["bin"].as_binary(minimum_address=0x7FFF0C, maximum_address=0x7FFF0D)[0]
    if not fprot & 0x80:                               # FPOPEN = 0: the regions are the unprotected ones
        return [("inverted", fprot)]
    out = []
    if not fprot & 0x20:                               # FPHDIS = 0: higher region, 2-16 KiB at the top
        out.append((0x800000 - (2048 << ((fprot >> 3) & 3)), 0x800000))
    if not fprot & 0x04:                               # FPLDIS = 0: lower region from 0x7F8000
        out.append((0x7F8000, 0x7F8000 + (2048 << (fprot & 3))))
    return out


def _run_jump(code: bytes, pc0: int, mem: dict) -> tuple:
    """Execute boot_start_app's instructions (only those it uses) from the
    linked bytes; returns (PPAGE written or None, the address it jumps to)."""
    a = b = x = 0
    ppage, pc, z = None, pc0, False
    rd = lambda addr: mem.get(addr, 0xFF)
    for _ in range(40):
        op = code[pc - pc0]
        nxt = code[pc - pc0 + 1: pc - pc0 + 4]
        if op == 0x14 and nxt[0] == 0x10:                       # SEI
            pc += 2
        elif op == 0xFC:                                        # LDD ext
            ad = nxt[0] << 8 | nxt[1]
            a, b = rd(ad), rd(ad + 1)
            pc += 3
        elif op == 0x59:                                        # ASLD
            d = ((a << 8 | b) << 1) & 0xFFFF
            a, b = d >> 8, d & 0xFF
            pc += 1
        elif op == 0xFE:                                        # LDX ext
            ad = nxt[0] << 8 | nxt[1]
            x = rd(ad) << 8 | rd(ad + 1)
            pc += 3
        elif op == 0xB7 and nxt[0] == 0xC5:                     # XGDX
            d = a << 8 | b
            a, b, x = x >> 8, x & 0xFF, d
            pc += 2
        elif op == 0x84:                                        # ANDA imm
            a &= nxt[0]
            pc += 2
        elif op == 0x81:                                        # CMPA imm
            z = a == nxt[0]
            pc += 2
        elif op == 0x27:                                        # BEQ rel8
            pc += 2 + ((nxt[0] ^ 0x80) - 0x80 if z else 0)
        elif op == 0x7A:                                        # STAA ext
            assert (nxt[0] << 8 | nxt[1]) == 0x0015            # PPAGE
            ppage = a
            pc += 3
        elif op == 0x1A and nxt[0] == 0xE2:                     # LEAX n16,X
            x = (x + (nxt[1] << 8 | nxt[2])) & 0xFFFF
            pc += 4
        elif op == 0x05 and nxt[0] == 0x00:                     # JMP 0,X
            return ppage, x
        else:
            raise AssertionError(f"unexpected opcode {op:02X} at {pc:04X}")
    raise AssertionError("no jump")


@pytest.mark.parametrize("entry, ppage, pc", [
    (0x7FC000, None, 0xC000), (0x7FEA12, None, 0xEA12),      # fixed page 0xFF
    (0x7F4123, None, 0x4123),                                 # fixed page 0xFD
    (0x7C0010, 0xF0, 0x8010), (0x7C4010, 0xF1, 0x8010), (0x700008, 0xC0, 0x8008),   # the PPAGE window
    (0x7FBFF8, 0xFE, 0xBFF8), (0x7A2000, 0xE8, 0xA000),
])
def test_bootloader_jumps_to_the_descriptors_entry(build, entry, ppage, pc):
    boot = build["boot"]
    s = boot["sym"]
    start = s["boot_start_app"]
    code = boot["bin"].as_binary(minimum_address=_global(start), maximum_address=_global(start) + 64)
    desc = _boot_h("BOOT_DESC_ADDR") - 0x7F0000                     # the descriptor, local in page 0xFF
    mem = {desc + 8 + i: v for i, v in enumerate(struct.pack(">I", entry))}
    got_page, got_pc = _run_jump(code, start, mem)
    assert (got_page, got_pc) == (ppage, pc)
    # the address reached is the entry: through the window, page * 16 KiB + offset
    page = 0xFF if 0xC000 <= got_pc else 0xFD if got_pc < 0x8000 else got_page
    assert (page << 14 | got_pc & 0x3FFF) == entry & 0x3FFFFF


def test_application_image_flashes_onto_the_emulated_probe(build, capsys):
    from inclino_emu.runner import Emulator
    from bootimg import decode_descriptor

    with Emulator("ideal", control_port=None, realtime=False) as emu:
        rc = cli.main(["flash", "--port", emu.path, build["app"]["s19"]])
        out, err = capsys.readouterr()
        assert rc == 0, err
        assert "flashed and verified" in out and "application running" in out
        with emu._lock:
            d = decode_descriptor(emu.probe.flash)
        assert d["entry"] == _global(build["app"]["sym"]["_app_start"])
        want = boot_image.load_image(build["app"]["s19"])
        assert [(a, n) for a, n, _ in d["ranges"]] == [(r.addr, len(r.data)) for r in want.ranges]


def _movb_writes(code: bytes) -> list:
    """[(register, value, offset)] of every `movb #imm, ext` (18 0B ii hh ll)."""
    out, i = [], 0
    while True:
        i = code.find(b"\x18\x0b", i)
        if i < 0 or i + 5 > len(code):
            return out
        out.append((code[i + 3] << 8 | code[i + 4], code[i + 2], i))
        i += 5


@pytest.mark.parametrize("img, start", [("boot", "_boot_reset"), ("app", "_app_start")])
def test_startup_clocks_the_bus_the_hal_assumes(build, img, start):
    """SYNR, REFDV and POSTDIV as the start-up writes them give the bus
    clock hal_s12x.c computes its SCI, SPI and timer dividers from, with
    the VCO and reference ranges (VCOFRQ, REFFRQ) set for those frequencies;
    the bus switches to the PLL only after LOCK."""
    b = build[img]
    a0 = _global(b["sym"][start])
    code = b["bin"].as_binary(minimum_address=a0, maximum_address=a0 + 0x60)
    w = {reg: (val, off) for reg, val, off in _movb_writes(code)}
    hal = (PORT / "hal_s12x.c").read_text()
    bus = int(re.search(r"#define S12X_BUS_HZ (\d+)UL", hal).group(1))
    osc = int(re.search(r"#define S12X_OSC_HZ (\d+)UL", hal).group(1))
    synr, refdv, postdiv = w[0x34][0], w[0x35][0], w[0x36][0]
    f_ref = osc / ((refdv & 0x3F) + 1)
    f_vco = 2 * f_ref * ((synr & 0x3F) + 1)
    f_pll = f_vco if postdiv & 0x1F == 0 else f_vco / (2 * (postdiv & 0x1F))
    assert f_pll / 2 == bus
    assert (refdv >> 6) == (0 if f_ref <= 2e6 else 1 if f_ref <= 6e6 else 2 if f_ref <= 12e6 else 3)
    assert 32e6 <= f_vco <= 120e6
    assert (synr >> 6) == (0 if f_vco <= 48e6 else 1 if f_vco <= 80e6 else 3)   # 10 is reserved
    lock = code.find(b"\x1f\x00\x37\x08")          # brclr CRGFLG, #LOCK, itself
    assert lock > max(off for off in (w[0x34][1], w[0x35][1], w[0x36][1]))
    assert code[lock + 4] == 0xFB                   # the branch goes back to itself
    assert code.find(b"\x1c\x00\x39\x80") > lock    # bset CLKSEL, #PLLSEL after the lock


def test_the_checks_catch_planted_errors(tmp_path):
    """A copy of the start-up with FPROT protecting 2 KiB, and one whose jump
    keeps a bit of the page in the offset: the checks above fail on them."""
    _tools()
    bad = _build(tmp_path, lambda name, text: text.replace("        .dc.b   0xCF\n", "        .dc.b   0xC7\n")
                 .replace("anda    #0x3F", "anda    #0x7F"))
    assert _protected(bad["boot"]) == [(0x7FF800, 0x800000)] != [(_boot_h("BOOT_LOADER_START"), 0x800000)]
    s = bad["boot"]["sym"]
    code = bad["boot"]["bin"].as_binary(minimum_address=_global(s["boot_start_app"]),
                                        maximum_address=_global(s["boot_start_app"]) + 64)
    mem = {0xEC08 + i: v for i, v in enumerate(struct.pack(">I", 0x7C4010))}
    assert _run_jump(code, s["boot_start_app"], mem) != (0xF1, 0x8010)
