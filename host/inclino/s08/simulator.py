"""The ucsim S08 simulator as a process: one-shot runs of a byte stream
through its simulator interface (a byte port at 0xff00) under a time
limit, cycle counts from its own counter, the deepest stack of a call."""
from __future__ import annotations

import os
import re
import subprocess
import tempfile
from concurrent.futures import ThreadPoolExecutor
from pathlib import Path
from inclino.s08.toolchain import McuBuild, McuError, SIMIF, TIMED


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
