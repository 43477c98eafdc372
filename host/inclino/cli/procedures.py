"""The bench procedures' commands: acquire (pose and temperature runs),
accept, plot, demo.  Argument checks and printing here; the work in
inclino.procedures (imported when a command runs, so `inclino --help` stays
fast)."""
from __future__ import annotations

import sys

from inclino.cli.paths import Input, Output
from inclino.cli.options import add_cal, add_json, add_output, add_port, command, deprecated
from inclino.cli.options import add_plot as add_plot_option
from inclino.errors import DataError


def add_common(p) -> None:
    """Options acquire and accept share: port, bench, stability."""
    add_port(p)
    p.add_argument("--bench", metavar="HOST:PORT",
                   help="drive the emulator's turntable over its control channel (unattended; the address "
                        "`inclino emulate` prints); without it a person turns the table when asked")
    p.add_argument("--reads", type=int, default=3,
                   help="readings that must agree at each position (default %(default)s)")
    p.add_argument("--tol-acc-mg", type=float, default=1.0,
                   help="stability: accelerometer spread, mg (default %(default)g)")
    p.add_argument("--tol-mag-nt", type=float, default=20.0,
                   help="stability: fluxgate spread, nT (default %(default)g)")
    p.add_argument("--max-reads", type=int, default=30,
                   help="bench: readings before a position is given up (default %(default)s)")
    p.add_argument("--average", type=int, help="set the probe's samples per reading first (SET_AVERAGE, 1-64; "
                                              "the probe's default is 16, acquire --procedure temperature's "
                                              "64; it keeps it until it restarts)")
    p.add_argument("--quiet", action="store_true", help="no progress bar")


def open_table(args):
    """The turntable of `--bench HOST:PORT` (the emulator's, unattended), else a person at one."""
    if args.bench:
        from inclino.procedures.turntable_emulated import EmulatedTurntable

        return EmulatedTurntable(args.bench)
    from inclino.procedures.turntable import ManualTurntable

    return ManualTurntable()


def _cmd_acquire_poses(args) -> int:
    from inclino.link.serial_link import ProbeLink
    from inclino.procedures.acquire import acquire, procedure_steps
    from inclino.procedures.readings import Tolerance

    tol = Tolerance(args.tol_acc_mg, args.tol_mag_nt, args.reads)
    tol.check(args.max_reads)
    if args.average is not None and not 1 <= args.average <= 64:
        raise DataError("--average must be within 1-64 samples")
    procedure_steps(args.procedure, points=args.points, d1=args.d1, azimuth=args.azimuth, step_deg=args.step)
    world = {"field_nT": args.field, "dip_deg": args.dip, "declination_deg": args.declination}
    from inclino.formats.dataset import check_meta

    for key, opt in (("field_nT", "--field"), ("dip_deg", "--dip"), ("declination_deg", "--declination")):
        check_meta(key, world[key], opt)  # the header's rule, before the port is opened
    table = open_table(args)
    try:
        with ProbeLink(args.port, baud=args.baud, timeout=args.timeout) as link:
            r = acquire(link, args.procedure, args.output, table, points=args.points, d1=args.d1,
                        azimuth=args.azimuth, step_deg=args.step, tol=tol, max_reads=args.max_reads,
                        world=world, quiet=args.quiet, average=args.average, resume=args.resume)
    finally:
        table.close()
    print(f"{r.path}: {r.rows} rows, {args.procedure}, probe {r.probe_serial}"
          + (f", field {r.meta['field_nT']:g} nT dip {r.meta['dip_deg']:g} deg" if "dip_deg" in r.meta else "")
          + f" ({r.reads} readings, {r.elapsed_s:.1f} s)")
    return 0


# options only some procedures read; the rest come from the parser's groups
ONLY_FOR = {"points": ("multi-position",), "d1": ("continuous",), "azimuth": ("continuous",),
            "step": ("continuous",)}
