"""The `inclino` command: a thin shell over the library.

Exit statuses: 0 success; 1 a check ran and failed; 2 bad input (file,
column, value, option); 3 calibration refused; 4 probe or port problem.
Every error is one line on stderr, never a traceback.
"""
from __future__ import annotations

import argparse
import csv
import json
import sys

import numpy as np

from inclino import __version__
from inclino.errors import DataError, InclinoError
from inclino.procedures.accept import add_parser as _add_accept
from inclino.procedures.acquire_temp import add_parser as _add_acquire  # acquire, with its temperature procedure
from inclino.cli.analysis import add_parser as _add_calibrate
from inclino.procedures.demo import add_parser as _add_demo
from inclino.cli.diagnose import add_parser as _add_diagnose
from inclino.boot.flashing import add_parser as _add_flash
from inclino.procedures.plots import add_parser as _add_plot
from inclino.cli.probe import add_parser as _add_probe_commands
from inclino.cli.survey import add_parser as _add_survey_commands


def _cmd_bitexact(args) -> int:
    from inclino.engines import bitexact

    if args.vectors < 0:
        raise DataError("--vectors must be >= 0")
    r = bitexact.run(args.vectors, args.seed)
    print(r.line)
    return 0 if r.mismatches == 0 else 1


ATTITUDE_CHUNK = 1 << 16  # rows computed and written at a time (bounded memory on a long run)


def _cmd_attitude(args) -> int:
    from inclino.formats import dataset, safeio
    from inclino.engines import attitude as engines
    from inclino import progress
    from inclino.formats.calfile import Calibration

    safeio.check_output(args.output, [args.input, args.cal])  # before any work
    cal = Calibration.load(args.cal) if args.cal else Calibration()  # a refused file costs no reading
    ds = dataset.read_raw(args.input, progress=True)
    cols = ["inc_deg", "azi_deg", "tf_deg", "gt_g", "bt_nT", "dip_deg", "flags", "mtf_deg"]
    with safeio.output_file(args.output, [args.input, args.cal]) as f, \
            progress.bar(len(ds), f"attitude {args.input}", unit=" rows") as bar:
        w = csv.writer(f)
        w.writerow(cols)
        acc, mag = ds.acc, ds.mag
        for lo in range(0, len(ds), ATTITUDE_CHUNK):
            hi = min(lo + ATTITUDE_CHUNK, len(ds))
            out = engines.run(acc[lo:hi], mag[lo:hi], cal, args.engine)
            text = {c: (out[c].astype(np.int64).astype(str) if c == "flags"
                        else np.char.mod("%.6f", np.asarray(out[c], dtype=float))) for c in cols}
            w.writerows(zip(*(text[c] for c in cols)))
            bar.update(hi - lo)
    return 0


