"""The firmware's frame parser, command layer and calibration-image checker,
and the bootloader's record and command handling (a second target), under
libFuzzer with AddressSanitizer and UndefinedBehaviorSanitizer: a bounded
run of each here (docs/fuzzing.md has longer ones).  Needs clang with
libFuzzer (Debian package clang); skipped with that reason when missing."""
import json
import os
import pathlib
import shutil
import subprocess

import pytest

ROOT = pathlib.Path(__file__).resolve().parents[1]
SOURCES = ["proto_frame.c", "proto_dispatch.c", "proto_cmd.c", "crc16.c", "calimg.c"]
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
    # calibration images of both versions: as CAL_WRITE requests and as the image checker's block
    for k, img in enumerate(_images()):
        (d / f"cal_write{k}").write_bytes(b"\xc0" + bytes([20 + k, 0x11, 1 + len(img)]) + b"\x00" + img)
        (d / f"image{k}").write_bytes(b"\x40" + img + b"\xff" * (192 - len(img)))


def _images():
    """A version 1 and a version 2 image (with temperature terms) of one calibration."""
    from inclino.formats.calfile import Calibration
    from inclino.formats.calimage import CalImage

    blk = {"t_ref_c": 25.0, "order": 2, "span_c": [-5.0, 55.0], "applied_by_firmware": True,
           "acc": {"bias": [[2e-5, -1e-5, 3e-5], [2e-7, 0.0, -1e-7]], "scale_ppm": [[30, -20, 25], [0.3, 0, -0.2]]},
           "mag": {"bias": [[2.0, -1.5, 3.0], [0.02, 0.0, 0.01]], "scale_ppm": [[50, 40, -30], [0.3, 0.1, 0]]}}
    kw = dict(acc_m=[[1.01, 0, 0], [0, 0.99, 0], [0, 0, 1.0]], acc_b=[0.01, 0, 0],
              mag_m=[[1.0, 0, 0], [0, 1.02, 0], [0, 0, 0.98]], mag_b=[300.0, -100.0, 50.0])
    return [CalImage(Calibration(**kw).to_fixed(), 1, 2, "joint").pack(),
            CalImage(Calibration(**kw, temperature=blk).to_fixed(), 1, 2, "joint").pack()]


def test_fuzz_bounded_run(tmp_path):
    exe = build(tmp_path)
    corpus = tmp_path / "corpus"
    seed_corpus(corpus)
    r = subprocess.run([str(exe), f"-runs={RUNS}", "-max_len=600", "-seed=1", str(corpus)],
                       capture_output=True, text=True, timeout=600)
    assert r.returncode == 0, r.stderr[-4000:]
    assert f"Done {RUNS} runs" in r.stderr


# ---- the bootloader (tests/fuzz/fuzz_boot.c) --------------------------------------------
BOOT_SOURCES = ["boot.c", "crc16.c", "crc32.c", "id_record.c", "proto_frame.c", "proto_dispatch.c"]
BOOT_RUNS = 60_000


def build_boot(out: pathlib.Path, boot_c: pathlib.Path | None = None, name: str = "fuzz_boot") -> pathlib.Path:
    clang = shutil.which("clang")
    if clang is None:
        _missing("clang not found: install the Debian packages clang libclang-rt-14-dev (libFuzzer)")
    exe = out / name
    srcs = [boot_c or ROOT / "firmware" / "src" / "boot.c"] + [ROOT / "firmware" / "src" / s
                                                               for s in BOOT_SOURCES if s != "boot.c"]
    cmd = [clang, "-std=c99", "-g", "-O1", "-fsanitize=fuzzer,address,undefined", "-fno-sanitize-recover=all",
           f"-I{ROOT / 'firmware' / 'include'}", str(ROOT / "tests" / "fuzz" / "fuzz_boot.c"), *map(str, srcs),
           "-o", str(exe)]
    r = subprocess.run(cmd, capture_output=True, text=True)
    if r.returncode != 0 and "fuzzer" in r.stderr and "cannot find" in r.stderr:
        _missing("clang has no libFuzzer runtime: install the Debian package libclang-rt-14-dev")
    assert r.returncode == 0, r.stderr
    return exe


