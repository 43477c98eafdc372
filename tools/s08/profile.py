"""Where the bus cycles of one survey go on the S08 simulator.

Builds the harness image (inclino.s08.mcu.build), runs one timed survey_compute
and single-steps ucsim between the harness's two timing stops, adding each
instruction's cycles (the simulator's own count) to the function it belongs
to (the labels of SDCC's .rst listings, static functions included) and to
its C source line.  Assembly helpers that are not C functions (fx_m_core,
fx_sq_core, ...) count towards the C function whose listing holds them.

    python tools/s08/profile.py                  # the first bench vector
    python tools/s08/profile.py --vector 7 --lines 30
    python tools/s08/profile.py --acc=1,-11584,-11584 --mag=-2,-35356,-35356 --identity
    python tools/s08/profile.py --func _fx_div_frac_q20   # per instruction

Run inside the source tree (or with INCLINO_ROOT set), with an installed
inclino (for inclino.s08 and the bench vectors).  It measures; it asserts
nothing.
"""
from __future__ import annotations

import argparse
import bisect
import re
import subprocess
import tempfile
from collections import defaultdict
from pathlib import Path

import numpy as np

from inclino.benchmarks import s08 as s08_bench
from inclino.s08 import harness as s08_harness
from inclino.s08 import toolchain as s08_toolchain

_INSN = re.compile(r"^\s+([0-9A-F]{4})\s+[0-9A-F]{2}[0-9A-F ]*?\s+\[\s*\d+\]")
_LABEL = re.compile(r"^\s+([0-9A-F]{4})\s+\d+\s+(_\w+):\s*$")
_SRC = re.compile(r"^\s+\d+\s+;(\S+?):(\d+):")
_STEP = re.compile(rb"Stop at 0x([0-9a-f]+): \(\d+\) stepped (\d+) ticks")


def code_map(workdir):
    """Sorted (address, label) of the code labels, and for each instruction
    address its C source line and its listing line."""
    labels, src, listing = [], {}, {}
    for rst in Path(workdir).glob("*.rst"):
        cur = None
        for line in rst.read_text(errors="replace").splitlines():
            m = _SRC.match(line)
            if m:
                cur = f"{Path(m.group(1)).name}:{m.group(2)}"
                continue
            m = _LABEL.match(line)
            if m:
                labels.append((int(m.group(1), 16), m.group(2)))
                continue
            m = _INSN.match(line)
            if m:
                a = int(m.group(1), 16)
                src[a] = cur or rst.stem
                listing[a] = line.strip()
    labels.sort()
    return labels, src, listing


def main(argv=None) -> int:
    ap = argparse.ArgumentParser(prog="tools/s08/profile.py", description=__doc__.splitlines()[0])
    ap.add_argument("--workdir", help="build directory (default: a new temporary one)")
    ap.add_argument("--vector", type=int, default=0, help="which of s08_bench.bench_vectors()")
    ap.add_argument("--acc", help="raw accelerometer counts a,b,c instead of a bench vector")
    ap.add_argument("--mag", help="raw fluxgate counts a,b,c (with --acc)")
    ap.add_argument("--identity", action="store_true", help="the identity calibration")
    ap.add_argument("--temperature", action="store_true",
                    help="survey_compute_temp with the typical temperature terms (inclino.s08.temperature)")
    ap.add_argument("--lines", type=int, default=0, help="also the N costliest source lines")
    ap.add_argument("--func", help="also each instruction of this function (a label, e.g. _att_norm3)")
    ap.add_argument("--max-steps", type=int, default=60000)
    a = ap.parse_args(argv)

    wd = a.workdir or tempfile.mkdtemp(prefix="inclino-profile-")
    b = s08_toolchain.build(wd)
    labels, src, listing = code_map(wd)
    addrs = [x for x, _ in labels]
    acc, mag, fc = s08_bench.bench_vectors(a.vector + 1)
    acc, mag = acc[a.vector:a.vector + 1], mag[a.vector:a.vector + 1]
    if a.acc:
        acc = np.array([[int(v) for v in a.acc.split(",")]])
        mag = np.array([[int(v) for v in a.mag.split(",")]])
    if a.identity:
        from inclino.engines.firmware import FixedCal
        fc = FixedCal.identity()
    rec = s08_harness._records(b"V", (acc, ">i4"), (mag, ">i4"))[0]
    setup = s08_harness.enc_cal(fc)
    entry = "_survey_compute"
    if a.temperature:
        from inclino.s08 import temperature as s08_temp
        acc_t, mag_t, tq, fct = s08_bench.bench_inputs(a.vector + 1, 11)
        rec = s08_temp.records(acc_t[a.vector:a.vector + 1], mag_t[a.vector:a.vector + 1],
                               tq[a.vector:a.vector + 1])[0]
        setup, entry = s08_temp.enc_setup(fct), "_survey_compute_temp"
    data = setup + bytes([rec[0] | s08_toolchain.TIMED]) + rec[1:] + b"E"
    with tempfile.TemporaryDirectory(prefix="inclino-sim-") as td:
        fin, fout = Path(td) / "in.bin", Path(td) / "out.bin"
        fin.write_bytes(data)
        fout.write_bytes(b"")
        script = "run\n" + "step\n" * a.max_steps + "run\nrun\nquit\n"
        r = subprocess.run(["timeout", "600", "shc08", "-t", "HCS08", "-b", "-I",
                            f"if={s08_toolchain.SIMIF},in={fin},out={fout}", b.ihx],
                           input=script.encode(), capture_output=True)
    start = dict((n, x) for x, n in labels)[entry]
    fn_t, ln_t, calls = defaultdict(int), defaultdict(int), defaultdict(int)
    ins_t, ins_n = defaultdict(int), defaultdict(int)
    prev, on, total, done = None, False, 0, False
    for pc, t in _STEP.findall(r.stdout):
        pc, t = int(pc, 16), int(t)
        if on:  # the cycles of the instruction at prev
            fn = labels[bisect.bisect_right(addrs, prev) - 1][1]
            if fn == "_do_survey":  # back in the harness
                done = True
                break
            fn_t[fn] += t
            ln_t[src.get(prev, "?")] += t
            total += t
            if fn == a.func:
                ins_t[prev] += t
                ins_n[prev] += 1
        if pc == start:
            on = True
        if on:
            i = bisect.bisect_right(addrs, pc) - 1
            if addrs[i] == pc:
                calls[labels[i][1]] += 1
        prev = pc
    if not done:
        raise SystemExit(f"the survey did not return within {a.max_steps} steps (--max-steps)")
    print(f"{entry[1:]}: {total} bus cycles")
    print(f"{'cycles':>8} {'share':>6} {'entries':>7}  function")
    for k, v in sorted(fn_t.items(), key=lambda kv: -kv[1]):
        print(f"{v:8d} {100 * v / total:5.1f}% {calls.get(k, 0):7d}  {k}")
    if a.func:
        print(f"\n{a.func}, per instruction (cycles, executions, listing):")
        for ad in sorted(ins_t):
            print(f"{ins_t[ad]:8d} {ins_n[ad]:5d}  {listing.get(ad, '')}")
    if a.lines:
        print("\ncostliest source lines:")
        for k, v in sorted(ln_t.items(), key=lambda kv: -kv[1])[:a.lines]:
            print(f"{v:8d} {100 * v / total:5.1f}%  {k}")
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
