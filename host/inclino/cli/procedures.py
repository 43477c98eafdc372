"""The bench procedures' commands: acquire (pose and temperature runs),
accept, plot, demo.  Argument checks and printing here; the work in
inclino.procedures (imported when a command runs, so `inclino --help` stays
fast)."""
from __future__ import annotations

import sys

from inclino.errors import DataError


def add_common(p) -> None:
    """Options acquire and accept share: port, bench, stability."""
    p.add_argument("--port", required=True, help="serial port name or pyserial URL of the probe")
    p.add_argument("--baud", type=int, default=115200)
    p.add_argument("--timeout", type=float, default=1.0, help="seconds to wait for an answer (default 1)")
    p.add_argument("--bench", metavar="HOST:PORT",
                   help="drive the emulator's turntable over its control channel (unattended)")
    p.add_argument("--reads", type=int, default=3, help="readings that must agree at each position (default 3)")
    p.add_argument("--tol-acc-mg", type=float, default=1.0, help="stability: accelerometer spread, mg (default 1)")
    p.add_argument("--tol-mag-nt", type=float, default=20.0, help="stability: fluxgate spread, nT (default 20)")
    p.add_argument("--max-reads", type=int, default=30, help="bench: readings before a position is given up")
    p.add_argument("--average", type=int, help="set the probe's samples per reading first (SET_AVERAGE, 1-64; "
                                              "the probe's default is 16; it keeps it until it restarts)")
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
    from inclino.procedures.acquire import Tolerance, acquire, procedure_steps

    tol = Tolerance(args.tol_acc_mg, args.tol_mag_nt, args.reads)
    tol.check()
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
                        world=world, quiet=args.quiet, average=args.average)
    finally:
        table.close()
    print(f"{r.path}: {r.rows} rows, {args.procedure}, probe {r.probe_serial}"
          + (f", field {r.meta['field_nT']:g} nT dip {r.meta['dip_deg']:g} deg" if "dip_deg" in r.meta else "")
          + f" ({r.reads} readings, {r.elapsed_s:.1f} s)")
    return 0


def add_acquire(sub):
    from inclino.procedures.acquire import PROCEDURES

    p = sub.add_parser("acquire", help="take a calibration run from the probe (operator or emulated bench)")
    add_common(p)
    p.add_argument("--procedure", required=True, choices=PROCEDURES,
                   help="twelve-position (Li 2021), multi-position (Li + Ren 2014 + orientations), "
                        "continuous (Guo 2009), temperature (a chamber run: --temperatures)")
    p.add_argument("-o", "--output", required=True, help="raw dataset CSV to write")
    p.add_argument("--points", type=int, default=36, help="multi-position: quasi-uniform orientations (default 36)")
    p.add_argument("--d1", type=float, default=30.0, help="continuous: first inclination (default 30)")
    p.add_argument("--azimuth", type=float, default=2.0, help="continuous: azimuth of both rotations (default 2)")
    p.add_argument("--step", type=float, default=10.0, help="continuous on the bench: toolface step (default 10)")
    p.add_argument("--field", type=float, help="field total, nT, for the header (the bench reports its own)")
    p.add_argument("--dip", type=float, help="magnetic dip, deg, for the header")
    p.add_argument("--declination", type=float, help="declination, deg, for the header")
    t = p.add_argument_group("temperature procedure (docs/bench.md)")
    t.add_argument("--temperatures", default="-5,25,55", help="chamber set points, degC (default -5,25,55)")
    t.add_argument("--poses", default="twelve-position", choices=("twelve-position", "multi-position"),
                   help="the pose set taken at each set point (default twelve-position)")
    t.add_argument("--ramp-rate", type=float, default=1.0, help="chamber ramp, degC/min (default 1)")
    t.add_argument("--interval", type=float, default=2.0, help="minutes between readings while the chamber "
                                                               "ramps and soaks (default 2)")
    t.add_argument("--ramp-poses", type=int, default=4, help="poses read through each ramp (1-6, default 4)")
    t.add_argument("--soak-band", type=float, default=1.0, help="settled within this of the set point, degC "
                                                                "(default 1)")
    t.add_argument("--soak-tol", type=float, default=0.5, help="... and changing by at most this, degC "
                                                               "(default 0.5) ...")
    t.add_argument("--soak-window", type=float, default=10.0, help="... over this many minutes (default 10)")
    t.add_argument("--max-soak", type=float, default=240.0, help="bench: give up after this many minutes at "
                                                                 "one set point (default 240)")
    p.set_defaults(func=_cmd_acquire)
    return p


