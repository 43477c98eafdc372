"""The firmware's frame parser, command layer and calibration-image checker
under libFuzzer with AddressSanitizer and UndefinedBehaviorSanitizer: a
bounded run here (docs/fuzzing.md has a longer one).  Needs clang with
libFuzzer (Debian package clang); skipped with that reason when missing."""
import json
import os
import pathlib
import shutil
import subprocess

import pytest

ROOT = pathlib.Path(__file__).resolve().parents[1]
SOURCES = ["proto_frame.c", "proto_cmd.c", "crc16.c", "calimg.c"]
RUNS = 200_000


def _missing(reason: str):
    # CI installs the tools (.ci/run): there a missing tool is a failure, not a skip
    if os.environ.get("CI"):
        pytest.fail(reason)
    pytest.skip(reason)


def build(out: pathlib.Path) -> pathlib.Path:
    clang = shutil.which("clang")
    if clang is None:
        _missing("clang not found: install the Debian packages clang libclang-rt-14-dev (libFuzzer)")
    exe = out / "fuzz_proto"
    cmd = [clang, "-std=c99", "-g", "-O1", "-fsanitize=fuzzer,address,undefined", "-fno-sanitize-recover=all",
           f"-I{ROOT / 'firmware' / 'include'}", str(ROOT / "tests" / "fuzz" / "fuzz_proto.c"),
           *(str(ROOT / "firmware" / "src" / s) for s in SOURCES), "-o", str(exe)]
    r = subprocess.run(cmd, capture_output=True, text=True)
    if r.returncode != 0 and "fuzzer" in r.stderr and "cannot find" in r.stderr:
        _missing("clang has no libFuzzer runtime: install the Debian package libclang-rt-14-dev")
    assert r.returncode == 0, r.stderr
    return exe


def seed_corpus(d: pathlib.Path) -> None:
    d.mkdir()
    cases = json.loads((ROOT / "tests" / "vectors" / "frames.json").read_text())["cases"]
    for i, c in enumerate(cases):
        data = b"".join(bytes.fromhex(s) for s in c["stream"] if s != "idle")
        (d / f"seed{i}").write_bytes(b"\x40" + data)
    # framed-request mode: one request of every command, with plausible payloads
    reqs = [(1, 0x01, b""), (2, 0x02, b""), (3, 0x03, b"\x00\x05\x00\x03"), (4, 0x04, b""), (5, 0x05, b""),
            (6, 0x06, b""), (7, 0x07, bytes(24)), (8, 0x10, b"\x01"), (9, 0x11, b"\x00ICAL" + bytes(116)),
            (10, 0x12, b"\x01\x00\x00\x00\x07"), (11, 0x21, b"BOOT"), (12, 0x20, b""), (12, 0x20, b"")]
    (d / "framed").write_bytes(b"\xc0" + b"".join(bytes([s, c, len(p)]) + p for s, c, p in reqs + [(13, 0x08, b"")]))


def test_fuzz_bounded_run(tmp_path):
    exe = build(tmp_path)
    corpus = tmp_path / "corpus"
    seed_corpus(corpus)
    r = subprocess.run([str(exe), f"-runs={RUNS}", "-max_len=600", "-seed=1", str(corpus)],
                       capture_output=True, text=True, timeout=600)
    assert r.returncode == 0, r.stderr[-4000:]
    assert f"Done {RUNS} runs" in r.stderr
