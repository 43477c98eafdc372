"""`inclino bench input`: memory and time of the commands that read long
inputs, each on its input at full size and at a quarter of it.

Cases (each command in its own process; the inputs written into a
temporary folder first):

* a raw run of 1.33 M rows (the bench probe of `inclino bench calibration`
  on the 120 multi-position poses, each held for rows / 120 consecutive
  readings; about 190 MB): `attitude`, `calibrate`, `diagnose`;
* a chamber run with temperature of 10^6 rows (the typical probe with its
  tempcos drawn, the 120 poses at -5, 25 and 55 degC with ramp rows
  between, that run repeated to 10^6 rows, as a long logging session
  repeats it): `calibrate --temperature-terms on`, `diagnose`, `diagnose
  --cal` with that calibration;
* a survey listing of 10^6 stations: `trajectory`;
* two listings of 10^5 stations (in-run and out-run of one hole): `compare`
  with the ISCWSA MWD revision 5 model.

Per case: peak resident memory (the command's process: its VmHWM on
Linux, else getrusage's ru_maxrss) and wall and CPU time (user + system of that process), at full
size and at a quarter; the time exponent p = log(cpu_full / cpu_quarter) /
log 4 (1 for time linear in the input, 2 for quadratic; fixed costs such as
the imports pull it below 1).  Targets: peak RSS <= 1 GB (10^9 bytes) and p
<= 1.25 on every case, the command's exit 0 or 1.  A figure, not an
assertion: exit status 1 when a target is missed.  --quick: a tenth of
every size (a check of the machinery, not the targets' figures).
"""
from __future__ import annotations

import json
import math
import os
import resource
import subprocess
import sys
import tempfile
import time
from dataclasses import asdict, dataclass, field

import numpy as np
from inclino.formats.jsonout import dumps

ROWS = 1_330_000
TEMP_ROWS = 1_000_000
STATIONS = 1_000_000
PAIRS = 100_000
TARGET_RSS_BYTES = 10**9
MAX_TIME_EXPONENT = 1.25
# name -> (input, full size, argv); {run} the input at the size, {tmp} the folder, {size} its size
CASES = {
    "attitude": ("run", ROWS, ["attitude", "{run}", "-o", "{tmp}/attitude-{size}.csv"]),
    "calibrate": ("run", ROWS, ["calibrate", "{run}", "-o", "{tmp}/cal-{size}.json"]),
    "diagnose": ("run", ROWS, ["diagnose", "{run}"]),
    "calibrate temperature": ("temperature", TEMP_ROWS, ["calibrate", "{run}", "--temperature-terms", "on",
                                                         "-o", "{tmp}/cal-t-{size}.json"]),
    "diagnose temperature": ("temperature", TEMP_ROWS, ["diagnose", "{run}"]),
    "diagnose --cal temperature": ("temperature", TEMP_ROWS, ["diagnose", "{run}", "--cal",
                                                              "{tmp}/cal-t-{size}.json"]),
    "trajectory": ("listing", STATIONS, ["trajectory", "{run}", "--declination", "2", "-o",
                                         "{tmp}/path-{size}.csv"]),
    "compare": ("pairs", PAIRS, ["compare", "{run}", "{run_b}", "--tool-model", "iscwsa-mwd-rev5",
                                 "--declination", "2", "--dip", "60", "--field", "50000", "--json"]),
}
# the command's peak: VmHWM, the high-water mark of its own memory (Linux); getrusage's ru_maxrss also
# holds the bench process's own peak, carried through the exec (every small case read 365 MB)
_CHILD = ("import resource, sys\nfrom inclino.cli import main\nrc = main(sys.argv[1:])\n"
          "u = resource.getrusage(resource.RUSAGE_SELF)\nkib = u.ru_maxrss\n"
          "try:\n    kib = int(next(l for l in open('/proc/self/status') if l.startswith('VmHWM:')).split()[1])\n"
          "except (OSError, StopIteration, ValueError, IndexError):\n    pass\n"
          "sys.stderr.write('\\nmaxrss_kib=%d cpu_s=%.3f\\n' % (kib, u.ru_utime + u.ru_stime))\n"
          "sys.exit(rc)\n")


@dataclass
class InputBench:
    sizes: dict = field(default_factory=dict)  # input -> full size
    target_rss_bytes: int = TARGET_RSS_BYTES
    max_time_exponent: float = MAX_TIME_EXPONENT
    # name -> {size, quarter: {...}, full: {exit, peak_rss_bytes, wall_s, cpu_s}, time_exponent, met}
    commands: dict = field(default_factory=dict)
    passed: bool = False
    quick: bool = False

    def to_json(self) -> str:
        return dumps(asdict(self))

    @staticmethod
    def from_json(text: str) -> "InputBench":
        return InputBench(**json.loads(text))


