"""The survey crew's commands: reffield, toolmodel, trajectory, compare.
A thin shell over inclino.survey.geomag, inclino.survey.errormodel, inclino.survey.wellpath and
inclino.survey.compare (docs/survey.md, docs/cli.md).

Exit statuses: 0 success; 1 a check ran and failed (compare: a station
outside its expected spread; trajectory --fail-on-qc: a station failed QC);
2 bad input; 4 port or probe problem (reffield --port).
"""
from __future__ import annotations

import json
import math
import sys

from inclino.cli.paths import Input, Output
from inclino.errors import DataError


def _add_reference(p, grid=True):
    g = p.add_argument_group("reference field (docs/survey.md)")
    g.add_argument("--lat", type=float, help="wellhead latitude, deg (WGS 84)")
    g.add_argument("--lon", type=float, help="wellhead longitude, deg (WGS 84)")
    g.add_argument("--alt", type=float, default=0.0, help="height above the ellipsoid, m (default 0)")
    g.add_argument("--date", help="survey date YYYY-MM-DD (main-field model)")
    g.add_argument("--model", choices=("igrf", "wmm"), default="igrf",
                   help="main-field model: igrf (ppigrf, default) or wmm (needs pygeomag)")
    g.add_argument("--declination", type=float, help="declination, deg east (in-field referencing; overrides the model)")
    g.add_argument("--dip", type=float, help="dip, deg down (overrides the model)")
    g.add_argument("--total", type=float, help="total field, nT (overrides the model)")
    g.add_argument("--gravity", type=float, help="local gravity, g (default: WGS 84 normal gravity)")
    if grid:
        g.add_argument("--grid", type=int, metavar="EPSG", help="projected CRS: grid azimuth, easting/northing")
    g.add_argument("--ref", action=Input, help="a reference-field file written by inclino reffield (instead of the options)")


def _reference(args):
    from inclino.survey import geomag

    if getattr(args, "ref", None):
        return geomag.ReferenceField.load(args.ref)
    return geomag.reference(lat=args.lat, lon=args.lon, date=args.date, alt_m=args.alt, model=args.model,
                            declination=args.declination, dip=args.dip, total=args.total, gravity=args.gravity,
                            grid_epsg=getattr(args, "grid", None))


def _tool_model(args, rf=None):
    from inclino.survey import errormodel as em

    if getattr(args, "tool_model", None):
        return em.ToolModel.load(args.tool_model)
    if getattr(args, "cal", None):
        from inclino.formats.calfile import Calibration

        cal = Calibration.load(args.cal)
        dip = rf.dip_deg if rf is not None and math.isfinite(rf.dip_deg) else _cal_dip(cal)
        tot = rf.total_nT if rf is not None and math.isfinite(rf.total_nT) else 50000.0
        return em.from_calibration(cal, dip, tot, acc_noise_g=args.acc_noise or 0.0, mag_noise_nT=args.mag_noise or 0.0)
    raise DataError("the error model needs --tool-model TOOL.json (inclino toolmodel) or --cal CAL.json")


def _cal_dip(cal) -> float:
    """The dip the calibration run saw (its fit report), else 60 deg."""
    v = ((cal.report or {}).get("residuals") or {}).get("dip_mean_deg")
    return float(v) if isinstance(v, (int, float)) and math.isfinite(v) and abs(v) < 90 else 60.0


def _cmd_reffield(args) -> int:
    rf = _reference(args)
    if args.output:
        from inclino.survey.wellpath import _write

        _write(args.output, rf.to_json() + "\n")
    if args.port:
        from inclino.survey import qcref

        with _open_link(args) as link:
            qcref.write_probe(link, rf)
    if args.json:
        print(rf.to_json())
    else:
        for k, v in rf.header().items():
            print(f"{k:16s} {v}")
    return 0


def _open_link(args):
    from inclino.link.serial_link import ProbeLink

    return ProbeLink(args.port, baud=args.baud, timeout=args.timeout)


