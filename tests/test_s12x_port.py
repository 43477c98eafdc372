"""The MC9S12XEP100 port (firmware/port/s12x/) stays valid C: a host
compile with the register header, the strict warning set and -fsyntax-only,
with each HAL function of inclino/hal.h defined there; and the register
addresses it uses are the reference manual's."""
import re
import shutil
import subprocess
from pathlib import Path

import pytest

ROOT = Path(__file__).resolve().parents[1]
PORT = ROOT / "firmware" / "port" / "s12x"
FLAGS = ["-std=c99", "-Wall", "-Wextra", "-Wconversion", "-Wshadow", "-Werror", "-fsyntax-only"]


def _gcc():
    return shutil.which("gcc") or pytest.skip("gcc not found")


def test_port_compiles_clean(tmp_path):
    srcs = sorted(PORT.glob("*.c"))
    assert srcs
    r = subprocess.run([_gcc(), *FLAGS, f"-I{ROOT / 'firmware' / 'include'}", f"-I{PORT}",
                        *map(str, srcs)], capture_output=True, text=True)
    assert r.returncode == 0, r.stderr


def test_syntax_check_catches_a_planted_error(tmp_path):
    """The same compile fails on a broken copy: the check is not vacuous."""
    src = (PORT / "hal_s12x.c").read_text().replace("SPI0DRL = out;", "SPI0DRL = out")
    bad = tmp_path / "hal_bad.c"
    bad.write_text(src)
    r = subprocess.run([_gcc(), *FLAGS, f"-I{ROOT / 'firmware' / 'include'}", f"-I{PORT}", str(bad)],
                       capture_output=True, text=True)
    assert r.returncode != 0


def test_every_hal_function_is_implemented():
    hal = (ROOT / "firmware" / "include" / "inclino" / "hal.h").read_text()
    names = re.findall(r"^\w[\w\s\*]*?\b(hal_\w+)\s*\(", hal, flags=re.M)
    assert len(names) >= 13
    port = (PORT / "hal_s12x.c").read_text()
    for n in names:
        assert re.search(rf"^\w[\w\s\*]*\b{n}\s*\([^;]*\)\s*\{{", port, flags=re.M), n


def test_register_addresses():
    """Addresses of the MC9S12XE register map (SCI0 0xC8, SPI0 0xD8, FTM
    0x100, PIT 0x340), checked against the header."""
    hdr = (PORT / "mc9s12xep100.h").read_text()
    regs = dict(re.findall(r"#define (\w+) REG(?:8|16)\((0x[0-9A-Fa-f]+)u\)", hdr))
    want = {"SCI0BDH": 0xC8, "SCI0CR2": 0xCB, "SCI0SR1": 0xCC, "SCI0DRL": 0xCF, "SPI0CR1": 0xD8,
            "SPI0CR2": 0xD9, "SPI0BR": 0xDA, "SPI0SR": 0xDB, "SPI0DR": 0xDC, "SPI0DRL": 0xDD,
            "FCLKDIV": 0x100, "FCCOBIX": 0x102, "FSTAT": 0x106, "FCCOB": 0x10A, "PPAGE": 0x15,
            "PITCFLMT": 0x340, "PITLD0": 0x348, "PITCNT1": 0x34E}
    for k, v in want.items():
        assert int(regs[k], 16) == v, k