def _cmd_bench(args) -> int:
    from inclino.benchmarks import fixed_point as bench

    if args.what == "accuracy":
        r = bench.accuracy(field_nT=args.field, dip_deg=args.dip)
        print(r.to_json() if args.json else _accuracy_text(r))
        return 0
    if args.what == "calibration":
        from inclino.benchmarks.calibration import bench_calibration

        r = bench_calibration()
        if args.json:
            print(r.to_json())
        else:
            for k, v in r.methods.items():
                print(f"{k:20s} " + (f"azimuth RMS {v['azi_rms_deg']:.4f} deg, inclination RMS {v['inc_rms_deg']:.4f}"
                                     f" deg" if "azi_rms_deg" in v else f"failed: {v.get('error', '')}"))
            print(f"{'Cramer-Rao floor':20s} azimuth RMS {r.cramer_rao['azi_rms_deg']:.4f} deg; targets "
                  + ("met" if r.passed else "NOT met: " + ", ".join(k for k, v in r.met.items() if v is False)))
        return 0 if r.passed else 1
    if args.what == "speed":
        r = bench.speed(vectors=args.vectors)
        print(r.to_json() if args.json else
              f"batched C: {r.batched_vectors_per_s:,.0f} vectors/s; golden: {r.golden_vectors_per_s:,.0f}"
              f" vectors/s; per call: {r.per_call_vectors_per_s:,.0f} vectors/s"
              f" (cost ratio {r.per_call_to_batched_cost_ratio:.0f})")
        return 0
    if args.what == "input":
        from inclino.benchmarks import input as bench_input

        r = bench_input.bench()
        print(r.to_json() if args.json else bench_input.text(r))
        return 0 if r.passed else 1
    if args.what == "diagnose":
        from inclino.benchmarks.diagnose import bench_command

        return bench_command(args)
    if args.what == "survey":
        from inclino.benchmarks.survey import bench_command

        return bench_command(args, main)
    if args.what == "link":
        from inclino.benchmarks import link as bench_link

        r = bench_link.bench()
        print(r.to_json() if args.json else
              f"stream: {r.stream_link_fraction:.1%} of the link; download: {r.download_ratio:.2f} x the minimum "
              f"bytes ({r.download_verify_ratio:.2f} x with verify)")
        return 0
    if args.what == "emulator":
        from inclino.benchmarks import emulator as bench_emulator

        r = bench_emulator.bench()
        print(r.to_json() if args.json else
              f"emulator: {r.realtime_factor:.1f} x real time ({r.samples_per_wall_s:.0f} samples/s), "
              f"target >= {r.target_realtime_factor:g}")
        return 0
    if args.what == "mcu":
        try:
            from inclino.s08 import mcu
        except ImportError:
            raise InclinoError("the S08 simulator bench is not part of this build")
        r = mcu.bench()
        print(r.to_json())
        return 0
    raise DataError(f"unknown benchmark {args.what!r}")


def _cmd_emulate(args) -> int:
    import signal
    import time

    from inclino.link.serial_link import BAUD_RANGE

    if not BAUD_RANGE[0] <= args.baud <= BAUD_RANGE[1]:
        raise DataError(f"--baud {args.baud}: a baud rate within {BAUD_RANGE[0]}-{BAUD_RANGE[1]}")
    if not 0 <= args.control <= 65535:
        raise DataError(f"--control {args.control}: a TCP port within 0-65535 (0: any free port)")

    try:
        from inclino_emu.runner import Emulator
    except ImportError as e:
        raise InclinoError(f"the emulator is not installed: {e}")
    try:
        emu = Emulator(scenario=args.scenario, seed=args.seed, baud=args.baud, link=args.link,
                       control_port=args.control, realtime=not args.unthrottled,
                       tempco_draw=args.tempco_draw)
    except FileNotFoundError as e:
        raise DataError(f"scenario not found: {e.filename or e}")
    except (OSError, ValueError, KeyError) as e:
        raise DataError(f"cannot start the emulator: {e}")
    print(f"inclino emulator: probe on {emu.path}" + (f" (link {args.link})" if args.link else ""), flush=True)
    if emu.control_port is not None:
        print(f"control channel: 127.0.0.1:{emu.control_port} (JSON lines, docs/emulator.md)", flush=True)
    stop = {"now": False}

    def _term(*_):
        stop["now"] = True

    signal.signal(signal.SIGTERM, _term)
    emu.start()
    try:
        while not stop["now"] and emu.error is None:
            time.sleep(0.1)
    except KeyboardInterrupt:
        pass
    try:
        emu.stop()
    except RuntimeError as e:
        raise InclinoError(str(e))
    print("inclino emulator: stopped", flush=True)
    return 0


def _accuracy_text(r) -> str:
    f = r.figures
    lines = [f"fixed point vs float64 on the same counts, {r.poses} poses (F={r.field_nT:g} nT, dip={r.dip_deg:g})"]
    for k, v in f.items():
        t = r.targets.get(k)
        lines.append(f"  {k:22s} {v:.6g}" + (f"   (target <= {t:g})" if t is not None else ""))
    if r.averaging:
        from inclino.benchmarks.averaging import AveragingResult
        lines += AveragingResult.from_json(json.dumps(r.averaging)).lines()
    lines.append("  verdict: " + ("pass" if r.passed else "FAIL"))
    return "\n".join(lines)