GROUP_FOR = {"temperature procedure": ("temperature",), "adaptive procedure": ("adaptive",)}


def _procedure_options(p) -> dict:
    """dest -> (option, the procedures that read it, its default as parsed)
    for every acquire option that only some procedures read."""
    out = {}
    for g in p._action_groups:
        procs = next((v for k, v in GROUP_FOR.items() if (g.title or "").startswith(k)), None)
        for a in g._group_actions:
            only = ONLY_FOR.get(a.dest, procs)
            if only and a.option_strings and a.dest not in out:
                default = a.type(a.default) if isinstance(a.default, str) and callable(a.type) else a.default
                out[a.dest] = (a.option_strings[0], only, default)
    return out


def _check_procedure_options(args) -> None:
    """An option of another procedure would be ignored without a word (a
    twelve-position run with --temperatures is still one run at 25 degC):
    refused before the port is opened."""
    for dest, (opt, procs, default) in args.procedure_options.items():
        if args.procedure not in procs and getattr(args, dest, default) != default:
            raise DataError(f"{opt} is an option of --procedure {' or '.join(procs)}, not {args.procedure}: "
                            f"drop it, or choose that procedure")


def _add_soak(t, interval_help: str) -> None:
    """The chamber's timing options, acquire and accept --temperatures alike."""
    t.add_argument("--ramp-rate", type=float, default=1.0, help="chamber ramp, degC/min (default %(default)g)")
    t.add_argument("--interval-min", type=float, default=2.0, help=interval_help + " (default %(default)g)")
    deprecated(t, "--interval", "--interval-min", type=float)
    return t


def _add_settle(t) -> None:
    t.add_argument("--soak-band", type=float, default=1.0,
                   help="settled: within this of the set point, degC (default %(default)g) ...")
    t.add_argument("--soak-tol", type=float, default=0.5,
                   help="... and changing by at most this, degC (default %(default)g) ...")
    t.add_argument("--soak-window-min", type=float, default=10.0,
                   help="... over this many minutes (default %(default)g)")
    deprecated(t, "--soak-window", "--soak-window-min", type=float)
    t.add_argument("--max-soak-min", type=float, default=240.0,
                   help="bench: give up after this many minutes at one set point (default %(default)g)")
    deprecated(t, "--max-soak", "--max-soak-min", type=float)


def add_acquire(sub):
    from inclino.procedures.acquire import PROCEDURES

    p = command(sub, "acquire", "take a calibration run from the probe (operator or emulated bench)",
                "Take a calibration run: the probe read at each pose of the procedure until --reads readings "
                "agree, the turntable turned by a person (asked at each pose) or, with --bench, the emulator's "
                "turntable over its control channel; the temperature procedure takes the poses at each chamber "
                "set point after a soak. Writes the raw dataset that `inclino calibrate` fits.",
                ["inclino acquire --port /dev/ttyUSB0 --procedure twelve-position -o run.csv",
                 "inclino acquire --port /dev/pts/5 --bench 127.0.0.1:40123 --procedure multi-position "
                 "-o run.csv"])
    add_common(p)
    p.add_argument("--procedure", required=True, choices=PROCEDURES,
                   help="twelve-position (Li 2021), multi-position (Li + Ren 2014 + orientations), "
                        "continuous (Guo 2009), temperature (a chamber run: --temperatures), adaptive (poses "
                        "chosen until the predicted acceptance reaches the target; --chamber-range-c)")
    add_output(p, "raw dataset CSV to write (rows go to RUN.csv.part as they are taken; renamed at the end); "
                  "required unless --resume", required=False, metavar="RUN.csv")
    p.add_argument("--resume", metavar="RUN.csv.part", action=Output, help="continue the run an interruption left in RUN.csv.part "
                                                            "(same probe, calibration and procedure): the positions "
                                                            "it holds are not taken again")
    p.add_argument("--points", type=int, default=36,
                   help="multi-position: quasi-uniform orientations (default %(default)s)")
    p.add_argument("--d1", type=float, default=30.0, help="continuous: first inclination, deg (default %(default)g)")
    p.add_argument("--azimuth", type=float, default=2.0,
                   help="continuous: azimuth of both rotations, deg (default %(default)g)")
    p.add_argument("--step", type=float, default=10.0,
                   help="continuous on the bench: toolface step, deg (default %(default)g)")
    p.add_argument("--field", type=float, help="total field, nT, for the header (the bench reports its own)")
    p.add_argument("--dip", type=float, help="magnetic dip, deg, for the header")
    p.add_argument("--declination", type=float, help="declination, deg, for the header")
    t = p.add_argument_group("temperature procedure (docs/bench.md)")
    t.add_argument("--temperatures", default="-5,25,55", help="chamber set points, degC (default %(default)s)")
    t.add_argument("--poses", default="twelve-position", choices=("twelve-position", "multi-position"),
                   help="the pose set taken at each set point (default %(default)s)")
    _add_soak(t, "minutes between readings while the chamber ramps and soaks")
    t.add_argument("--ramp-poses", type=int, default=4, help="poses read through each ramp, 1-6 (default %(default)s)")
    _add_settle(t)
    from inclino.cli.adaptive import add_adaptive_options

    add_adaptive_options(p)
    negative_lists(p)
    p.set_defaults(func=_cmd_acquire, procedure_options=_procedure_options(p))
    return p