def seed_corpus_boot(d: pathlib.Path) -> None:
    """One input per bootloader command with plausible arguments, a whole
    flash of a small image, a RUN, and descriptors for the checker."""
    import struct
    import zlib

    d.mkdir()
    u32 = lambda v: struct.pack(">I", v)  # noqa: E731
    data = bytes(range(64))
    crc = zlib.crc32(data)
    reqs = [(1, 0x40, u32(0x1234)), (2, 0x41, u32(0x7C0000)), (3, 0x42, u32(0x7C0000) + data),
            (4, 0x43, u32(0x7C0000) + b"\x00\x40"), (5, 0x44, u32(0x7C0000) + u32(64)),
            (6, 0x45, u32(0x7C0000) + b"\x01" + u32(0x7C0000) + u32(64) + u32(crc)), (7, 0x46, b""),
            (8, 0x40, b""), (9, 0x21, b"BOOT"), (10, 0x20, b""), (10, 0x20, b"")]
    flash = b"".join(bytes([s, c, len(p)]) + p for s, c, p in reqs)
    (d / "flash").write_bytes(b"\x80\x00" + flash)
    (d / "flash-over-app").write_bytes(b"\xc0\x00" + flash)
    for k in (1, 2, 3, 5):   # power failure at the k-th flash command
        (d / f"cut{k}").write_bytes(bytes([0xE0, k - 1]) + flash)
    (d / "protected").write_bytes(b"\x80\x00" + b"".join(bytes([s, c, len(p)]) + p for s, c, p in [
        (1, 0x41, u32(0x7FF000)), (2, 0x41, u32(0x7A0000)), (3, 0x42, u32(0x7FEC00) + bytes(8)),
        (4, 0x43, u32(0x7FFFF0) + b"\x00\x20"), (5, 0x44, u32(0x700000) + u32(0x100000))]))
    (d / "raw").write_bytes(b"\x40\x07" + b"ID\r" + struct.pack(">BBBBH", 0xA5, 1, 1, 0x40, 0) + b"\x00\x00")
    desc = struct.pack(">4sBBHII", b"IAPP", 1, 1, 0xFFFF, 0x7C0000, 2048) + u32(0x7C0000) + u32(2048) + u32(0)
    app = bytes((i * 37 + 11) & 0xFF for i in range(2048))   # fuzz_boot.c's valid_app()
    (d / "commit-same").write_bytes(b"\xc0\x00" + bytes([1, 0x45, 17]) + u32(0x7C0000) + b"\x01" + u32(0x7C0000)
                                    + u32(2048) + u32(zlib.crc32(app)) + bytes([2, 0x46, 0]))
    (d / "desc").write_bytes(b"\x58\x00" + desc)
    (d / "desc-app").write_bytes(b"\x58\x00" + desc[:28] + u32(0))


def test_fuzz_bootloader_bounded_run(tmp_path):
    exe = build_boot(tmp_path)
    corpus = tmp_path / "corpus_boot"
    seed_corpus_boot(corpus)
    r = subprocess.run([str(exe), f"-runs={BOOT_RUNS}", "-max_len=600", "-seed=1", str(corpus)],
                       capture_output=True, text=True, timeout=600)
    assert r.returncode == 0, r.stderr[-4000:]
    assert f"Done {BOOT_RUNS} runs" in r.stderr


def test_fuzz_bootloader_target_catches_a_planted_bug(tmp_path):
    """The target's invariants are live: a bootloader that forgets to erase
    the descriptor before the first erase of the application area (the
    power-cut guarantee) is caught from the seed corpus at once."""
    src = (ROOT / "firmware" / "src" / "boot.c").read_text()
    planted = src.replace("    if (b->desc_blank) {\n        return HAL_FLASH_OK;\n    }",
                          "    if (b->desc_blank || 1) {\n        return HAL_FLASH_OK;\n    }")
    assert planted != src
    (tmp_path / "boot_planted.c").write_text(planted)
    bad = build_boot(tmp_path, tmp_path / "boot_planted.c", "fuzz_boot_planted")
    corpus = tmp_path / "corpus_planted"
    seed_corpus_boot(corpus)
    r = subprocess.run([str(bad), "-runs=20000", "-max_len=600", "-seed=1", str(corpus)],
                       capture_output=True, text=True, timeout=600, cwd=tmp_path)
    assert r.returncode != 0 and "deadly signal" in r.stderr, r.stderr[-2000:]
