"""`inclino bench NAME [--json]`: the benchmarks, one function a name
(BENCHMARKS), each printing its figures (text, or one JSON object with
--json) and returning the exit status: 0, or 1 when the benchmark states
targets and they are not met.  The measuring is in inclino.benchmarks
(imported when a benchmark runs).

The diagnosis benchmark with its sizes chosen, and its near-limit miss
rates, are `python -m inclino.cli.bench_diagnose` (a module of its own, so
that running it does not import it twice: docs/diagnose.md)."""
from __future__ import annotations

import argparse
import json

from inclino.cli.options import add_json, add_plot, command
from inclino.errors import InclinoError


def _accuracy(args) -> int:
    from inclino.benchmarks import fixed_point as bench

    r = bench.accuracy(field_nT=args.field, dip_deg=args.dip)
    print(r.to_json() if args.json else _accuracy_text(r))
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
    if r.temperature:
        t = r.temperature
        lines.append(f"  temperature path (image version 2), C vs float64 with the same terms, worst over "
                     f"{', '.join(f'{x:g}' for x in t['temperatures_c'])} degC: azimuth max "
                     f"{t['worst']['azi_max_deg']:.2g}, inclination max {t['worst']['inc_max_deg']:.2g} deg")
    lines.append("  verdict: " + ("pass" if r.passed else "FAIL"))
    return "\n".join(lines)


def _speed(args) -> int:
    from inclino.benchmarks import fixed_point as bench

    r = bench.speed(vectors=args.vectors)
    print(r.to_json() if args.json else
          f"batched C: {r.batched_vectors_per_s:,.0f} vectors/s; golden: {r.golden_vectors_per_s:,.0f}"
          f" vectors/s; per call: {r.per_call_vectors_per_s:,.0f} vectors/s"
          f" (cost ratio {r.per_call_to_batched_cost_ratio:.0f})")
    return 0


def _calibration(args) -> int:
    from inclino.benchmarks.calibration import bench_calibration

    if args.section == "temperature":  # alone (benchmarks/calibration_temperature.py)
        from inclino.benchmarks import calibration_temperature as bench_temp

        t = bench_temp.bench_temperature()
        print(t.to_json() if args.json else bench_temp.text(t))
        return 0 if t.passed else 1
    if args.section == "time":  # alone (benchmarks/calibration_time.py)
        from inclino.benchmarks import calibration_time as bench_time

        plot = None
        if args.plot:
            import os

            from inclino.cli.options import plot_target
            from inclino.plotting import make_dir

            folder, name = plot_target(args.plot, "calibration-time.png")
            make_dir(folder, "the figures' folder")
            plot = os.path.join(folder, name)
        t = bench_time.bench_time(plot=plot)
        print(t.to_json() if args.json else bench_time.text(t))
        return 0 if t.passed else 1
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


def _input(args) -> int:
    from inclino.benchmarks import input as bench_input

    r = bench_input.bench(quick=getattr(args, "quick", False))
    print(r.to_json() if args.json else bench_input.text(r))
    return 0 if r.passed else 1


def _diagnose(args) -> int:
    """`inclino bench diagnose [--json] [--quick]`."""
    from inclino.benchmarks.diagnose import bench_diagnose

    r = bench_diagnose(quick=getattr(args, "quick", False))
    print(r.to_json() if getattr(args, "json", False) else r.summary())
    return 0 if r.passed else 1


def _demo(args) -> int:
    """`inclino bench demo [--json] [--quick]`: the demo's prediction against its acceptance over seeds."""
    from inclino.benchmarks.demo_prediction import bench_demo

    r = bench_demo(seeds=3 if getattr(args, "quick", False) else 10)
    print(r.to_json() if getattr(args, "json", False) else r.summary())
    return 0 if r.passed else 1


def _survey(args) -> int:
    """`inclino bench survey [--json] [--plot PNG]`: the benchmark drives the
    real commands in-process through the command runner add_bench was given
    (inclino.cli.main: this module does not import its own package)."""
    from inclino.benchmarks.survey import bench, text

    plot = None
    if args.plot:
        import os

        from inclino.cli.options import plot_target

        folder, name = plot_target(args.plot, "survey-wellpath.png")
        os.makedirs(folder, exist_ok=True)
        plot = os.path.join(folder, name)
    try:
        r = bench(plot=plot, cli_main=args.cli_main)
    except RuntimeError as e:  # a step of the chain (emulator, a command) failed: its message, no traceback
        raise InclinoError(str(e))
    print(r.to_json() if args.json else text(r))
    return 0 if r.passed else 1