def _cmd_acquire(args) -> int:
    """`inclino acquire`: the temperature procedure (inclino.procedures.acquire_temp),
    the others (inclino.procedures.acquire)."""
    from inclino.procedures.acquire_temp import ThermalPlan, acquire_temperature, parse_temperatures
    from inclino.procedures.readings import Tolerance
    from inclino.formats.dataset import check_meta
    from inclino.link.serial_link import ProbeLink

    _check_procedure_options(args)
    if args.resume is not None:
        if not args.resume.endswith(".part"):
            raise DataError(f"--resume {args.resume}: the .part file an interrupted run left (RUN.csv.part)")
        if args.output is not None and args.output + ".part" != args.resume:
            raise DataError(f"--resume {args.resume} continues {args.resume[:-5]}, not -o {args.output}")
        args.output = args.resume[:-5]
    elif args.output is None:
        raise DataError("acquire needs -o RUN.csv (or --resume RUN.csv.part)")
    if args.procedure == "adaptive":
        if args.resume is not None:
            raise DataError("--resume: an adaptive run chooses each pose from the readings before it; start it again")
        from inclino.cli.adaptive import cmd_acquire_adaptive

        return cmd_acquire_adaptive(args, open_table)
    if args.procedure != "temperature":
        return _cmd_acquire_poses(args)
    if args.resume is not None:
        raise DataError("--resume: a temperature run follows the chamber through time; start it again")
    tol = Tolerance(args.tol_acc_mg, args.tol_mag_nt, args.reads)
    tol.check(args.max_reads)
    if args.average is not None and not 1 <= args.average <= 64:
        raise DataError("--average must be within 1-64 samples")
    plan = ThermalPlan(parse_temperatures(args.temperatures), args.poses, args.ramp_rate, args.interval_min,
                       args.ramp_poses, args.soak_band, args.soak_tol, args.soak_window_min, args.max_soak_min)
    plan.check()
    world = {"field_nT": args.field, "dip_deg": args.dip, "declination_deg": args.declination}
    for key, opt in (("field_nT", "--field"), ("dip_deg", "--dip"), ("declination_deg", "--declination")):
        check_meta(key, world[key], opt)
    table = open_table(args)
    try:
        with ProbeLink(args.port, baud=args.baud, timeout=args.timeout) as link:
            r = acquire_temperature(link, args.output, table, plan, tol=tol, max_reads=args.max_reads,
                                    world=world, quiet=args.quiet, average=args.average)
    finally:
        table.close()
    print(f"{r.path}: {r.rows} rows, temperature, probe {r.probe_serial}"
          + (f", field {r.meta['field_nT']:g} nT dip {r.meta['dip_deg']:g} deg" if "dip_deg" in r.meta else "")
          + f" ({r.reads} readings, {r.elapsed_s:.1f} s)")
    return 0




