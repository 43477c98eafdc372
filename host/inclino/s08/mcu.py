"""The firmware core on the Freescale S08, through SDCC and the ucsim simulator.

The host build proves the algorithm; this module proves the same C on a
16-bit-int, big-endian MCU with no hardware 32-bit multiply (the S08 is a
harsher relative of the probe's HCS12X), and measures it there:

  build()        compile firmware/src + firmware/port/s08/harness.c with
                 `sdcc -ms08` (or tools/s08/survey_float.c: the float baseline)
  run_stream()   one-shot run of a byte stream through ucsim's simulator
                 interface (a byte port at 0xff00), under a time limit
  survey(), mul32_q31(), ...   NumPy in, NumPy out, like inclino.engines.firmware
  timed()        cycles of single calls from the simulator's own counter
  sizes()        code and static RAM from SDCC's .rel and .map files
  bench()        the figures of `inclino bench mcu --json`

The byte protocol is described at the top of firmware/port/s08/harness.c.
The SCI frame parser (proto_frame.c) and the calibration-image checker
(calimg.c, crc16.c) are in the same image: frame_events(), frame_encode(),
calimg_parse(), calimg_build().

Traps handled: the image is built with --stack-auto and links no SDCC helper
library (the shipped ones are the non-reentrant builds; the struct copy's
__memcpy is the port's own, memcpy_s08.c); no compound literals or VLAs in
the harness; the simulator always runs under `timeout` and the harness stops
it with simif 's' followed by the read of the answer.
"""
from __future__ import annotations

import json
import os
import re
import shutil
import subprocess
import tempfile
from concurrent.futures import ThreadPoolExecutor
from dataclasses import asdict, dataclass, field
from pathlib import Path

import numpy as np

from inclino import fw_sources

MISSING_REASON = ("S08 simulator tools not found (sdcc, shc08): "
                  "install the Debian packages sdcc and sdcc-ucsim")

# The harness image's files are the builds "s08_core" (the portable core and
# the port's part of it) and "s08_rig" (main() and the byte protocol) of the
# one source manifest, firmware/sources.txt (fw_sources.py).
# each port file replaces the portable C of the same functions (firmware/port/s08/*.c)
PORT_DEFINES = ("-DFX_PORT_MUL16", "-DFX_PORT_OPS", "-DFX_PORT_MUL32", "-DFX_PORT_DIV",
                "-DFX_PORT_SQRT", "-DFX_PORT_ATAN2", "-DATT_PORT_NORM3", "-DPROTO_PORT_FEED")
FLOAT_SOURCES = ("survey_float.c",)
SIMIF = "rom[0xff00]"
CFLAGS = ("-ms08", "--std-c99", "--opt-code-speed", "--stack-auto")
FLOAT_CFLAGS = ("-ms08", "--std-c99", "--opt-code-speed")
# SDCC keeps spill locations and its helper registers in the direct page
# (areas DSEG, OSEG).  A real S08 has registers at 0x00-0x7f and direct-page
# RAM at 0x80-0xff only.  Built with --stack-auto, the harness image keeps
# only the return registers and the port's few scratch bytes there, and its
# direct page starts at 0x80 as on a real part.  The non-reentrant float
# baseline needs more than those 128 bytes; the simulator's memory is flat,
# so its direct page starts at 0x10.  See _check_page0 for why the page must
# not overflow.
LDFLAGS = ("--data-loc", "0x80")
FLOAT_LDFLAGS = ("--data-loc", "0x10")
S08_DIRECT_PAGE_RAM = 128  # 0x80-0xff on a real part
TIMED = 0x80
BUS_HZ = 20_000_000  # the HCS12X/S08 bus the cycle target is stated for

TARGET_SURVEY_CYCLES = 60_000
TARGET_FLOAT_RATIO = 0.25
TARGET_PARSER_CPU = 0.15  # the frame parser's share of the bus at 115 200 baud

CODE_AREAS = ("CSEG", "CONST", "HOME", "GSINIT0", "GSINIT", "GSFINAL", "XINIT", "CODEIVT0")
RAM_AREAS = ("DSEG", "OSEG", "XSEG", "XISEG")


class McuError(RuntimeError):
    pass


def tools_missing() -> str | None:
    """None when sdcc and shc08 are on PATH, else a one-line reason."""
    if shutil.which("sdcc") and shutil.which("shc08"):
        return None
    return MISSING_REASON


def repo_root() -> Path:
    """The source tree holding firmware/: $INCLINO_ROOT, the current
    directory or one of its parents, or the tree this module sits in."""
    cands = []
    if os.environ.get("INCLINO_ROOT"):
        cands.append(Path(os.environ["INCLINO_ROOT"]))
    cwd = Path.cwd().resolve()
    cands += [cwd, *cwd.parents]
    here = Path(__file__).resolve()
    cands += list(here.parents)
    for c in cands:
        if (c / "firmware" / "src" / "survey.c").is_file() and (c / "firmware" / "port" / "s08").is_dir():
            return c
    raise McuError("firmware sources not found: run from the inclino source tree or set INCLINO_ROOT")


# ------------------------------------------------------------------ build
@dataclass
class McuBuild:
    program: str  # "harness" (fixed-point core) or "float"
    workdir: str
    ihx: str
    map: str
    core_rels: list
    other_rels: list
    cflags: list

    def to_json(self) -> str:
        return json.dumps(asdict(self), indent=2)


def _sdcc(args, cwd):
    r = subprocess.run(["sdcc", *args], cwd=cwd, capture_output=True, text=True, timeout=300)
    if r.returncode != 0:
        raise McuError(f"sdcc {' '.join(args)} failed:\n{r.stdout}\n{r.stderr}")
    return r