def _link(args) -> int:
    from inclino.benchmarks import link as bench_link

    r = bench_link.bench()
    print(r.to_json() if args.json else
          f"stream: {r.stream_link_fraction:.1%} of the link; download: {r.download_ratio:.2f} x the minimum "
          f"bytes ({r.download_verify_ratio:.2f} x with verify)")
    return 0


def _emulator(args) -> int:
    from inclino.benchmarks import emulator as bench_emulator

    r = bench_emulator.bench()
    print(r.to_json() if args.json else
          f"emulator: {r.realtime_factor:.1f} x real time ({r.samples_per_wall_s:.0f} samples/s), "
          f"target >= {r.target_realtime_factor:g}")
    return 0


def _mcu(args) -> int:
    try:
        from inclino.benchmarks import s08
    except ImportError:
        raise InclinoError("the S08 simulator bench is not part of this build")
    r = s08.bench()
    print(r.to_json())
    return 0


def _realdata(args) -> int:
    """`inclino bench realdata`: held-out |g| of a pose-free calibration of real logs (benchmarks/realdata.py)."""
    from inclino.benchmarks import realdata

    r = realdata.run()
    print(r.to_json() if args.json else "\n".join(r.lines()))
    return 0 if r.passed else 1


def _attitude_temperature(args) -> int:
    """`inclino bench attitude-temperature`: attitude --cal with temperature terms on an oven run, every engine."""
    from inclino.benchmarks import attitude_temperature as bench_at

    r = bench_at.run(args.cli_main)
    print(r.to_json() if args.json else "\n".join(r.lines()))
    return 0 if r.passed else 1


# NAME -> function(args) -> exit status; the order is the order `--help` lists them
BENCHMARKS = {"accuracy": _accuracy, "speed": _speed, "mcu": _mcu, "emulator": _emulator, "link": _link,
              "calibration": _calibration, "diagnose": _diagnose, "input": _input, "survey": _survey,
              "demo": _demo, "realdata": _realdata, "attitude-temperature": _attitude_temperature}


def _cmd_bench(args) -> int:
    return BENCHMARKS[args.what](args)


def add_bench(sub, cli_main):
    be = command(sub, "bench", "benchmarks (figures, JSON with --json)",
                 "Measure and print a benchmark's figures next to its targets (JSON with --json): fixed-point "
                 "accuracy and speed, the S08's cycles and size, the emulator's and the link's throughput, the "
                 "calibration methods against the Cramer-Rao floor, the diagnosis's detection rates, input "
                 "memory, the survey chain, the demo's prediction against its acceptance over seeds. Exit 1 when a benchmark states targets and misses them.",
                 ["inclino bench accuracy", "inclino bench calibration --json",
                  "inclino bench survey --plot figures"])
    be.add_argument("what", choices=tuple(BENCHMARKS), help="the benchmark to run")
    add_json(be, "print one JSON object")
    be.add_argument("--field", type=float, default=50000.0, help="accuracy: total field, nT (default %(default)g)")
    be.add_argument("--dip", type=float, default=60.0, help="accuracy: dip, degrees (default %(default)g)")
    be.add_argument("--vectors", type=int, default=1_000_000, help="speed: batch size (default %(default)s)")
    be.add_argument("--quick", action="store_true", help="diagnose, demo, input: a small set (not the targets' figures)")
    add_plot(be, "survey: also draw the first seed's well path and ellipses into this folder (survey-wellpath.png); "
                 "calibration --section time: the first probe's predicted accuracy against bench time "
                 "(calibration-time.png)")
    be.add_argument("--section", choices=("all", "temperature", "time"), default="all",
                    help="calibration: only the temperature section, or only bench time against accuracy "
                         "(today's procedures and the adaptive ones; default %(default)s)")
    be.set_defaults(func=_cmd_bench, cli_main=cli_main)