def _cmd_toolmodel(args) -> int:
    from inclino.survey import errormodel as em
    from inclino.formats.calfile import Calibration

    cal = Calibration.load(args.cal)
    rf = _reference(args) if (args.lat is not None or args.declination is not None or args.ref) else None
    dip = rf.dip_deg if rf is not None and math.isfinite(rf.dip_deg) else \
        args.dip if args.dip is not None else _cal_dip(cal)
    tot = rf.total_nT if rf is not None and math.isfinite(rf.total_nT) else args.total or 50000.0
    an, mn = args.acc_noise, args.mag_noise
    if args.noise:
        from inclino.survey.wellpath import read_survey_rows

        na, nm = em.noise_from_survey(read_survey_rows(args.noise))
        an = na if an is None else an
        mn = nm if mn is None else mn
    for name, v in (("--acc-noise", an), ("--mag-noise", mn)):
        if v is not None and not (math.isfinite(v) and v >= 0):
            raise DataError(f"{name} must be >= 0")
    tm = em.from_calibration(cal, dip, tot, acc_noise_g=an or 0.0, mag_noise_nT=mn or 0.0, name=args.name)
    tm.save(args.output, reference=args.ref_terms)
    f = tm.fit
    print(f"tool model {tm.name} -> {args.output}: " + ", ".join(
        f"{g} {_show(g, v)}" for g, v in tm.systematic.items()))
    print(f"noise per survey: acc {an or 0:.3g} g, mag {mn or 0:.3g} nT; projection of the calibration covariance: "
          f"sigma ratio {f['sigma_ratio_min']:.2f}-{f['sigma_ratio_max']:.2f} (RMS {f['sigma_ratio_rms']:.1%} off) "
          f"over {f['attitudes']} attitudes at dip {f['dip_deg']:.2f} deg, {f['field_nT']:.0f} nT")
    mc = f["monte_carlo"]
    print(f"Monte Carlo over the covariance ({mc['draws']} draws, {len(mc['inc_deg'])} attitudes, inclination "
          f"{min(mc['inc_deg']):g}-{max(mc['inc_deg']):g} deg): model/MC 1-sigma inclination "
          f"{min(mc['inc_ratio']):.2f}-{max(mc['inc_ratio']):.2f}, azimuth {min(mc['azi_ratio']):.2f}-"
          f"{max(mc['azi_ratio']):.2f} ({'within' if mc['within_20pct'] else 'NOT within'} +-20 %)")
    return 0 if mc["within_20pct"] else 1  # the file is written either way


def _show(g, v):
    if g.startswith("AB"):
        return f"{v:.3g} m/s2"
    if g.startswith("MB"):
        return f"{v:.3g} nT"
    if g.startswith("XYM"):
        return f"{math.degrees(v):.3g} deg"
    return f"{v:.3g}"


def _cmd_trajectory(args) -> int:
    from inclino.survey import wellpath as wp

    from inclino.formats import safeio

    for out in (args.output, args.las):
        if out:
            safeio.check_output(out, args.input)  # never over a survey file it reads
    sv = wp.concat([wp.read_survey(p) for p in args.input])
    rf = _reference(args)
    tm = _tool_model(args, rf) if args.uncertainty else None
    ref_terms = args.ref_terms or ("srgm" if rf.source.startswith(("IGRF", "WMM")) else "ifr1")
    tr = wp.trajectory(sv, rf, tm, ref_terms if tm is not None else "none")
    if args.output.lower().endswith(".las"):
        wp.write_las(tr, args.output)
    else:
        wp.write_csv(tr, args.output)
    if args.las:
        wp.write_las(tr, args.las)
    if args.plot:
        from inclino.survey import wellplot

        try:
            wellplot.plot(tr.rows, args.plot, title=f"{' '.join(args.input)}: {len(tr.rows)} stations")
        except OSError as e:
            raise DataError(f"cannot write {args.plot}: {e.strerror}")
    s = tr.summary
    e = s["end"]
    msg = (f"{s['stations']} stations, MD {s['md_m'][0]:g}-{s['md_m'][1]:g} m; declination "
           f"{rf.declination_deg:.2f} deg ({rf.source})"
           + (f", grid convergence {rf.convergence_deg:.3f} deg (EPSG {rf.grid_epsg})" if rf.grid_epsg else "")
           + f"; end TVD {e['tvd_m']:.2f} m, N {e['north_m']:.2f} m, E {e['east_m']:.2f} m"
           + (f"; 1-sigma ellipse {e['ell_major_m']:.3f} x {e['ell_minor_m']:.3f} m" if tm is not None else "")
           + f"; QC: {s['stations'] - s['qc_fail']} pass, {s['qc_fail']} fail")
    print(msg, file=sys.stderr if args.output == "-" else sys.stdout)
    return 1 if (args.fail_on_qc and s["qc_fail"]) else 0


def _cmd_compare(args) -> int:
    from inclino.survey import compare as cmp
    from inclino.survey import wellpath as wp

    a, b = wp.read_survey(args.first), wp.read_survey(args.second)
    rf = _reference(args) if (args.lat is not None or args.ref or args.declination is not None) else None
    tm = _tool_model(args, rf)
    dip = rf.dip_deg if rf is not None and math.isfinite(rf.dip_deg) else \
        args.dip if args.dip is not None else tm.fit.get("dip_deg", 60.0)
    tot = rf.total_nT if rf is not None and math.isfinite(rf.total_nT) else \
        args.total if args.total is not None else tm.fit.get("field_nT", 50000.0)
    r = cmp.compare(a, b, tm, dip, tot, k=args.k, md_tol=args.md_tol, two_probes=args.two_probes)
    if args.json:
        print(r.to_json())
    else:
        print(f"{'MD m':>9} {'inc':>8} {'d inc':>9} {'k sig':>8} {'d azi':>9} {'k sig':>8}  verdict")
        for s in r.stations:
            da = "" if s["d_azi_deg"] is None else f"{s['d_azi_deg']:9.4f} {r.k * s['sigma_d_azi_deg']:8.4f}"
            print(f"{s['md_m']:9.2f} {s['inc_deg']:8.3f} {s['d_inc_deg']:9.4f} {r.k * s['sigma_d_inc_deg']:8.4f} "
                  f"{da:18s}  {s['verdict']}")
        sm = r.summary
        print(f"{sm['pairs']} station pairs ({r.mode}, k = {r.k:g}): {sm['pairs'] - sm['failed']} pass, "
              f"{sm['failed']} fail; unmatched {sm['unmatched_in']} + {sm['unmatched_out']}; verdict: "
              + ("PASS" if r.passed else "FAIL"))
    return 0 if r.passed else 1