def _floats(text: str | None, what: str):
    if text is None:
        return None
    try:
        return [float(v) for v in text.split(",") if v.strip()]
    except ValueError:
        raise DataError(f"{what}: a comma-separated list of numbers, got {text!r}")


def _cmd_accept(args) -> int:
    from inclino.formats.dataset import check_meta
    from inclino.link.serial_link import ProbeLink
    from inclino.procedures.accept import accept, grid_points, render
    from inclino.procedures.readings import Tolerance

    check_meta("declination_deg", args.declination, "--declination")  # nan: every azimuth error nan
    if args.temperatures is not None:  # at chamber set points (inclino.procedures.accept_temp)
        return _cmd_accept_temperatures(args)
    if args.force:
        raise DataError("--force is an option of --temperatures")
    if args.toolfaces is None:
        args.toolfaces = "0"
    tol = Tolerance(args.tol_acc_mg, args.tol_mag_nt, args.reads)
    tol.check(args.max_reads)
    if args.average is not None and not 1 <= args.average <= 64:
        raise DataError("--average must be within 1-64 samples")
    incs = _floats(args.inclinations, "--inclinations")
    azis = _floats(args.azimuths, "--azimuths")
    tfs = _floats(args.toolfaces, "--toolfaces")
    grid_points(args.grid, incs, azis, tfs)  # a grid the turntable cannot reach: refused before the port
    cal = None
    if args.cal:
        from inclino.formats.calfile import Calibration

        cal = Calibration.load(args.cal)
        cal.check()
    limits = {"max_azi_rms_deg": args.max_azi_rms, "max_inc_rms_deg": args.max_inc_rms}
    for opt, v in (("--max-azi-rms", args.max_azi_rms), ("--max-inc-rms", args.max_inc_rms)):
        if not 0 < v < 180:   # nan fails too: a limit no grid can meet (or any meets) is no verdict
            raise DataError(f"{opt} {v:g}: the verdict's limit, degrees within (0, 180)")
    table = open_table(args)
    try:
        with ProbeLink(args.port, baud=args.baud, timeout=args.timeout) as link:
            res = accept(link, table, args.grid, cal=cal, before=args.before, inclinations=incs, azimuths=azis,
                         toolfaces=tfs, tol=tol, max_reads=args.max_reads, circles=args.circles,
                         declination=args.declination, limits=limits, quiet=args.quiet, average=args.average)
    finally:
        table.close()
    if args.output:
        _write(args.output, res.to_json() + "\n")
    if args.plot:
        from inclino.procedures import plots

        for path in plots.accept_figures(res, args.plot):
            print(f"wrote {path}", file=sys.stderr)
    print(res.to_json() if args.json else render(res))
    return 0 if res.passed else 1