def build(workdir: str | os.PathLike | None = None, program: str = "harness",
          cflags: tuple | None = None, root: str | os.PathLike | None = None) -> McuBuild:
    """Compile each source with `sdcc -ms08` and link an Intel-hex image.

    program "harness": the fixed-point core (firmware/src) and the test
    harness (firmware/port/s08), by default with CFLAGS (--stack-auto: locals
    and spill locations on the stack, not in the 128-byte direct page);
    "float": the float baseline (tools/s08/survey_float.c), by default with
    FLOAT_CFLAGS (not --stack-auto: it calls SDCC's float library, whose
    shipped build is the non-reentrant one).  A --stack-auto image that
    links any SDCC helper library module is refused (_check_helpers)."""
    if tools_missing():
        raise McuError(tools_missing())
    if cflags is None:
        cflags = FLOAT_CFLAGS if program == "float" else CFLAGS
    root = Path(root) if root else repo_root()
    wd = Path(workdir) if workdir else Path(tempfile.mkdtemp(prefix=f"inclino-s08-{program}-"))
    wd.mkdir(parents=True, exist_ok=True)
    inc = ["-I", str(root / "firmware" / "include"), "-I", str(root / "firmware" / "port" / "s08")]
    if program == "harness":
        inc += list(PORT_DEFINES)
    if program == "harness":
        core = fw_sources.sources("s08_core", root)
        other = fw_sources.sources("s08_rig", root)
    elif program == "float":
        core = []
        other = [root / "tools" / "s08" / s for s in FLOAT_SOURCES]
    else:
        raise ValueError(f"unknown program {program!r}")
    rels = {}
    for src in core + other:
        rel = wd / (src.stem + ".rel")
        _sdcc([*cflags, *inc, "-c", str(src), "-o", str(rel)], wd)
        rels[src] = rel
    # the object with main() first: SDCC's linker takes its start-up from it
    order = [rels[s] for s in other] + [rels[s] for s in core]
    ihx = wd / f"{program}.ihx"
    ldflags = FLOAT_LDFLAGS if program == "float" else LDFLAGS
    _sdcc([*cflags, *ldflags, "--out-fmt-ihx", "-o", str(ihx), *map(str, order)], wd)
    _check_page0(ihx.with_suffix(".map"))
    if "--stack-auto" in cflags:
        _check_helpers(ihx.with_suffix(".map"), {Path(r).stem for r in rels.values()})
    return McuBuild(program, str(wd), str(ihx), str(ihx.with_suffix(".map")),
                    [str(rels[s]) for s in core], [str(rels[s]) for s in other], list(cflags))


def _check_page0(map_path: Path) -> None:
    """SDCC keeps its spill locations and helper registers in the direct
    page (areas DSEG and OSEG, from 0x80).  Past 0xff the linker silently
    wraps the 8-bit direct addresses and variables alias each other (found
    by trying: wrong G and B totals, no warning).  Refuse such an image."""
    for line in map_path.read_text(errors="replace").splitlines():
        m = _AREA_MAP.match(line)
        if m and m.group(1) in ("DSEG", "OSEG"):
            end = int(m.group(2), 16) + int(m.group(3), 16)
            if end > 0x100:
                raise McuError(f"{m.group(1)} ends at {end:#x}, beyond the direct page (0x100): "
                               "too many page-zero spill locations; simplify the code or "
                               "move data out of the direct page")


# SDCC library modules a --stack-auto image may link: start-up code and the
# return registers, no arithmetic
STACK_AUTO_SAFE_MODULES = ("_startup", "_ret")


def _check_helpers(map_path: Path, ours: set) -> None:
    """With --stack-auto, SDCC calls its helpers (__mullong, __divulong,
    __mulint, the float routines, ...) with the reentrant convention, but the
    libraries Debian ships are the non-reentrant builds: the products come
    out wrong without a link error.  The core needs none of them (fx_mul16
    is the port's own); refuse an image that links one."""
    mods = _linked_modules(map_path) - ours
    bad = sorted(m for m in mods if m not in STACK_AUTO_SAFE_MODULES)
    if bad:
        raise McuError(f"--stack-auto image links SDCC helper modules {bad}: the shipped "
                       "helpers are not reentrant; avoid the operation or rebuild the "
                       "helpers from /usr/share/sdcc/lib/src with the same flags")


# ------------------------------------------------------------------ run
def run_stream(b: McuBuild, data: bytes, timeout: float = 300.0) -> bytes:
    """Run the image on `data` (must end with the 'E' command) until the
    harness stops the simulator; returns what it wrote, without the final
    'e' acknowledgement."""
    with tempfile.TemporaryDirectory(prefix="inclino-sim-") as td:
        fin = Path(td) / "in.bin"
        fout = Path(td) / "out.bin"
        fin.write_bytes(data)
        fout.write_bytes(b"")
        # not -G: with -G the simulator quits as soon as its console input
        # ends, while the program may still be running; `run` returns at the
        # harness's stop, then `quit`
        cmd = ["timeout", str(int(timeout)), "shc08", "-t", "HCS08", "-b",
               "-I", f"if={SIMIF},in={fin},out={fout}", b.ihx]
        r = subprocess.run(cmd, input=b"run\nquit\n", capture_output=True, timeout=timeout + 30)
        out = fout.read_bytes()
    if r.returncode == 124:
        raise McuError(f"simulator timed out after {timeout} s")
    if not out.endswith(b"e"):
        raise McuError(f"harness did not finish (rc {r.returncode}, {len(out)} bytes, "
                       f"last {out[-8:]!r}): {r.stdout[-400:]!r}")
    return out[:-1]