def _write_rows(f, ds, first: bool) -> None:
    from inclino.formats.dataset import COLUMN_ORDER, META_KEYS

    cols = [c for c in COLUMN_ORDER if c in ds.columns]
    if first:
        for k in META_KEYS:
            if k in ds.meta:
                f.write(f"# {k}={ds.meta[k]}\n")
        f.write(",".join(cols) + "\n")
    text = np.char.mod("%.10g", np.stack([ds.columns[c] for c in cols], axis=1))
    f.write("\n".join(",".join(r) for r in text.tolist()) + "\n")


def write_run(path: str, rows: int = ROWS, seed: int = 5) -> None:
    """The long run: emulated readings, written in blocks (fast, bounded)."""
    from inclino.benchmarks import calibration as bench
    from inclino.calib import runs
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
            _write_rows(f, ds, lo == 0)


def chamber_plan(setpoints=(-5.0, 25.0, 55.0), poses: int = 120, ramp_rows: int = 24):
    """(inc, azi, tf, temp_c) of one chamber run: at each set point ramp rows
    at the ramp poses, the temperature moving from the last set point to this
    one, then the pose set at the set point (acquire --procedure temperature's
    order)."""
    from inclino.calib import runs
    from inclino.procedures.acquire_temp import RAMP_POSES

    inc, azi, tf = runs.multi_position(poses)
    parts = []
    last = 25.0
    for sp in setpoints:
        k = np.arange(ramp_rows)
        rp = [RAMP_POSES[i % len(RAMP_POSES)] for i in k]
        parts.append((np.array([p.inc for p in rp]), np.array([p.azi for p in rp]), np.array([p.tf for p in rp]),
                      last + (sp - last) * (1.0 - np.exp(-3.0 * (k + 1) / ramp_rows))))
        parts.append((inc, azi, tf, np.full(len(inc), sp)))
        last = sp
    return tuple(np.concatenate([p[i] for p in parts]) for i in range(4))


def write_temperature_run(path: str, rows: int = TEMP_ROWS, seed: int = 7) -> None:
    """A chamber run with temperature repeated to `rows` rows (the typical
    probe, its tempcos drawn with `seed`), written in blocks."""
    from inclino.benchmarks.calibration_temperature import drawn_probe
    from inclino.model.scenario import generate_raw

    s = drawn_probe(seed)
    inc, azi, tf, temp = chamber_plan()
    with open(path, "w", encoding="utf-8", newline="") as f:
        block = 100_000
        for lo in range(0, rows, block):
            hi = min(rows, lo + block)
            sel = np.arange(lo, hi) % len(inc)
            ds = generate_raw(s, inc[sel], azi[sel], tf[sel], t_s=np.arange(lo, hi) * 1.0, temp_c=temp[sel],
                              seed=seed + lo)
            ds.meta.update(field_nT=50000.0, dip_deg=60.0)
            _write_rows(f, ds, lo == 0)


def write_listing(path: str, n: int, seed: int = 1, step_m: float = None) -> None:
    """A survey listing of n stations: a build to 60 deg and a slow turn,
    with survey noise; depth from 0 at step_m (default: the hole's 10^5 m
    limit over n, at most 30 m)."""
    rng = np.random.default_rng(seed)
    step = step_m or min(30.0, 99_000.0 / max(n, 1))
    md = np.arange(n) * step
    frac = md / max(md[-1], 1.0)
    inc = np.abs(np.clip(frac * 120.0, 0.0, 60.0) + rng.normal(0, 0.05, n))
    azi = np.mod(30.0 + 20.0 * np.sin(frac * 2 * math.pi) + rng.normal(0, 0.1, n), 360.0)
    with open(path, "w", encoding="utf-8", newline="") as f:
        f.write("md_m,inc_deg,azi_deg\n")
        for lo in range(0, n, 100_000):
            hi = min(n, lo + 100_000)
            text = np.char.mod("%.3f", np.stack([md[lo:hi], inc[lo:hi], azi[lo:hi]], axis=1))
            f.write("\n".join(",".join(r) for r in text.tolist()) + "\n")


