"""`inclino bench input`: `attitude`, `calibrate` and `diagnose` on a long run.

Writes a raw run of ROWS rows (the bench probe of `inclino bench
calibration` on the 120 multi-position poses, each held for ROWS / 120
consecutive readings; about 190 MB) into a temporary folder, then runs each
command in its own process and reports its peak resident memory
(getrusage ru_maxrss of that process) and wall time against the target
(peak RSS <= 1 GB = 10^9 bytes, docs/dataset.md "Long runs").  A figure, not
an assertion: exit status 1 when a target is missed.
"""
from __future__ import annotations

import json
import os
import subprocess
import sys
import tempfile
import time
from dataclasses import asdict, dataclass, field

import numpy as np
from inclino.formats.jsonout import dumps

ROWS = 1_330_000
TARGET_RSS_BYTES = 10**9
COMMANDS = {
    "attitude": ["attitude", "{run}", "-o", "{tmp}/attitude.csv"],
    "calibrate": ["calibrate", "{run}", "-o", "{tmp}/cal.json"],
    "diagnose": ["diagnose", "{run}"],
}
_CHILD = ("import resource, sys\nfrom inclino.cli import main\nrc = main(sys.argv[1:])\n"
          "sys.stderr.write('\\nmaxrss_kib=%d\\n' % resource.getrusage(resource.RUSAGE_SELF).ru_maxrss)\n"
          "sys.exit(rc)\n")


@dataclass
class InputBench:
    rows: int
    file_bytes: int
    target_rss_bytes: int = TARGET_RSS_BYTES
    commands: dict = field(default_factory=dict)  # name -> {exit, peak_rss_bytes, wall_s, met}
    passed: bool = False

    def to_json(self) -> str:
        return dumps(asdict(self))

    @staticmethod
    def from_json(text: str) -> "InputBench":
        return InputBench(**json.loads(text))


def write_run(path: str, rows: int = ROWS, seed: int = 5) -> None:
    """The long run: emulated readings, written in blocks (fast, bounded)."""
    from inclino.benchmarks import calibration as bench
    from inclino.calib import runs
    from inclino.formats.dataset import COLUMN_ORDER, META_KEYS
    from inclino.model.scenario import generate_raw

    s = bench.bench_probe(linear=True)
    inc, azi, tf = runs.multi_position(120)
    rep = -(-rows // len(inc))
    with open(path, "w", encoding="utf-8", newline="") as f:
        block = 100_000
        for lo in range(0, rows, block):
            hi = min(rows, lo + block)
            sel = np.arange(lo, hi) // rep
            ds = generate_raw(s, inc[sel], azi[sel], tf[sel], t_s=np.arange(lo, hi) * 0.01, seed=seed)
            cols = [c for c in COLUMN_ORDER if c in ds.columns]
            if lo == 0:
                for k in META_KEYS:
                    if k in ds.meta:
                        f.write(f"# {k}={ds.meta[k]}\n")
                f.write(",".join(cols) + "\n")
            text = np.char.mod("%.10g", np.stack([ds.columns[c] for c in cols], axis=1))
            f.write("\n".join(",".join(r) for r in text.tolist()) + "\n")


def run_command(argv: list[str]) -> dict:
    t0 = time.perf_counter()
    env = dict(os.environ, INCLINO_PROGRESS="0")
    r = subprocess.run([sys.executable, "-c", _CHILD, *argv], capture_output=True, text=True, env=env)
    wall = time.perf_counter() - t0
    rss = None
    for line in r.stderr.splitlines():
        if line.startswith("maxrss_kib="):
            rss = int(line.split("=", 1)[1]) * 1024
    err = [l for l in r.stderr.splitlines() if l and not l.startswith("maxrss_kib=")]
    return {"exit": r.returncode, "peak_rss_bytes": rss, "wall_s": round(wall, 2),
            "met": bool(rss is not None and rss <= TARGET_RSS_BYTES and r.returncode in (0, 1)),
            "stderr": err[-1] if err else ""}


def bench(rows: int = ROWS) -> InputBench:
    with tempfile.TemporaryDirectory(prefix="inclino-bench-input-") as tmp:
        run = os.path.join(tmp, "run.csv")
        write_run(run, rows)
        res = InputBench(rows=rows, file_bytes=os.path.getsize(run))
        for name, argv in COMMANDS.items():
            res.commands[name] = run_command([a.format(run=run, tmp=tmp) for a in argv])
        res.passed = all(c["met"] for c in res.commands.values())
    return res


def text(r: InputBench) -> str:
    lines = [f"{r.rows} rows ({r.file_bytes / 1e6:.0f} MB); target peak RSS <= {r.target_rss_bytes / 1e9:g} GB"]
    for name, c in r.commands.items():
        rss = "-" if c["peak_rss_bytes"] is None else f"{c['peak_rss_bytes'] / 1e6:.0f} MB"
        lines.append(f"  {name:10s} peak RSS {rss:>8s}, {c['wall_s']:6.1f} s, exit {c['exit']}"
                     + ("" if c["met"] else "  NOT met" + (f" ({c['stderr']})" if c["stderr"] else "")))
    lines.append("  verdict: " + ("pass" if r.passed else "FAIL"))
    return "\n".join(lines)