def run_streams(b: McuBuild, streams: list[bytes], jobs: int | None = None,
                timeout: float = 300.0) -> list[bytes]:
    """run_stream over several streams, in parallel simulator processes."""
    jobs = jobs or max(1, min(len(streams), os.cpu_count() or 1))
    with ThreadPoolExecutor(jobs) as ex:
        return list(ex.map(lambda s: run_stream(b, s, timeout), streams))


_TOTAL = re.compile(rb"Total time since last reset=[^(]*\((\d+) clks\)")


def _cycles_of(b: McuBuild, cmds: list[bytes], timeout: float) -> list[int]:
    data = b"".join(cmds) + b"E"
    with tempfile.TemporaryDirectory(prefix="inclino-sim-") as td:
        fin = Path(td) / "in.bin"
        fout = Path(td) / "out.bin"
        fin.write_bytes(data)
        script = "run\nstate\n" * (2 * len(cmds)) + "run\nquit\n"
        cmd = ["timeout", str(int(timeout)), "shc08", "-t", "HCS08", "-b",
               "-I", f"if={SIMIF},in={fin},out={fout}", b.ihx]
        r = subprocess.run(cmd, input=script.encode(), capture_output=True, timeout=timeout + 30)
        out = fout.read_bytes()
    counts = [int(x) for x in _TOTAL.findall(r.stdout)]
    if r.returncode == 124 or len(counts) != 2 * len(cmds) or not out.endswith(b"e"):
        raise McuError(f"timed run failed (rc {r.returncode}, {len(counts)} counts for "
                       f"{len(cmds)} calls, output ends {out[-4:]!r})")
    return [counts[2 * i + 1] - counts[2 * i] for i in range(len(cmds))]


def timed(b: McuBuild, cmds: list[bytes], timeout: float = 300.0, setup: bytes = b"") -> list[int]:
    """Bus cycles of each command's call (command bytes without the timed
    bit; `setup` is sent first untimed, e.g. a calibration).  Each call runs
    between two simulator stops; the constant overhead of the stops, measured
    on the empty command 'Z', is subtracted."""
    tcmds = [bytes([c[0] | TIMED]) + c[1:] for c in cmds]
    z = bytes([ord("Z") | TIMED])
    n0 = 3
    pre = [setup + z] + [z] * (n0 - 1) if setup else [z] * n0
    cyc = _cycles_of(b, pre + tcmds, timeout)
    zs = set(cyc[:n0])
    if len(zs) != 1:
        raise McuError(f"stop overhead not constant: {sorted(zs)}")
    over = cyc[0]
    return [c - over for c in cyc[n0:]]


_SP = re.compile(rb"SP= \$([0-9a-fA-F]+)")
STACK_FLOOR = 0x7000  # SDCC's S08 start-up: stack from 0x7fff down (ucsim's limit)


def _stack_run(b: McuBuild, data: bytes, middle: str, timeout: float) -> bytes:
    with tempfile.TemporaryDirectory(prefix="inclino-sim-") as td:
        fin = Path(td) / "in.bin"
        fout = Path(td) / "out.bin"
        fin.write_bytes(data)
        script = "run\n" + middle + "run\nquit\n"
        cmd = ["timeout", str(int(timeout)), "shc08", "-t", "HCS08", "-b",
               "-I", f"if={SIMIF},in={fin},out={fout}", b.ihx]
        r = subprocess.run(cmd, input=script.encode(), capture_output=True, timeout=timeout + 30)
    if r.returncode == 124:
        raise McuError(f"simulator timed out after {timeout} s")
    return r.stdout


def stack_bytes(b: McuBuild, cmd: bytes, setup: bytes = b"", timeout: float = 120.0) -> int:
    """Deepest stack use of one call (command bytes without the timed bit):
    at the stop before the call the free stack below SP is filled with a
    pattern; at the stop after it, the lowest byte that changed gives the
    depth (SP at the first stop is found by a first run; it is the same in
    the second, the program being deterministic)."""
    data = setup + bytes([cmd[0] | TIMED]) + cmd[1:] + b"E"
    sps = _SP.findall(_stack_run(b, data, "info registers\nrun\nrun\n", timeout))
    if not sps:
        raise McuError("stack measurement: no SP in the simulator's output")
    sp = int(sps[0], 16)
    out = _stack_run(b, data, f"fill rom {STACK_FLOOR:#x} {sp:#x} 0xa5\nrun\n"
                              f"dump rom {STACK_FLOOR:#x} {sp:#x} 16\nrun\n", timeout)
    mem = {}
    for line in out.splitlines():
        t = line.split()
        if not t or not re.fullmatch(rb"0x[0-9a-f]+", t[0]):
            continue
        base = int(t[0], 16)
        if not STACK_FLOOR <= base <= sp:
            continue
        for i, tok in enumerate(t[1:1 + min(16, sp - base + 1)]):
            mem[base + i] = int(tok, 16)
    if len(mem) != sp - STACK_FLOOR + 1:
        raise McuError(f"stack measurement: dumped {len(mem)} bytes of {sp - STACK_FLOOR + 1}")
    used = [a for a, v in mem.items() if v != 0xA5]
    return sp - min(used) + 1 if used else 0


# ------------------------------------------------------------------ encoders
def _be(a, dt):
    return np.ascontiguousarray(np.asarray(a, dtype=np.int64).astype(dt)).tobytes()


def enc_cal(cal) -> bytes:
    """'C' + the 24 int32 coefficients of a FixedCal."""
    words = list(cal.acc_m) + list(cal.acc_b) + list(cal.mag_m) + list(cal.mag_b)
    return b"C" + _be(words, ">i4")