def build_parser() -> argparse.ArgumentParser:
    p = argparse.ArgumentParser(prog="inclino", description="Toolkit for magnetic borehole inclinometer probes.")
    p.add_argument("--version", action="version", version=f"inclino {__version__}")
    sub = p.add_subparsers(dest="command", required=True)

    _add_demo(sub)

    b = sub.add_parser("bitexact", help="firmware C against the golden model, bit for bit")
    b.add_argument("--vectors", type=int, default=1_000_000, help="random vectors besides the edge cases")
    b.add_argument("--seed", type=int, default=1)
    b.set_defaults(func=_cmd_bitexact)

    a = sub.add_parser("attitude", help="attitude of every row of a raw dataset")
    a.add_argument("input", help="raw dataset CSV")
    a.add_argument("--cal", help="calibration JSON (default: identity)")
    a.add_argument("--engine", choices=("firmware", "golden", "reference"), default="firmware")
    a.add_argument("-o", "--output", required=True, help="output CSV ('-' for stdout)")
    a.set_defaults(func=_cmd_attitude)

    em = sub.add_parser("emulate", help="run the emulated probe on a pseudo-terminal until interrupted")
    em.add_argument("--scenario", default="typical", help="built-in scenario name or TOML file (default typical)")
    em.add_argument("--seed", type=int, default=None, help="override the scenario's seed")
    em.add_argument("--baud", type=int, default=115200)
    em.add_argument("--link", help="also make this path a symlink to the pseudo-terminal")
    em.add_argument("--control", type=int, default=0,
                    help="control channel TCP port on 127.0.0.1 (default: any free port)")
    em.add_argument("--unthrottled", action="store_true", help="run faster than real time")
    em.add_argument("--tempco-draw", type=int, metavar="N", default=None,
                    help="draw this probe's tempcos from the scenario's spread with seed N (docs/emulator.md)")
    em.set_defaults(func=_cmd_emulate)

    be = sub.add_parser("bench", help="benchmarks (figures, JSON with --json)")
    be.add_argument("what", choices=("accuracy", "speed", "mcu", "emulator", "link", "calibration", "diagnose",
                                     "input", "survey"))
    be.add_argument("--json", action="store_true", help="print one JSON object")
    be.add_argument("--field", type=float, default=50000.0, help="accuracy: field total, nT")
    be.add_argument("--dip", type=float, default=60.0, help="accuracy: dip, degrees")
    be.add_argument("--vectors", type=int, default=1_000_000, help="speed: batch size")
    be.add_argument("--quick", action="store_true", help="diagnose: a small set (not the targets' figures)")
    be.add_argument("--plot", help="survey: also draw the first seed's well path and ellipses (PNG)")
    be.set_defaults(func=_cmd_bench)
    _add_calibrate(sub)
    _add_diagnose(sub)
    _add_flash(sub)
    _add_probe_commands(sub)
    _add_acquire(sub)
    _add_accept(sub)
    _add_plot(sub)
    _add_survey_commands(sub)
    return p


def main(argv: list[str] | None = None) -> int:
    parser = build_parser()
    args = parser.parse_args(argv)
    try:
        return int(args.func(args))
    except InclinoError as e:
        print(f"inclino: error: {e}", file=sys.stderr)
        return e.exit_code
    except KeyboardInterrupt as e:   # a command may say what the interruption left (inclino flash)
        print("inclino: interrupted" + (f": {e}" if str(e) else ""), file=sys.stderr)
        return 130
    except BrokenPipeError:
        return 0
    except MemoryError:  # one line, never a traceback (docs/cli.md: exit 2)
        print("inclino: error: out of memory: the input is too large for this machine's memory limit",
              file=sys.stderr)
        return 2


if __name__ == "__main__":  # pragma: no cover
    raise SystemExit(main())