def _cmd_accept_temperatures(args) -> int:
    """`inclino accept --temperatures ... --cal CAL.json` (docs/calibration.md)."""
    import math

    from inclino.engines import temperature as temp_engine
    from inclino.formats.calfile import Calibration
    from inclino.link.serial_link import ProbeLink
    from inclino.procedures.accept import grid_points
    from inclino.procedures.accept_temp import (DEFAULT_TOOLFACES, accept_temperatures, check_takings,
                                                parse_setpoints, render)
    from inclino.procedures.readings import Tolerance
    from inclino.procedures.acquire_temp import ThermalPlan

    if args.toolfaces is None:  # three toolfaces: 198 positions, the ratio's sampling spread 1/sqrt(3) of the 66's
        args.toolfaces = ",".join(f"{t:g}" for t in DEFAULT_TOOLFACES)
    sps = parse_setpoints(args.temperatures, args.reference_temp)
    tol = Tolerance(args.tol_acc_mg, args.tol_mag_nt, args.reads)
    tol.check(args.max_reads)
    if args.average is not None and not 1 <= args.average <= 64:
        raise DataError("--average must be within 1-64 samples")
    if not (math.isfinite(args.target_ratio) and args.target_ratio >= 1.0):
        raise DataError("--target-ratio must be a number >= 1")
    check_takings(args.takings, args.vertical_takings, args.significance_z)
    plan = ThermalPlan(sps, "twelve-position", args.ramp_rate, args.interval_min, 1, args.soak_band, args.soak_tol,
                       args.soak_window_min, args.max_soak_min)
    plan.check()
    eng = temp_engine.get(args.engine)
    if args.circles or args.plot or args.before != "auto":
        raise DataError("--temperatures does not take --circles, --plot or --before (its columns are with and "
                        "without the temperature terms)")
    incs = _floats(args.inclinations, "--inclinations")
    azis = _floats(args.azimuths, "--azimuths")
    tfs = _floats(args.toolfaces, "--toolfaces")
    grid_points(args.grid, incs, azis, tfs)
    if not args.cal:
        raise DataError("--temperatures needs --cal CAL.json with temperature terms (inclino calibrate --method "
                        "joint --temperature-terms on)")
    cal = Calibration.load(args.cal)
    cal.check()
    if not temp_engine.has_terms(cal):
        raise DataError(f"{args.cal} has no temperature terms (inclino calibrate --method joint --temperature-terms on, "
                        "from a chamber run)")
    eng.check(cal)  # exit 3 before the port when the firmware cannot hold the terms
    table = open_table(args)
    try:
        with ProbeLink(args.port, baud=args.baud, timeout=args.timeout) as link:
            res = accept_temperatures(link, table, cal, sps, args.grid, args.reference_temp, args.target_ratio,
                                      plan, args.engine, incs, azis, tfs, tol, args.max_reads, args.declination,
                                      force=args.force, quiet=args.quiet, average=args.average,
                                      takings=args.takings, vertical_takings=args.vertical_takings,
                                      significance_z=args.significance_z)
    finally:
        table.close()
    if args.output:
        _write(args.output, res.to_json() + "\n")
    print(res.to_json() if args.json else render(res))
    return 0 if res.passed else 1


def negative_lists(p) -> None:
    """Let `--temperatures -5,25,55` (a list starting with a minus sign) be a
    value, not an option: argparse takes only plain negative numbers as
    values; these parsers have no option that looks like a number."""
    import re

    p._negative_number_matcher = re.compile(r"^-\d+$|^-\d*\.\d+$|^-\d*\.?\d*(,\s*-?\d*\.?\d*)+$")


def _write(path: str, text: str) -> None:
    from inclino.formats import safeio

    safeio.write_output(path, text)