def _records(tag: bytes, *cols) -> list[bytes]:
    """One command per row: tag + the row's fields packed big-endian."""
    n = len(cols[0][0])
    dt = np.dtype([("t", "u1")] + [(f"f{i}", d, np.shape(a)[1:]) for i, (a, d) in enumerate(cols)])
    rec = np.zeros(n, dtype=dt)
    rec["t"] = tag[0]
    for i, (a, _) in enumerate(cols):
        rec[f"f{i}"] = np.asarray(a, dtype=np.int64)
    raw = rec.tobytes()
    w = dt.itemsize
    return [raw[i * w:(i + 1) * w] for i in range(n)]


def _split(parts: list[bytes], chunks: int, head: bytes = b"") -> list[bytes]:
    k = max(1, min(chunks, len(parts)))
    bounds = np.linspace(0, len(parts), k + 1).astype(int)
    return [head + b"".join(parts[bounds[i]:bounds[i + 1]]) + b"E" for i in range(k)]


def _decode(outs: list[bytes], dt: np.dtype, n: int) -> np.ndarray:
    raw = b"".join(outs)
    if len(raw) != n * dt.itemsize:
        raise McuError(f"expected {n * dt.itemsize} result bytes, got {len(raw)}")
    return np.frombuffer(raw, dtype=dt)


ATT_DT = [("inc", ">i4"), ("azi", ">i4"), ("gtf", ">i4"), ("mtf", ">i4"), ("gt", ">i4"),
          ("bt", ">i4"), ("dip", ">i4"), ("flags", ">u2")]
SURVEY_DT = np.dtype([("g", ">i4", (3,)), ("b", ">i4", (3,))] + ATT_DT)