def run_command(argv: list[str]) -> dict:
    t0 = time.perf_counter()
    env = dict(os.environ, INCLINO_PROGRESS="0")
    r = subprocess.run([sys.executable, "-c", _CHILD, *argv], capture_output=True, text=True, env=env)
    wall = time.perf_counter() - t0
    rss = cpu = None
    for line in r.stderr.splitlines():
        if line.startswith("maxrss_kib="):
            a, b = line.split()
            rss = int(a.split("=", 1)[1]) * 1024
            cpu = float(b.split("=", 1)[1])
    err = [l for l in r.stderr.splitlines() if l and not l.startswith("maxrss_kib=")]
    return {"exit": r.returncode, "peak_rss_bytes": rss, "wall_s": round(wall, 2),
            "cpu_s": None if cpu is None else round(cpu, 2), "stderr": err[-1] if err else ""}


def _inputs(kind: str, size: int, tmp: str) -> dict:
    p = os.path.join(tmp, f"{kind}-{size}")
    if kind == "run":
        write_run(p + ".csv", size)
    elif kind == "temperature":
        write_temperature_run(p + ".csv", size)
    elif kind == "listing":
        write_listing(p + ".csv", size)
    else:  # pairs: in-run and out-run of one hole at 1 m, the out-run surveyed again (another noise)
        write_listing(p + ".csv", size, seed=1, step_m=1.0 if size <= 99_000 else 99_000.0 / size)
        write_listing(p + "-b.csv", size, seed=2, step_m=1.0 if size <= 99_000 else 99_000.0 / size)
        return {"run": p + ".csv", "run_b": p + "-b.csv"}
    return {"run": p + ".csv"}


def bench(quick: bool = False, scale: int | None = None) -> InputBench:
    """Every case at full size and a quarter (sizes divided by `scale`;
    quick: by 10)."""
    scale = scale or (10 if quick else 1)
    res = InputBench(quick=quick)
    with tempfile.TemporaryDirectory(prefix="inclino-bench-input-") as tmp:
        files = {}
        for name, (kind, full, argv) in CASES.items():
            full //= scale
            res.sizes[kind] = full
            c = {"input": kind, "size": full}
            for label, size in (("quarter", full // 4), ("full", full)):
                if (kind, size) not in files:
                    files[(kind, size)] = _inputs(kind, size, tmp)
                f = files[(kind, size)]
                c[label] = run_command([a.format(tmp=tmp, size=size, **f) for a in argv])
            q, f = c["quarter"], c["full"]
            p = None
            if q["cpu_s"] and f["cpu_s"]:
                p = round(math.log(f["cpu_s"] / q["cpu_s"]) / math.log(4.0), 3)
            c["time_exponent"] = p
            c["met"] = bool(all(r["peak_rss_bytes"] is not None and r["peak_rss_bytes"] <= TARGET_RSS_BYTES
                                and r["exit"] in (0, 1) for r in (q, f))
                            and p is not None and p <= MAX_TIME_EXPONENT)
            res.commands[name] = c
            for (k, sz), fl in list(files.items()):  # an input no later case reads is removed
                if not any(CASES[n][0] == k for n in list(CASES)[list(CASES).index(name) + 1:]):
                    for path in fl.values():
                        if os.path.exists(path):
                            os.remove(path)
                    del files[(k, sz)]
        res.passed = all(c["met"] for c in res.commands.values())
    return res


def text(r: InputBench) -> str:
    lines = [f"peak RSS <= {r.target_rss_bytes / 1e9:g} GB and time exponent <= {r.max_time_exponent:g} "
             "(CPU time at full size against a quarter)" + (" -- quick: a tenth of every size" if r.quick else "")]
    for name, c in r.commands.items():
        f, q = c["full"], c["quarter"]
        rss = "-" if f["peak_rss_bytes"] is None else f"{f['peak_rss_bytes'] / 1e6:.0f} MB"
        rq = "-" if q["peak_rss_bytes"] is None else f"{q['peak_rss_bytes'] / 1e6:.0f} MB"
        p = "-" if c["time_exponent"] is None else f"{c['time_exponent']:.2f}"
        bad = [x for x in (f, q) if x["exit"] not in (0, 1)]
        lines.append(f"  {name:27s} {c['size']:>9d} {c['input']:12s} peak RSS {rss:>8s} ({rq} at a quarter), "
                     f"CPU {f['cpu_s']} s ({q['cpu_s']} s), wall {f['wall_s']:.1f} s, exponent {p}, exit {f['exit']}"
                     + ("" if c["met"] else "  NOT met" + (f" ({bad[0]['stderr']})" if bad else "")))
    lines.append("  verdict: " + ("pass" if r.passed else "FAIL"))
    return "\n".join(lines)