def add_accept(sub) -> None:
    from inclino.procedures.accept import DEFAULT_MAX_AZI_RMS, DEFAULT_MAX_INC_RMS, GRIDS

    p = command(sub, "accept", "the papers' check grids on the probe, before and after calibration",
                "Run an acceptance grid (Li 2021's or Ren 2014's positions) on the turntable and print the "
                "azimuth and inclination errors at each position before and after the calibration, in the "
                "paper's layout, with their RMS; with --cal the calibration is downloaded first and the "
                "'before' column is the probe as found. Exit 1 when the RMS after exceeds --max-azi-rms or "
                "--max-inc-rms. --temperatures runs the grid at each chamber set point instead, with and "
                "without the calibration's temperature terms.",
                ["inclino accept --port /dev/ttyUSB0 --cal cal.json",
                 "inclino accept --port /dev/pts/5 --bench 127.0.0.1:40123 --cal cal.json --grid ren2014 "
                 "-o accept.json",
                 "inclino accept --port /dev/pts/5 --bench 127.0.0.1:40123 --cal cal_t.json "
                 "--temperatures -5,25,55"])
    add_common(p)
    add_cal(p, "download this calibration first; before = the probe as found")
    p.add_argument("--grid", choices=GRIDS, default="li2021", help="the check grid (default %(default)s)")
    p.add_argument("--before", choices=("auto", "identity", "as-found"), default="auto",
                   help="the before column (default auto: as found with --cal, identity without)")
    p.add_argument("--inclinations", help="replace the grid's inclinations (ren2014: signed tilts), e.g. 5,30,60")
    p.add_argument("--azimuths", help="replace the grid's azimuths")
    p.add_argument("--toolfaces", help="toolfaces at every position (default 0; 0,120,240 with --temperatures)")
    p.add_argument("--declination", type=float, help="declination of the turntable's north (default: the "
                                                     "bench's, else 0)")
    p.add_argument("--circles", action="store_true", help="also the horizontal circles of Li 2021 Fig. 2")
    p.add_argument("--max-azi-rms", type=float, default=DEFAULT_MAX_AZI_RMS,
                   help="verdict: azimuth RMS after, deg (default %(default)g)")
    p.add_argument("--max-inc-rms", type=float, default=DEFAULT_MAX_INC_RMS,
                   help="verdict: inclination RMS after, deg (default %(default)g)")
    add_json(p)
    add_output(p, "also write the result as JSON (for inclino plot --accept)", required=False,
               metavar="ACCEPT.json")
    deprecated(p, "--save", "-o/--output", dest="output")
    add_plot_option(p, "write the error maps (and circles) as PNG into this folder")
    t = p.add_argument_group("at chamber set points (--temperatures; docs/calibration.md)")
    t.add_argument("--temperatures", help="run the grid at each chamber set point, degC (e.g. -5,25,55); needs "
                                          "--cal with temperature terms; toolfaces default 0,120,240")
    t.add_argument("--reference-temp", type=float, default=25.0,
                   help="the set point the others are compared with, degC (default %(default)g)")
    t.add_argument("--target-ratio", type=float, default=1.2,
                   help="verdict: RMS with the terms at every set point <= this x the reference's (default %(default)g)")
    t.add_argument("--takings", type=int, default=1, help="takings of the whole grid per set point, pooled "
                                                          "(default %(default)s)")
    t.add_argument("--vertical-takings", type=int, default=8,
                   help="takings in all of the positions within 5 deg of vertical, whose reading noise makes the "
                        "azimuth RMS's spread (default %(default)s)")
    t.add_argument("--significance-z", type=float, default=2.0,
                   help="verdict: a ratio fails when above --target-ratio by more than this many of its standard "
                        "uncertainties (default %(default)g; 0: the ratio alone)")
    t.add_argument("--engine", choices=("auto", "firmware", "golden", "host-terms"), default="auto",
                   help="the correction with the terms (default auto: the firmware's when it applies them)")
    _add_soak(t, "minutes between soak readings")
    _add_settle(t)
    t.add_argument("--force", action="store_true", help="download the calibration even when its own fit report "
                                                        "did not pass (as download --force)")
    negative_lists(p)
    p.set_defaults(func=_cmd_accept, toolfaces=None)  # 0; 0,120,240 with --temperatures


def _cmd_plot(args) -> int:
    from inclino.formats import dataset
    from inclino.procedures.plots import accept_figures, run_figures
    from inclino.formats.calfile import Calibration

    if not args.run and not args.accept:
        raise DataError("nothing to plot: give --run RUN.csv (with --cal) and/or --accept ACCEPT.json")
    paths = []
    if args.run:
        if not args.cal:
            raise DataError("--run needs --cal CAL.json (the calibration to show the run through)")
        ds = dataset.read_raw(args.run)
        cal = Calibration.load(args.cal)
        paths += run_figures(ds, cal, args.output)
    if args.accept:
        from inclino.procedures.accept_result import AcceptResult

        paths += accept_figures(AcceptResult.load(args.accept), args.output)
    for p in paths:
        print(p)
    return 0