def _jobs(n):
    return max(1, min(os.cpu_count() or 1, 8, n // 200 + 1))


def survey(b: McuBuild, acc, mag, cals: list) -> dict:
    """survey_compute on the S08 for each row (acc, mag in Q6 counts); vector
    i uses cals[i % len(cals)] (as inclino.engines.firmware.survey).  Returns int64 arrays: g, b (n, 3) and ATT_COLS."""
    acc = np.clip(np.asarray(acc, dtype=np.int64), -(2**31), 2**31 - 1)
    mag = np.clip(np.asarray(mag, dtype=np.int64), -(2**31), 2**31 - 1)
    n = len(acc)
    idx = np.arange(n) % len(cals)
    order = np.argsort(idx, kind="stable")  # group by calibration: one 'C' each
    recs = _records(b"V", (acc[order], ">i4"), (mag[order], ">i4"))
    parts = []
    for k, c in enumerate(cals):
        sel = np.nonzero(idx[order] == k)[0]
        if len(sel):
            parts.append([enc_cal(c)] + [recs[i] for i in sel])
    streams = []
    jobs = _jobs(n)
    for p in parts:  # each calibration's block split over the jobs
        head, body = p[0], p[1:]
        streams += _split(body, max(1, jobs * len(body) // n), head)
    outs = run_streams(b, streams, jobs)
    res = _decode(outs, SURVEY_DT, n)
    inv = np.empty(n, dtype=np.int64)
    inv[order] = np.arange(n)
    res = res[inv]
    out = {k: res[k].astype(np.int64) for k in SURVEY_DT.names}
    return out


def _prim(b: McuBuild, tag: bytes, cols, out_dt) -> np.ndarray:
    n = len(cols[0][0])
    recs = _records(tag, *cols)
    outs = run_streams(b, _split(recs, _jobs(n // 20)), None)
    return _decode(outs, np.dtype(out_dt), n)


def mul32_q31(b, x, y):
    r = _prim(b, b"M", [(x, ">i4"), (y, ">i4")], [("r", ">i4"), ("sat", "u1")])
    return r["r"].astype(np.int64), r["sat"].astype(bool)


def dot3_q31(b, x, y=None):
    """fx_dot3_q31 of the rows of x and y (n, 3); y None: of x with itself,
    the same array passed twice (the port's path for squares)."""
    if y is None:
        r = _prim(b, b"W", [(np.asarray(x, dtype=np.int64), ">i4")], [("r", ">i4"), ("sat", "u1")])
        return r["r"].astype(np.int64), r["sat"].astype(bool)
    xy = np.concatenate([np.asarray(x, dtype=np.int64), np.asarray(y, dtype=np.int64)], axis=1)
    r = _prim(b, b"3", [(xy, ">i4")], [("r", ">i4"), ("sat", "u1")])
    return r["r"].astype(np.int64), r["sat"].astype(bool)


def norm3(b, v):
    """att_norm3 of the rows of v (n, 3): (out (n, 3), s (n,))."""
    r = _prim(b, b"N", [(np.asarray(v, dtype=np.int64), ">i4")], [("out", ">i4", (3,)), ("s", "i1")])
    return r["out"].astype(np.int64), r["s"].astype(np.int64)


def asr32(b, x, n, rnd: bool = False):
    """fx_asr32 (or fx_asr32_rnd) of x by n (arrays)."""
    return _prim(b, b"U" if rnd else b"S", [(x, ">i4"), (n, "u1")], [("r", ">i4")])["r"].astype(np.int64)


def add32_sat(b, x, y, sub: bool = False):
    """fx_add32_sat (or fx_sub32_sat): (result, saturated)."""
    r = _prim(b, b"-" if sub else b"+", [(x, ">i4"), (y, ">i4")], [("r", ">i4"), ("sat", "u1")])
    return r["r"].astype(np.int64), r["sat"].astype(bool)


def div_frac_q20(b, num, den):
    return _prim(b, b"D", [(num, ">u4"), (den, ">u4")], [("r", ">u4")])["r"].astype(np.int64)


def sqrt_u32_q8(b, x):
    return _prim(b, b"Q", [(x, ">u4")], [("r", ">u4")])["r"].astype(np.int64)


def isqrt_u32(b, x):
    return _prim(b, b"R", [(x, ">u4")], [("r", ">u2")])["r"].astype(np.int64)


def atan2_q16(b, y, x):
    return _prim(b, b"A", [(y, ">i4"), (x, ">i4")], [("r", ">i4")])["r"].astype(np.int64)


def mul16(b, x, y):
    return _prim(b, b"P", [(x, ">i2"), (y, ">i2")], [("r", ">i4")])["r"].astype(np.int64)


def att_compute(b, g, bv):
    g = np.asarray(g, dtype=np.int64)
    r = _prim(b, b"T", [(np.concatenate([g, np.asarray(bv, dtype=np.int64)], axis=1), ">i4")], ATT_DT)
    return {k: r[k].astype(np.int64) for k, _ in ATT_DT}


def corr_triad(b, x, cal, which: int):
    """corr_triad with cal's accelerometer (which=0) or fluxgate (1) triad."""
    x = np.asarray(x, dtype=np.int64)
    n = len(x)
    recs = _records(b"K", (np.full(n, which), "u1"), (x, ">i4"))
    outs = run_streams(b, _split(recs, _jobs(n // 20), enc_cal(cal)), None)
    r = _decode(outs, np.dtype([("out", ">i4", (3,)), ("sat", "u1")]), n)
    return r["out"].astype(np.int64), r["sat"].astype(bool)


# ------------------------------------------------------------------ frames and images
FEED_CHUNK = 256  # the harness's HBUF_SIZE: longer segments go as several 'F'
PF_KINDS = {1: "frame", 2: "bad_crc", 3: "bad_len", 4: "line"}


def _u16(n: int) -> bytes:
    return int(n).to_bytes(2, "big")


def enc_frame_case(segments) -> bytes:
    """'I', then per segment 'F' n bytes (in chunks of FEED_CHUNK) or, for
    the marker "idle", 'L' (the layout of tests/vectors/frames.json)."""
    out = [b"I"]
    for seg in segments:
        if isinstance(seg, str):
            if seg != "idle":
                raise ValueError(f"unknown stream marker {seg!r}")
            out.append(b"L")
            continue
        seg = bytes(seg)
        for i in range(0, len(seg), FEED_CHUNK):
            out.append(b"F" + _u16(len(seg[i:i + FEED_CHUNK])) + seg[i:i + FEED_CHUNK])
    return b"".join(out)


def _dec_events(out: bytes, pos: int, events: list) -> int:
    """Event records of one 'F' up to its 0x00; appends dicts in the
    vectors' format; returns the new position."""
    while True:
        k = out[pos]
        pos += 1
        if k == 0:
            return pos
        kind = PF_KINDS.get(k)
        if kind == "frame":
            ver, seq, cmd = out[pos:pos + 3]
            n = int.from_bytes(out[pos + 3:pos + 5], "big")
            pl = out[pos + 5:pos + 5 + n]
            if len(pl) != n:
                raise McuError("truncated frame event")
            pos += 5 + n
            events.append({"kind": kind, "ver": ver, "seq": seq, "cmd": cmd, "payload": pl.hex()})
        elif kind == "bad_crc":
            events.append({"kind": kind, "seq": out[pos], "cmd": out[pos + 1]})
            pos += 2
        elif kind == "bad_len":
            events.append({"kind": kind})
        elif kind == "line":
            n = out[pos]
            events.append({"kind": kind, "line": out[pos + 1:pos + 1 + n].decode("ascii")})
            pos += 1 + n
        else:
            raise McuError(f"unknown parser event {k} at byte {pos - 1}")


def frame_events(b: McuBuild, cases: list) -> list[dict]:
    """proto_frame_feed on the S08: each case is a list of segments (bytes,
    or "idle" for proto_parser_idle), run from a fresh parser.  Returns per
    case {"events": [...] in the format of tests/vectors/frames.json,
    "idle": [proto_parser_idle's result, ...]}."""
    enc = [enc_frame_case(c) for c in cases]
    n = len(cases)
    k = max(1, min(n, _jobs(sum(map(len, enc)) // 50)))
    bounds = np.linspace(0, n, k + 1).astype(int)
    groups = [list(range(bounds[i], bounds[i + 1])) for i in range(k) if bounds[i] < bounds[i + 1]]
    outs = run_streams(b, [b"".join(enc[i] for i in g) + b"E" for g in groups])
    res = []
    for g, out in zip(groups, outs):
        pos = 0
        for i in g:
            ev, idle = [], []
            for seg in cases[i]:
                if isinstance(seg, str):
                    idle.append(out[pos])
                    pos += 1
                    continue
                for j in range(0, len(seg), FEED_CHUNK):
                    pos = _dec_events(out, pos, ev)
            res.append({"events": ev, "idle": idle})
        if pos != len(out):
            raise McuError(f"{len(out) - pos} result bytes left over")
    return res


def enc_frame_encode(seq: int, cmd: int, payload: bytes, cap: int = FEED_CHUNK) -> bytes:
    return b"G" + bytes([seq & 0xFF, cmd & 0xFF]) + _u16(len(payload)) + bytes(payload) + _u16(cap)


def frame_encode(b: McuBuild, frames: list) -> list[bytes]:
    """proto_frame_encode on the S08 for each (seq, cmd, payload[, cap]);
    b"" where it refuses.  payload and cap at most FEED_CHUNK bytes."""
    cmds = [enc_frame_encode(*f) for f in frames]
    outs = run_streams(b, _split(cmds, _jobs(len(cmds) // 4)))
    raw = b"".join(outs)
    res, pos = [], 0
    for _ in frames:
        m = int.from_bytes(raw[pos:pos + 2], "big")
        res.append(raw[pos + 2:pos + 2 + m])
        pos += 2 + m
    if pos != len(raw):
        raise McuError(f"{len(raw) - pos} result bytes left over")
    return res


CALIMG_DT = np.dtype([("status", "u1"), ("acc_m", ">i4", (9,)), ("acc_b", ">i4", (3,)),
                      ("mag_m", ">i4", (9,)), ("mag_b", ">i4", (3,)), ("serial", ">u4"),
                      ("time", ">u4"), ("method", "u1")])
CALIMG_UNTOUCHED = (0x25A5A5A5, 0xA5A5A5A5, 0xA5)  # the harness's fill: coefficient, serial/time, method


def enc_calimg_parse(data: bytes) -> bytes:
    return b"X" + _u16(len(data)) + bytes(data)


def calimg_parse(b: McuBuild, images: list) -> np.ndarray:
    """calimg_parse on the S08 of each byte string (at most FEED_CHUNK bytes):
    a CALIMG_DT record each: the status and the decoded fields (on an error
    the harness's fill, CALIMG_UNTOUCHED, which the parser must not touch)."""
    cmds = [enc_calimg_parse(d) for d in images]
    outs = run_streams(b, _split(cmds, _jobs(len(cmds) // 2)))
    return _decode(outs, CALIMG_DT, len(images)).copy()


def enc_calimg_build(cal, serial: int, time: int, method: int) -> bytes:
    words = list(cal.acc_m) + list(cal.acc_b) + list(cal.mag_m) + list(cal.mag_b)
    return (b"B" + _be(words, ">i4") + int(serial).to_bytes(4, "big") + int(time).to_bytes(4, "big")
            + bytes([method & 0xFF]))


def calimg_build(b: McuBuild, items: list) -> list[bytes]:
    """calimg_build on the S08 for each (FixedCal, serial, time, method code)."""
    cmds = [enc_calimg_build(*it) for it in items]
    outs = run_streams(b, _split(cmds, _jobs(len(cmds) // 2)))
    raw = b"".join(outs)
    if len(raw) != 120 * len(items):
        raise McuError(f"expected {120 * len(items)} image bytes, got {len(raw)}")
    return [raw[i * 120:(i + 1) * 120] for i in range(len(items))]


# ------------------------------------------------------------------ float baseline
FLOAT_DT = np.dtype([("inc", ">f4"), ("azi", ">f4"), ("gtf", ">f4"), ("mtf", ">f4"),
                     ("gt", ">f4"), ("bt", ">f4"), ("dip", ">f4"), ("flags", ">u2")])


def enc_float_cal(cal) -> bytes:
    """'C' + the float coefficients (M unitless, acc bias g, mag bias nT) of
    the fixed calibration, dequantised."""
    m = 2.0**29
    w = ([v / m for v in cal.acc_m] + [v / 2.0**29 for v in cal.acc_b]
         + [v / m for v in cal.mag_m] + [v / 2.0**10 for v in cal.mag_b])
    return b"C" + np.asarray(w, dtype=">f4").tobytes()


def survey_float(b: McuBuild, acc, mag, cal) -> dict:
    """The float baseline (tools/s08/survey_float.c) on the S08; degrees, g, nT."""
    acc = np.asarray(acc, dtype=np.int64)
    mag = np.asarray(mag, dtype=np.int64)
    recs = _records(b"V", (acc, ">i4"), (mag, ">i4"))
    outs = run_streams(b, _split(recs, _jobs(len(acc)), enc_float_cal(cal)))
    r = _decode(outs, FLOAT_DT, len(acc))
    return {k: r[k].astype(np.float64) for k in FLOAT_DT.names}


# ------------------------------------------------------------------ sizes
_AREA_REL = re.compile(r"^A (\S+) size ([0-9A-Fa-f]+) ")
_AREA_MAP = re.compile(r"^(\S+)\s+([0-9A-Fa-f]{8})\s+([0-9A-Fa-f]{8}) =\s+(\d+)\. bytes")


def _linked_modules(map_path: Path) -> set:
    """Names of the modules whose symbols the linker map lists."""
    mods = set()
    for line in Path(map_path).read_text(errors="replace").splitlines():
        parts = line.split()
        if len(parts) == 4 and parts[0] == "C:" and parts[2].startswith("_"):
            mods.add(parts[3])
        elif len(parts) == 3 and re.fullmatch(r"[0-9A-Fa-f]{8}", parts[0]):
            mods.add(parts[2])
    return mods


def _rel_areas(path) -> dict:
    out = {}
    for line in Path(path).read_text(errors="replace").splitlines():
        m = _AREA_REL.match(line)
        if m:
            out[m.group(1)] = out.get(m.group(1), 0) + int(m.group(2), 16)
    return out


@dataclass
class McuSizes:
    core_code_bytes: int  # firmware/src modules: CSEG + CONST
    core_table_bytes: int  # of which constant data (fx_atan_table)
    core_ram_bytes: int  # firmware/src modules: DSEG + OSEG + XSEG (locals are static)
    image_code_bytes: int  # whole linked image, incl. harness and SDCC helpers
    image_ram_bytes: int
    direct_page_bytes: int  # DSEG + OSEG of the image (SDCC's page-zero variables)
    fits_s08_direct_page: bool  # direct_page_bytes <= 128 (0x80-0xff on a real S08)
    per_module: dict = field(default_factory=dict)  # name -> {"code": n, "ram": n}
    library_modules: list = field(default_factory=list)  # SDCC helpers linked in


def sizes(b: McuBuild) -> McuSizes:
    per = {}
    for r in b.core_rels:
        a = _rel_areas(r)
        per[Path(r).stem] = {"code": sum(a.get(k, 0) for k in CODE_AREAS),
                             "const": a.get("CONST", 0),
                             "ram": sum(a.get(k, 0) for k in RAM_AREAS)}
    img = {}
    ours = {Path(r).stem for r in b.core_rels + b.other_rels}
    mods = _linked_modules(Path(b.map))
    for line in Path(b.map).read_text(errors="replace").splitlines():
        m = _AREA_MAP.match(line)
        if m:
            img[m.group(1)] = img.get(m.group(1), 0) + int(m.group(4))
    return McuSizes(
        core_code_bytes=sum(v["code"] for v in per.values()),
        core_table_bytes=sum(v["const"] for v in per.values()),
        core_ram_bytes=sum(v["ram"] for v in per.values()),
        image_code_bytes=sum(img.get(k, 0) for k in CODE_AREAS),
        image_ram_bytes=sum(img.get(k, 0) for k in RAM_AREAS),
        direct_page_bytes=img.get("DSEG", 0) + img.get("OSEG", 0),
        fits_s08_direct_page=img.get("DSEG", 0) + img.get("OSEG", 0) <= S08_DIRECT_PAGE_RAM,
        per_module=per,
        library_modules=sorted(m for m in mods - ours if m.startswith("_")),
    )


# ------------------------------------------------------------------ bench
@dataclass
class CycleStats:
    calls: int
    mean: float
    min: int
    max: int


def _stats(c) -> CycleStats:
    c = np.asarray(c)
    return CycleStats(int(len(c)), float(c.mean()), int(c.min()), int(c.max()))


@dataclass
class McuBench:
    target: str
    compiler: str
    cflags: list
    functions: dict  # name -> CycleStats (bus cycles per call)
    survey: CycleStats  # whole survey_compute
    survey_float: CycleStats  # the same survey in float (SDCC software float)
    fixed_to_float_ratio: float  # mean cycles, fixed / float
    survey_ms_at_20mhz: float  # mean survey time at a 20 MHz bus
    survey_stack_bytes: int  # deepest stack use of survey_compute (--stack-auto: its RAM)
    sizes: McuSizes
    float_sizes: dict
    float_max_abs_err_deg: float  # float baseline vs the golden model (sanity)
    frame_parser_cycles_per_byte: CycleStats  # proto_frame_feed, one call per byte of traffic_stream()
    frame_parser_cpu_at_115200_baud: float  # mean cycles per byte / bus cycles per byte time (20 MHz)
    calimg_parse_cycles: int  # calimg_parse of one good 120-byte image (the whole check, CRC included)
    targets: dict
    meets_cycle_target: bool
    meets_ratio_target: bool
    passed: bool
    meets_parser_target: bool = False  # frame_parser_cpu_at_115200_baud <= TARGET_PARSER_CPU
    # what survey_compute is timed on: the acquisition's means with 6 fraction bits
    survey_inputs: str = "int32 Q6 counts (1/64 count) for both triads, fractional means of the bench vectors"

    def to_json(self) -> str:
        return json.dumps(asdict(self), indent=2)


def _sdcc_version() -> str:
    try:
        r = subprocess.run(["sdcc", "--version"], capture_output=True, text=True, timeout=30)
        return r.stdout.splitlines()[0].split()[-3] if r.stdout else "?"
    except (OSError, IndexError, subprocess.SubprocessError):
        return "?"


def bench_vectors(n: int = 200, seed: int = 11):
    """Physically plausible readings for the timing runs: random poses with
    I in [1, 179] degrees, fields of 20 000 to 70 000 nT, the typical
    calibration's raw readings (what a probe sees)."""
    from inclino.model import typical_probe as hbench
    from inclino.engines import reference

    rng = np.random.default_rng(seed)
    cal = hbench.typical_calibration()
    inc = rng.uniform(1.0, 179.0, n)
    azi = rng.uniform(0.0, 360.0, n)
    tf = rng.uniform(0.0, 360.0, n)
    dip = rng.uniform(-80.0, 80.0, n)
    F = rng.uniform(20000.0, 70000.0, n)
    g = np.empty((n, 3))
    bb = np.empty((n, 3))
    for i in range(n):
        g[i], bb[i] = reference.body_vectors(inc[i:i + 1], azi[i:i + 1], tf[i:i + 1], F[i], dip[i])
    ga, bm = hbench._raw_for(cal, g, bb)
    # averaged readings as the acquisition passes them on (Q6 counts)
    return reference.readings_acc(ga), reference.readings_mag(bm), cal.to_fixed()


def traffic_stream() -> bytes:
    """Link traffic for the parser's figure: a request and its 36-byte survey
    answer, a text line, the largest frame (200-byte payload)."""
    from inclino.link import protocol

    return (protocol.encode_frame(7, 0x05, b"") + protocol.encode_frame(7, 0x85, bytes(range(36)))
            + b"status ok\r\n" + protocol.encode_frame(8, 0x11, bytes(range(200))))


def bench_image() -> bytes:
    """The typical calibration as a calibration image (CalImage.pack)."""
    from inclino.model import typical_probe as hbench
    from inclino.formats.calimage import CalImage

    return CalImage(hbench.typical_calibration().to_fixed(), 123456, 1795000000, "joint").pack()


def bench(vectors: int = 100, seed: int = 11, workdir: str | os.PathLike | None = None) -> McuBench:
    """Cycles, sizes and the fixed/float ratio on the S08 (ucsim's cycle
    counter: exact and repeatable).  `vectors` plausible survey inputs
    (bench_vectors) are timed through survey_compute and through the float
    baseline; each core function is timed on the arguments the survey gives
    it (from the golden model's intermediate values of the same vectors).
    Targets: a whole survey <= 60 000 bus cycles (the max over the vectors)
    and mean fixed/float <= 0.25.  `inclino bench mcu --json` prints
    bench().to_json()."""
    from inclino.engines import golden

    if tools_missing():
        raise McuError(tools_missing())
    with tempfile.TemporaryDirectory(prefix="inclino-bench-") as td:
        wd = Path(workdir) if workdir else Path(td)
        fx = build(wd / "fixed")
        fl = build(wd / "float", program="float")
        acc, mag, fc = bench_vectors(vectors, seed)
        recs = _records(b"V", (acc, ">i4"), (mag, ">i4"))
        cyc_s = timed(fx, recs, setup=enc_cal(fc))
        cyc_f = timed(fl, recs, setup=enc_float_cal(fc))
        # per-function inputs: what the survey passes them
        arrs = fc.arrays()
        gs = golden.survey_compute(acc, mag, *arrs)
        G, _ = golden.att_norm3(gs["g"])
        B, _ = golden.att_norm3(gs["b"])
        x_acc = golden.corr_in_acc(acc)
        funcs = {}
        funcs["fx_mul16"] = timed(fx, _records(b"P", ((G[:, 0] >> 16), ">i2"), ((B[:, 1] >> 16), ">i2")))
        funcs["fx_mul32_q31"] = timed(fx, _records(b"M", (G[:, 0], ">i4"), (B[:, 1], ">i4")))
        funcs["fx_dot3_q31"] = timed(fx, _records(b"3", (np.concatenate([G, B], 1), ">i4")))
        funcs["fx_dot3_q31 (a, a)"] = timed(fx, _records(b"W", (B, ">i4")))
        funcs["fx_div_frac_q20"] = timed(fx, _records(
            b"D", (np.minimum(np.abs(G[:, 0]), np.abs(G[:, 2])), ">u4"),
            (np.maximum(np.abs(G[:, 0]), np.abs(G[:, 2])), ">u4")))
        sq = np.abs(G[:, 0]) * 2 + np.abs(G[:, 1])
        funcs["fx_isqrt_u32"] = timed(fx, _records(b"R", (sq, ">u4")))
        funcs["fx_sqrt_u32_q8"] = timed(fx, _records(b"Q", (sq, ">u4")))
        funcs["fx_atan2_q16"] = timed(fx, _records(b"A", (G[:, 1], ">i4"), (-G[:, 0], ">i4")))
        funcs["att_norm3"] = timed(fx, _records(b"N", (gs["b"], ">i4")))
        funcs["corr_triad"] = timed(fx, _records(b"K", (np.zeros(len(acc)), "u1"), (x_acc, ">i4")),
                                    setup=enc_cal(fc))
        funcs["att_compute"] = timed(fx, _records(b"T", (np.concatenate([gs["g"], gs["b"]], 1), ">i4")))
        # the frame parser: each byte of the traffic timed alone (per-byte cost,
        # by parser state), and the image check on a good image
        traffic = traffic_stream()
        cyc_feed = timed(fx, [b"F" + _u16(1) + bytes([x]) for x in traffic], setup=b"I")
        funcs["proto_frame_feed (per byte)"] = cyc_feed
        funcs["proto_frame_encode (36-byte payload)"] = timed(fx, [enc_frame_encode(7, 0x85, bytes(range(36)))])
        img = bench_image()
        cyc_img = timed(fx, [enc_calimg_parse(img)])
        funcs["calimg_parse"] = cyc_img
        funcs["calimg_build"] = timed(fx, [enc_calimg_build(fc, 123456, 1795000000, 4)])
        res_f = survey_float(fl, acc, mag, fc)
        err = 0.0
        for k in ("inc", "dip"):
            err = max(err, float(np.abs(res_f[k] - gs[k] / 65536.0).max()))
        for k in ("azi", "gtf", "mtf"):
            d = (res_f[k] - gs[k] / 65536.0 + 180.0) % 360.0 - 180.0
            err = max(err, float(np.abs(d).max()))
        stack = max(stack_bytes(fx, r, setup=enc_cal(fc)) for r in recs[:3])
        sz = sizes(fx)
        fsz = sizes(fl)
    s = _stats(cyc_s)
    f = _stats(cyc_f)
    ratio = s.mean / f.mean
    meets_c = s.max <= TARGET_SURVEY_CYCLES
    meets_r = ratio <= TARGET_FLOAT_RATIO
    parser_cpu = float(np.mean(cyc_feed)) / (BUS_HZ * 10 / 115_200)
    meets_p = parser_cpu <= TARGET_PARSER_CPU
    return McuBench(
        target="Freescale S08 (ucsim shc08 -t HCS08), bus cycles",
        compiler=f"SDCC {_sdcc_version()}",
        cflags=list(CFLAGS),
        functions={k: _stats(v) for k, v in funcs.items()},
        survey=s,
        survey_float=f,
        fixed_to_float_ratio=ratio,
        survey_ms_at_20mhz=s.mean / BUS_HZ * 1e3,
        survey_stack_bytes=stack,
        sizes=sz,
        float_sizes={"image_code_bytes": fsz.image_code_bytes, "image_ram_bytes": fsz.image_ram_bytes},
        float_max_abs_err_deg=err,
        frame_parser_cycles_per_byte=_stats(cyc_feed),
        frame_parser_cpu_at_115200_baud=parser_cpu,
        calimg_parse_cycles=int(cyc_img[0]),
        targets={"survey_max_cycles": TARGET_SURVEY_CYCLES, "fixed_to_float_ratio": TARGET_FLOAT_RATIO,
                 "frame_parser_cpu_at_115200_baud": TARGET_PARSER_CPU},
        meets_cycle_target=meets_c,
        meets_ratio_target=meets_r,
        passed=meets_c and meets_r and meets_p,
        meets_parser_target=meets_p,
    )

