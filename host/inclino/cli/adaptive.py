"""`inclino acquire --procedure adaptive`: its options and its handler
(the procedure is inclino.procedures.adaptive; docs/calibration.md,
"Adaptive runs")."""
from __future__ import annotations

from inclino.errors import DataError


def _auto_or_float(text: str):
    if str(text).strip().lower() == "auto":
        return None
    try:
        return float(text)
    except ValueError:
        raise DataError(f"a target is a number of degrees or 'auto', got {text!r}")


def _target(text: str):
    """--target-*-deg: 'auto' or degrees."""
    import argparse

    try:
        v = _auto_or_float(text)
    except DataError as e:
        raise argparse.ArgumentTypeError(str(e))
    return "auto" if v is None else v


def _chamber_range(text: str) -> tuple:
    """--chamber-range-c: LO,HI in degC."""
    import argparse

    try:
        lo, hi = (float(x) for x in str(text).split(","))
    except ValueError:
        raise argparse.ArgumentTypeError(f"--chamber-range-c wants LO,HI in degC, got {text!r}")
    return lo, hi


def add_adaptive_options(p) -> None:
    a = p.add_argument_group("adaptive procedure (docs/calibration.md, \"Adaptive runs\")")
    a.add_argument("--target-azi-deg", default="auto", type=_target,
                   help="stop when the predicted acceptance azimuth RMS is at or below this, deg; auto: 1.12 x the "
                        "acceptance's own floor, the calibration's share at most half of it (default %(default)s)")
    a.add_argument("--target-inc-deg", default="auto", type=_target,
                   help="... and the inclination RMS at or below this, deg (default %(default)s)")
    a.add_argument("--target-ratio", type=float, default=1.1,
                   help="through a chamber: ... and the predicted RMS at the range's ends at most this times the "
                        "25 degC figure (default %(default)g)")
    a.add_argument("--min-poses", type=int, default=16, help="poses before the run may stop (default %(default)s)")
    a.add_argument("--max-poses", type=int, default=150,
                   help="stop after this many poses whatever the prediction (default %(default)s)")
    a.add_argument("--plateau", type=float, default=0.002,
                   help="stop when each of the last --patience poses lowered the prediction by less than this "
                        "fraction (default %(default)g)")
    a.add_argument("--patience", type=int, default=8, help="see --plateau (default %(default)s)")
    a.add_argument("--diagnose-share", type=float, default=0.5,
                   help="do not stop before every static effect diagnose tests (nonlinearity, turntable offsets "
                        "and axes) shows at least this share of the signature the multi-position run gives; 0: "
                        "no floor (default %(default)g)")
    a.add_argument("--accept-average", type=int, default=16,
                   help="samples per reading of the acceptance the prediction is for (default %(default)s, the "
                        "probe's default)")
    a.add_argument("--table-rate-deg-s", type=float, default=10.0,
                   help="the turntable's speed per axis, for the moves' cost, deg/s (default %(default)g)")
    a.add_argument("--table-settle-s", type=float, default=3.0,
                   help="the turntable's settling time after a move, s (default %(default)g)")
    a.add_argument("--chamber-range-c", metavar="LO,HI", type=_chamber_range,
                   help="through a chamber: ramp continuously so that the probe spans LO..HI degC, no soaks "
                        "(default none: room temperature)")
    a.add_argument("--chamber-rate-c-per-min", type=float, default=5.0,
                   help="with --chamber-range-c: the chamber's ramp, degC/min (default %(default)g)")
    a.add_argument("--air-margin-c", type=float, default=20.0,
                   help="with --chamber-range-c: how far beyond the range the air may go, degC "
                        "(default %(default)g)")
    a.add_argument("--probe-tau-s", type=float, default=900.0,
                   help="with --chamber-range-c: the probe's thermal lag to start from, s; fitted to its own "
                        "temperature readings as the run goes (default %(default)g)")


def plan_of(args):
    from inclino.procedures.adaptive import AdaptivePlan
    from inclino.procedures.ramp import RampPlan

    ramp = None
    if args.chamber_range_c is not None:
        try:
            lo, hi = (args.chamber_range_c if isinstance(args.chamber_range_c, tuple)
                      else _chamber_range(args.chamber_range_c))
        except Exception as e:
            raise DataError(str(e))
        ramp = RampPlan(lo, hi, args.chamber_rate_c_per_min, args.air_margin_c, tau_guess_s=args.probe_tau_s)
    plan = AdaptivePlan(target_azi_deg=_auto_or_float(args.target_azi_deg),
                        target_inc_deg=_auto_or_float(args.target_inc_deg), target_ratio=args.target_ratio,
                        min_poses=args.min_poses, max_poses=args.max_poses, plateau=args.plateau,
                        patience=args.patience, diagnose_share=args.diagnose_share, average=args.average, accept_average=args.accept_average,
                        table_rate_deg_s=args.table_rate_deg_s, table_settle_s=args.table_settle_s, ramp=ramp)
    plan.check()
    return plan


def cmd_acquire_adaptive(args, open_table) -> int:
    from inclino.formats.dataset import check_meta
    from inclino.link.serial_link import ProbeLink
    from inclino.procedures.adaptive import acquire_adaptive
    from inclino.procedures.readings import Tolerance

    tol = Tolerance(args.tol_acc_mg, args.tol_mag_nt, args.reads)
    tol.check(args.max_reads)
    plan = plan_of(args)
    world = {"field_nT": args.field, "dip_deg": args.dip, "declination_deg": args.declination}
    for key, opt in (("field_nT", "--field"), ("dip_deg", "--dip"), ("declination_deg", "--declination")):
        check_meta(key, world[key], opt)
    table = open_table(args)
    try:
        with ProbeLink(args.port, baud=args.baud, timeout=args.timeout) as link:
            r = acquire_adaptive(link, args.output, table, plan, tol=tol, max_reads=args.max_reads, world=world,
                                 quiet=args.quiet)
    finally:
        table.close()
    print(summary(r))
    return 0


def summary(r) -> str:
    pa = (r.prediction or {}).get("acceptance_grid") or {}
    t = r.targets or {}
    lines = [f"{r.path}: {r.rows} rows, adaptive, probe {r.probe_serial}; stopped: {r.stop_reason}",
             f"  bench time {r.bench_s / 60:.1f} min ({r.reads} readings; the host computed {r.planning_s:.1f} s "
             "between them)"]
    if pa:
        lines.append(f"  predicted acceptance (Li grid, {r.prediction.get('accept_average', 16)} samples per reading): "
                     f"azimuth RMS {pa['azi_rms_deg']:.4f} deg (target {t.get('azi_deg') or float('nan'):.4f}), "
                     f"inclination {pa['inc_rms_deg']:.4f} deg (target {t.get('inc_deg') or float('nan'):.4f})")
    ratios = (r.prediction or {}).get("ratios")
    if ratios:
        lines.append("  predicted ratio to t_ref: " + ", ".join(
            f"{k} degC azimuth {v['azi']:.2f}, inclination {v['inc']:.2f}" for k, v in ratios.items()))
    if r.ramp:
        rg = r.ramp.get("probe_range_c") or [float("nan")] * 2
        lines.append(f"  chamber: the probe spanned {rg[0]:.1f} to {rg[1]:.1f} degC; its lag fitted "
                     f"{r.ramp.get('tau_fitted_s', float('nan')):.0f} s")
    return "\n".join(lines)
