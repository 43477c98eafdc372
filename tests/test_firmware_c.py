"""The C unit tests (CMake target test_core) under AddressSanitizer and
UndefinedBehaviorSanitizer, the strict warning set, and the firmware rules
that a compiler does not check: no floating point, no heap, no recursion."""
import os
import pathlib
import re
import shutil
import subprocess
import sys

import pytest

ROOT = pathlib.Path(__file__).resolve().parents[1]
FW = ROOT / "firmware"


def _cmake():
    exe = shutil.which("cmake", path=os.pathsep.join([str(pathlib.Path(sys.executable).parent),
                                                      os.environ.get("PATH", "")]))
    if exe is None:
        pytest.skip("cmake not found (pip install cmake, or the Debian package cmake)")
    return exe


def test_c_unit_tests_under_sanitizers(tmp_path):
    cmake = _cmake()
    b = tmp_path / "build"
    subprocess.run([cmake, "-S", str(ROOT), "-B", str(b), "-DINCLINO_SANITIZE=ON",
                    "-DCMAKE_BUILD_TYPE=Debug"], check=True, capture_output=True)
    r = subprocess.run([cmake, "--build", str(b), "--target", "test_core"], capture_output=True, text=True)
    assert r.returncode == 0, r.stdout + r.stderr
    env = dict(os.environ, UBSAN_OPTIONS="halt_on_error=1:print_stacktrace=1", ASAN_OPTIONS="detect_leaks=0")
    r = subprocess.run([str(b / "test_core")], capture_output=True, text=True, env=env)
    assert r.returncode == 0, r.stdout[-3000:] + r.stderr[-3000:]
    assert " 0 failed" in r.stdout
    assert "runtime error" not in r.stderr


def _code_without_comments(path):
    text = path.read_text()
    # S08 assembly blocks (SDCC __asm ... __endasm) hold no C: their ';' comments may quote numbers
    text = re.sub(r"__asm\b.*?__endasm", " ", text, flags=re.S)
    text = re.sub(r"/\*.*?\*/", " ", text, flags=re.S)
    text = re.sub(r"//[^\n]*", " ", text)
    return re.sub(r'"(\\.|[^"\\])*"', '""', text)


def _firmware_sources():
    files = sorted(list(FW.rglob("*.c")) + list(FW.rglob("*.h")))
    assert files
    return files


def test_no_floating_point_in_firmware():
    bad = [f"{p.relative_to(ROOT)}: {m.group(0)}" for p in _firmware_sources()
           for m in re.finditer(r"\b(float|double|long\s+double)\b|\b\d+\.\d*([eE][-+]?\d+)?[fF]?\b",
                                _code_without_comments(p))]
    assert not bad, bad


def test_no_heap_in_firmware():
    bad = [str(p.relative_to(ROOT)) for p in _firmware_sources()
           if re.search(r"\b(malloc|calloc|realloc|free)\s*\(", _code_without_comments(p))]
    assert not bad, bad


def test_no_recursion_in_core():
    """No function of the core calls itself, directly or through another."""
    src = {p: _code_without_comments(p) for p in (FW / "src").glob("*.c")}
    defs = {}
    for p, text in src.items():
        for m in re.finditer(r"^[a-z_][\w\s\*]*?\b(\w+)\s*\(([^;{]*)\)\s*\{", text, flags=re.M):
            name = m.group(1)
            depth, i = 1, m.end()
            while depth and i < len(text):
                depth += {"{": 1, "}": -1}.get(text[i], 0)
                i += 1
            defs[name] = text[m.end():i]
    assert "att_compute" in defs and "fx_atan2_q16" in defs
    calls = {f: {g for g in defs if g != f and re.search(rf"\b{g}\s*\(", body)} |
             ({f} if re.search(rf"\b{f}\s*\(", body) else set()) for f, body in defs.items()}

    def reaches(start):
        seen, todo = set(), list(calls[start])
        while todo:
            f = todo.pop()
            if f == start:
                return True
            if f not in seen:
                seen.add(f)
                todo.extend(calls.get(f, ()))
        return False

    assert not [f for f in defs if reaches(f)]


def test_strict_warnings_clean(tmp_path):
    cc = shutil.which("gcc") or pytest.skip("gcc not found")
    srcs = [str(p) for p in (FW / "src").glob("*.c")]
    r = subprocess.run([cc, "-std=c99", "-Wall", "-Wextra", "-Wconversion", "-Wshadow", "-Werror",
                        "-fsyntax-only", f"-I{FW / 'include'}", *srcs], capture_output=True, text=True)
    assert r.returncode == 0, r.stderr