def add_plot(sub) -> None:
    p = command(sub, "plot", "calibration figures (PNG): fluxgate sphere, horizontal circles, error maps",
                "Draw a calibration run through its calibration (the fluxgate readings on their sphere before "
                "and after, the horizontal circles) and an accept result's error maps, as PNG files in the "
                "folder -o names.",
                ["inclino plot --run run.csv --cal cal.json -o figures",
                 "inclino plot --accept accept.json -o figures"])
    p.add_argument("--run", metavar="RUN.csv", action=Input, help="a calibration run (raw dataset CSV)")
    add_cal(p, "the run's calibration (needed with --run)")
    p.add_argument("--accept", metavar="ACCEPT.json", action=Input, help="an accept result (inclino accept -o)")
    add_output(p, "folder for the PNG files", metavar="DIR")
    p.set_defaults(func=_cmd_plot)


def _cmd_demo(args) -> int:
    from inclino.procedures.demo import calibration_demo, render, run, summary

    if args.core:
        print(render(run(field_nT=args.field, dip_deg=args.dip)))
        return 0
    if args.chamber:  # the temperature step (demo_temp.py)
        from inclino.procedures import demo_temp

        r = demo_temp.run(args.output, tempco_draw=args.tempco_draw, seed=args.seed, quiet=args.quiet)
        gain = r.get("accept_gain_min")  # the acceptance grid at the set points, with / without the terms
        return 0 if r["passed"] and r["gain"] >= 10.0 and gain is not None and gain > 1.0 else 1
    res = calibration_demo(args.output, scenario=args.scenario, seed=args.seed, quiet=args.quiet)
    print(summary(res))
    ok = res.verify_ok and all(a.passed for a in res.accept.values())
    return 0 if ok else 1


def add_demo(sub) -> None:
    from inclino.procedures.demo import DEFAULT_OUT

    d = command(sub, "demo", "the whole calibration bench on the emulated probe (--core: the C core "
                             "on a table of poses)",
                "The calibration bench from end to end on the emulated probe, in about 10 s: start a typical "
                "uncalibrated probe, acquire an adaptive run on the emulated motorised turntable (poses chosen "
                "until the predicted acceptance reaches its target), fit it, download "
                "and verify the calibration, and run the Li 2021 and Ren 2014 acceptance grids before and after; "
                "the run, the calibration, the results and the figures go into the -o folder. --chamber does "
                "the temperature step instead, --core the firmware's C on a table of poses.",
                ["inclino demo", "inclino demo --chamber -o demo-chamber", "inclino demo --core"])
    add_output(d, "folder for the run, calibration and figures (default ./%(default)s)", required=False,
               metavar="DIR", default=DEFAULT_OUT)
    deprecated(d, "--out", "-o/--output", dest="output")
    d.add_argument("--scenario", default="typical", action=Input, help="emulator scenario (default %(default)s)")
    d.add_argument("--seed", type=int, default=None, help="override the scenario's seed")
    d.add_argument("--quiet", action="store_true", help="no progress bars")
    d.add_argument("--core", action="store_true",
                   help="instead: attitude of a table of poses through the firmware C, next to float64")
    d.add_argument("--field", type=float, default=50000.0, help="--core: total field, nT (default %(default)g)")
    d.add_argument("--dip", type=float, default=60.0, help="--core: dip, degrees (default %(default)g)")
    d.add_argument("--chamber", action="store_true",
                   help="instead: the temperature step (chamber run, temperature terms, diagnose before/after, "
                        "the acceptance grid at each set point with and without the terms)")
    deprecated(d, "--temperature", "--chamber", flag=True)
    d.add_argument("--tempco-draw", type=int, default=1, help="--chamber: the probe's tempcos drawn with "
                                                              "this seed (default %(default)s)")
    d.set_defaults(func=_cmd_demo)