def _cmd_acquire(args) -> int:
    """`inclino acquire`: the temperature procedure (inclino.procedures.acquire_temp),
    the others (inclino.procedures.acquire)."""
    from inclino.procedures import acquire as acq
    from inclino.procedures.acquire_temp import ThermalPlan, acquire_temperature, parse_temperatures
    from inclino.formats.dataset import check_meta
    from inclino.link.serial_link import ProbeLink

    if args.procedure != "temperature":
        return _cmd_acquire_poses(args)
    tol = acq.Tolerance(args.tol_acc_mg, args.tol_mag_nt, args.reads)
    tol.check()
    if args.average is not None and not 1 <= args.average <= 64:
        raise DataError("--average must be within 1-64 samples")
    plan = ThermalPlan(parse_temperatures(args.temperatures), args.poses, args.ramp_rate, args.interval,
                       args.ramp_poses, args.soak_band, args.soak_tol, args.soak_window, args.max_soak)
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
    from inclino.link.serial_link import ProbeLink
    from inclino.procedures.accept import accept, grid_points, render
    from inclino.procedures.acquire import Tolerance

    tol = Tolerance(args.tol_acc_mg, args.tol_mag_nt, args.reads)
    tol.check()
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
    table = open_table(args)
    try:
        with ProbeLink(args.port, baud=args.baud, timeout=args.timeout) as link:
            res = accept(link, table, args.grid, cal=cal, before=args.before, inclinations=incs, azimuths=azis,
                         toolfaces=tfs, tol=tol, max_reads=args.max_reads, circles=args.circles,
                         declination=args.declination, limits=limits, quiet=args.quiet, average=args.average)
    finally:
        table.close()
    if args.save:
        _write(args.save, res.to_json() + "\n")
    if args.plot:
        from inclino.procedures import plots

        for path in plots.accept_figures(res, args.plot):
            print(f"wrote {path}", file=sys.stderr)
    print(res.to_json() if args.json else render(res))
    return 0 if res.passed else 1


def _write(path: str, text: str) -> None:
    from inclino.formats import safeio

    safeio.write_output(path, text)


def add_accept(sub) -> None:
    from inclino.procedures.accept import DEFAULT_MAX_AZI_RMS, DEFAULT_MAX_INC_RMS, GRIDS

    p = sub.add_parser("accept", help="the papers' check grids on the probe, before and after calibration")
    add_common(p)
    p.add_argument("--cal", help="download this calibration first; before = the probe as found")
    p.add_argument("--grid", choices=GRIDS, default="li2021", help="li2021 (default) or ren2014")
    p.add_argument("--before", choices=("auto", "identity", "as-found"), default="auto",
                   help="the before column (default: as found with --cal, identity without)")
    p.add_argument("--inclinations", help="replace the grid's inclinations (ren2014: signed tilts), e.g. 5,30,60")
    p.add_argument("--azimuths", help="replace the grid's azimuths")
    p.add_argument("--toolfaces", default="0", help="toolfaces at every position (default 0)")
    p.add_argument("--declination", type=float, help="declination of the turntable's north (default: the "
                                                     "bench's, else 0)")
    p.add_argument("--circles", action="store_true", help="also the horizontal circles of Li 2021 Fig. 2")
    p.add_argument("--max-azi-rms", type=float, default=DEFAULT_MAX_AZI_RMS, help="verdict: azimuth RMS after, deg")
    p.add_argument("--max-inc-rms", type=float, default=DEFAULT_MAX_INC_RMS,
                   help="verdict: inclination RMS after, deg")
    p.add_argument("--json", action="store_true", help="print the result as one JSON object")
    p.add_argument("--save", help="write the result as JSON (for inclino plot --accept)")
    p.add_argument("--plot", metavar="DIR", help="write the error maps (and circles) as PNG into DIR")
    p.set_defaults(func=_cmd_accept)


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
    p = sub.add_parser("plot", help="calibration figures (PNG): fluxgate sphere, horizontal circles, error maps")
    p.add_argument("--run", help="a calibration run (raw dataset CSV)")
    p.add_argument("--cal", help="its calibration (CAL.json)")
    p.add_argument("--accept", help="an accept result (inclino accept --save)")
    p.add_argument("-o", "--output", required=True, metavar="DIR", help="folder for the PNG files")
    p.set_defaults(func=_cmd_plot)


def _cmd_demo(args) -> int:
    from inclino.procedures.demo import calibration_demo, render, run, summary

    if args.core:
        print(render(run(field_nT=args.field, dip_deg=args.dip)))
        return 0
    if args.temperature:  # the temperature step (demo_temp.py)
        from inclino.procedures import demo_temp

        r = demo_temp.run(args.out, tempco_draw=args.tempco_draw, seed=args.seed, quiet=args.quiet)
        return 0 if r["passed"] and r["gain"] >= 10.0 else 1
    res = calibration_demo(args.out, scenario=args.scenario, seed=args.seed, quiet=args.quiet)
    print(summary(res))
    ok = res.verify_ok and all(a.passed for a in res.accept.values())
    return 0 if ok else 1


def add_demo(sub) -> None:
    from inclino.procedures.demo import DEFAULT_OUT

    d = sub.add_parser("demo", help="the whole calibration bench on the emulated probe (--core: the C core "
                                    "on a table of poses)")
    d.add_argument("--out", default=DEFAULT_OUT, help=f"folder for the run, calibration and figures "
                                                      f"(default ./{DEFAULT_OUT})")
    d.add_argument("--scenario", default="typical", help="emulator scenario (default typical)")
    d.add_argument("--seed", type=int, default=None, help="override the scenario's seed")
    d.add_argument("--quiet", action="store_true", help="no progress bars")
    d.add_argument("--core", action="store_true",
                   help="instead: attitude of a table of poses through the firmware C, next to float64")
    d.add_argument("--field", type=float, default=50000.0, help="--core: field total, nT (default 50000)")
    d.add_argument("--dip", type=float, default=60.0, help="--core: dip, degrees (default 60)")
    d.add_argument("--temperature", action="store_true",
                   help="instead: the temperature step (chamber run, temperature terms, diagnose before/after)")
    d.add_argument("--tempco-draw", type=int, default=1, help="--temperature: the probe's tempcos drawn with "
                                                              "this seed (default 1)")
    d.set_defaults(func=_cmd_demo)