def add_parser(sub) -> None:
    p = sub.add_parser("reffield", help="reference field of a survey: declination, dip, total field, gravity, grid")
    _add_reference(p)
    p.add_argument("-o", "--output", action=Output, help="write the reference field as JSON (stored with the run)")
    p.add_argument("--port", action=Input, help="also write it to the probe as its QC reference (QCREF_WRITE)")
    p.add_argument("--baud", type=int, default=115200)
    p.add_argument("--timeout", type=float, default=1.0)
    p.add_argument("--json", action="store_true")
    p.set_defaults(func=_cmd_reffield)

    p = sub.add_parser("toolmodel", help="the calibrated probe's error model as an ISCWSA tool model (JSON)")
    p.add_argument("cal", action=Input, help="calibration JSON with its fit report (inclino calibrate)")
    _add_reference(p, grid=False)
    p.add_argument("--noise", action=Input, help="a survey listing of repeated surveys at rest: the per-survey noise")
    p.add_argument("--acc-noise", type=float, help="accelerometer noise per survey and axis, g")
    p.add_argument("--mag-noise", type=float, help="fluxgate noise per survey and axis, nT")
    p.add_argument("--name", default="INCLINO", help="the tool model's short name")
    p.add_argument("--ref-terms", choices=("none", "srgm", "ifr1"), default="none",
                   help="reference-field terms to include (default none: trajectory adds them per survey)")
    p.add_argument("-o", "--output", action=Output, required=True, help="tool model JSON")
    p.set_defaults(func=_cmd_toolmodel)

    p = sub.add_parser("trajectory", help="well path by minimum curvature from a survey listing, with QC "
                                          "and position uncertainty")
    p.add_argument("input", nargs="+", action=Input, help="survey listing(s) (CSV, JSON lines or LAS) with md_m, inc_deg, azi_deg; "
                                            "several files are one survey, sorted by depth")
    _add_reference(p)
    p.add_argument("--uncertainty", action="store_true", help="position covariance (1-sigma ellipse) per station")
    p.add_argument("--tool-model", action=Input, help="tool model JSON (inclino toolmodel)")
    p.add_argument("--cal", action=Input, help="or a calibration JSON to build the tool model from")
    p.add_argument("--acc-noise", type=float, help="with --cal: accelerometer noise per survey and axis, g")
    p.add_argument("--mag-noise", type=float, help="with --cal: fluxgate noise per survey and axis, nT")
    p.add_argument("--ref-terms", choices=("none", "srgm", "ifr1"),
                   help="reference-field error terms (default: srgm for a main-field model, ifr1 for user values)")
    p.add_argument("--las", action=Output, help="also write the trajectory as LAS 2.0")
    p.add_argument("--fail-on-qc", action="store_true", help="exit 1 when a station fails QC")
    p.add_argument("--plot", action=Output, help="a PNG of the path (plan view with the ellipses, vertical section)")
    p.add_argument("-o", "--output", action=Output, required=True, help="trajectory CSV ('-' for stdout; .las for LAS 2.0)")
    p.set_defaults(func=_cmd_trajectory)

    p = sub.add_parser("compare", help="repeatability QC of two surveys station by station")
    p.add_argument("first", action=Input, help="in-run survey listing")
    p.add_argument("second", action=Input, help="out-run (or second probe) survey listing")
    p.add_argument("--tool-model", action=Input, help="tool model JSON (inclino toolmodel)")
    p.add_argument("--cal", action=Input, help="or a calibration JSON to build it from")
    p.add_argument("--acc-noise", type=float, help="with --cal: accelerometer noise per survey and axis, g")
    p.add_argument("--mag-noise", type=float, help="with --cal: fluxgate noise per survey and axis, nT")
    _add_reference(p, grid=False)
    p.add_argument("--two-probes", action="store_true", help="two probes: every sensor term differs")
    p.add_argument("--k", type=float, default=3.0, help="pass within k x the expected sigma (default 3)")
    p.add_argument("--md-tol", type=float, default=0.5, help="pair stations within this many m of MD (default 0.5)")
    p.add_argument("--json", action="store_true")
    p.set_defaults(func=_cmd_compare)
