"""Static analysis and style of firmware/: cppcheck with the project's
configuration (tools/cppcheck/firmware.cppcheck, S08 data model: 16-bit int)
and clang-format with firmware/.clang-format."""
import shutil
import subprocess
from pathlib import Path

import pytest

ROOT = Path(__file__).resolve().parents[1]
FW = ROOT / "firmware"
PROJECT = ROOT / "tools" / "cppcheck" / "firmware.cppcheck"
CPPCHECK_ARGS = ["--enable=warning,style,performance,portability", "--std=c99",
                 "--error-exitcode=1", "--inline-suppr", "-q"]
GENERATED = {"fx_atan_table.c"}  # layout written by tools/gen_atan_table.py


def _cppcheck():
    return shutil.which("cppcheck") or pytest.skip(
        "cppcheck not found: install the Debian package cppcheck")


def _clang_format():
    return shutil.which("clang-format") or pytest.skip(
        "clang-format not found: install the Debian package clang-format")


def test_cppcheck_clean_over_firmware():
    exe = _cppcheck()
    r = subprocess.run([exe, f"--project={PROJECT}", *CPPCHECK_ARGS], cwd=ROOT,
                       capture_output=True, text=True, timeout=600)
    assert r.returncode == 0 and not r.stderr.strip(), r.stdout + r.stderr


def test_cppcheck_configuration_reports_findings(tmp_path):
    """The same options and platform flag a planted out-of-bounds write and a
    16-bit int overflow: the clean run above is not a configuration that
    checks nothing."""
    exe = _cppcheck()
    bad = tmp_path / "bad.c"
    bad.write_text("#include <stdint.h>\n"
                   "int16_t f(void) { int16_t a[3]; a[3] = 1; return a[0]; }\n")
    r = subprocess.run([exe, f"--platform={PROJECT.parent / 's08-platform.xml'}", *CPPCHECK_ARGS,
                        str(bad)], capture_output=True, text=True, timeout=120)
    assert r.returncode == 1 and "arrayIndexOutOfBounds" in r.stderr, r.stderr


def _fw_c_files():
    files = sorted(list(FW.rglob("*.c")) + list(FW.rglob("*.h")))
    return [p for p in files if p.name not in GENERATED]


def test_clang_format_holds_for_firmware():
    exe = _clang_format()
    files = _fw_c_files()
    assert files
    r = subprocess.run([exe, "--dry-run", "--Werror", "--style=file", *map(str, files)],
                       cwd=ROOT, capture_output=True, text=True, timeout=300)
    assert r.returncode == 0, r.stderr[-4000:]


def test_clang_format_style_is_the_firmware_one(tmp_path):
    """The style file is found and enforced: a misformatted copy of a firmware
    file fails the same check."""
    exe = _clang_format()
    src = FW / "src" / "correct.c"
    style = f"--style=file:{FW / '.clang-format'}"
    good = tmp_path / "good.c"
    bad = tmp_path / "bad.c"
    good.write_text(src.read_text())
    bad.write_text(src.read_text().replace("    ", "  ", 5))
    runs = [subprocess.run([exe, "--dry-run", "--Werror", style, str(p)],
                           capture_output=True, text=True, timeout=60) for p in (good, bad)]
    assert runs[0].returncode == 0, runs[0].stderr
    assert runs[1].returncode != 0
