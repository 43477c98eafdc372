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
from inclino.cli.options import add_cal, add_json, add_output, add_plot, command, deprecated, plot_target, \
    require
from inclino.errors import DataError


def _add_reference(p, grid=True):
    g = p.add_argument_group("reference field (docs/survey.md)")
    g.add_argument("--lat", type=float, help="wellhead latitude, deg (WGS 84)")
    g.add_argument("--lon", type=float, help="wellhead longitude, deg (WGS 84)")
    g.add_argument("--alt", type=float, help="height above the ellipsoid, m (default 0)")
    g.add_argument("--date", help="survey date YYYY-MM-DD (main-field model)")
    g.add_argument("--model", choices=("igrf", "wmm"),
                   help="main-field model: igrf (ppigrf) or wmm (needs pygeomag) (default igrf)")
    g.add_argument("--declination", type=float, help="declination, deg east (in-field referencing; overrides the model)")
    g.add_argument("--dip", type=float, help="dip, deg down (overrides the model)")
    g.add_argument("--field", type=float, help="total field, nT (overrides the model)")
    deprecated(g, "--total", "--field", type=float)
    g.add_argument("--gravity", type=float, help="local gravity, g (default: WGS 84 normal gravity)")
    if grid:
        g.add_argument("--grid", type=int, metavar="EPSG", help="projected CRS: grid azimuth, easting/northing "
                                                                "(also with --ref: at the file's position)")
    g.add_argument("--ref", metavar="REF.json", action=Input,
                   help="a reference-field file written by inclino reffield -o, in place of the position, date "
                        "and field options (given with it: exit 2)" + ("; --grid adds a grid to it" if grid else ""))


# the options a reference file replaces: given with --ref, a value would be given twice
_REF_OPTIONS = (("--lat", "lat"), ("--lon", "lon"), ("--alt", "alt"), ("--date", "date"), ("--model", "model"),
                ("--declination", "declination"), ("--dip", "dip"), ("--field", "field"), ("--gravity", "gravity"))


def _reference(args):
    from inclino.survey import geomag

    epsg = getattr(args, "grid", None)
    if getattr(args, "ref", None):
        rf = geomag.ReferenceField.load(args.ref)  # bounded JSON, every field by its rule
        _refuse_twice(args, rf)
        if epsg is not None and rf.grid_epsg != epsg:
            if rf.grid_epsg is not None:
                raise DataError(f"--grid {epsg} with --ref {args.ref}, whose grid is EPSG {rf.grid_epsg}: give one "
                                f"grid (leave out --grid, or write the reference again with inclino reffield "
                                f"--grid {epsg})")
            geomag.add_grid(rf, epsg, where=args.ref)
        return rf
    return geomag.reference(lat=args.lat, lon=args.lon, date=args.date, alt_m=0.0 if args.alt is None else args.alt,
                            model=args.model or "igrf", declination=args.declination, dip=args.dip,
                            field=args.field, gravity=args.gravity, grid_epsg=epsg)


def _refuse_twice(args, rf) -> None:
    """A reference file holds the position, date and field: an option that
    gives one of them again is refused (exit 2), never silently outvoted by
    the file nor silently overriding what the file records. The line says
    how to write a reference with the value wanted."""
    given = [(o, getattr(args, d)) for o, d in _REF_OPTIONS if getattr(args, d, None) is not None]
    if not given:
        return
    names = ", ".join(o for o, _ in given)
    field_only = all(o in ("--declination", "--dip", "--field", "--gravity") for o, _ in given)
    if field_only and rf.lat_deg is not None and rf.date:
        src = "--model wmm " if rf.ref_source.startswith("WMM") else ""
        alt = f"--alt {rf.alt_m:.10g} " if rf.alt_m else ""
        grid = f"--grid {rf.grid_epsg} " if rf.grid_epsg is not None else ""
        redo = (f"inclino reffield --lat {rf.lat_deg:.10g} --lon {rf.lon_deg:.10g} {alt}--date {rf.date} {src}"
                + grid + " ".join(f"{o} {v:.10g}" for o, v in given) + " -o NEW.json")
    else:
        redo = "inclino reffield with your values -o NEW.json"
    raise DataError(f"{names} with --ref {args.ref}: the file gives the position, date and field already "
                    f"(declination {rf.declination_deg:.4f} deg, {rf.ref_source}), and a value given twice is "
                    f"refused; leave out {names} or --ref, or write a reference with "
                    f"{'it' if len(given) == 1 else 'them'}: {redo}")


def _field_options(args) -> None:
    """--declination, --dip, --field and --gravity by the reference field's
    rules (geomag.RULES) also where no reference field is built from them."""
    from inclino.survey.geomag import RULES

    for name, key, unit in (("declination", "declination_deg", "deg"), ("dip", "dip_deg", "deg"),
                            ("field", "field_nT", "nT"), ("gravity", "gravity_g", "g")):
        v = getattr(args, name, None)
        if v is None:
            continue
        lo, hi, lo_open = RULES[key]
        if not (math.isfinite(v) and (lo < v if lo_open else lo <= v) and v <= hi):
            raise DataError(f"--{name} {v:g}: {unit} within {'(' if lo_open else '['}{lo:g}, {hi:g}]")


def _noise(args, cal):
    """(acc g, mag nT, where from) for the probe's terms: --acc-noise and
    --mag-noise where given, else the calibration's fit report (never a
    silent zero)."""
    from inclino.survey import errormodel as em

    for name, v in (("--acc-noise", args.acc_noise), ("--mag-noise", args.mag_noise)):
        if v is not None and not (math.isfinite(v) and v >= 0):
            raise DataError(f"{name} must be >= 0")
    if args.acc_noise is not None and args.mag_noise is not None:
        return args.acc_noise, args.mag_noise, "given (--acc-noise, --mag-noise)"
    a, m, src = em.calibration_noise(cal)
    if args.acc_noise is not None:
        return args.acc_noise, m, f"--acc-noise; fluxgate from {src}"
    if args.mag_noise is not None:
        return a, args.mag_noise, f"--mag-noise; accelerometer from {src}"
    return a, m, src


def _noise_dof(args):
    """The degrees of freedom of the noise compare's sigma takes from the
    calibration's fit report (None: given by --acc-noise and --mag-noise, no
    calibration, or a report that records none, as acquire's measured
    noise)."""
    from inclino.survey import errormodel as em

    if not getattr(args, "cal", None) or (args.acc_noise is not None and args.mag_noise is not None):
        return None
    return em.calibration_noise_dof(_survey_calibration(args.cal))


def _field_for(rf, cal=None):
    dip = rf.dip_deg if rf is not None and math.isfinite(rf.dip_deg) else _cal_dip(cal) if cal else 60.0
    tot = rf.field_nT if rf is not None and math.isfinite(rf.field_nT) else 50000.0
    return dip, tot


def _error_model(args, rf=None, default_base=None, add_reference=True):
    """--tool-model / --cal as an inclino.survey.models.ErrorModel: the base
    model (a name or an ISCWSA file; `default_base` when only --cal is
    given), the probe's terms from the calibration (its noise: the fit
    report's unless given), the reference-field terms (--ref-terms; without
    it and `add_reference`, the reference's own kind for a model that has
    none: a position uncertainty needs them, a repeat survey's difference of
    magnetic azimuths does not)."""
    from inclino.survey import errormodel as em, models

    if not (getattr(args, "tool_model", None) or getattr(args, "cal", None)):
        raise DataError("the error model needs --tool-model (iscwsa-mwd-rev5, a name welleng ships, or an ISCWSA "
                        "JSON file such as inclino toolmodel writes) or --cal CAL.json")
    if (args.acc_noise is not None or args.mag_noise is not None) and not args.cal:
        raise DataError("--acc-noise/--mag-noise set the noise of the probe's terms from --cal CAL.json: give --cal "
                        "(a tool-model file carries its own noise terms)")
    base = models.load(args.tool_model) if args.tool_model else None
    if base is None and default_base:
        base = models.load(default_base)
    probe = None
    if args.cal:
        cal = _survey_calibration(args.cal)
        an, mn, src = _noise(args, cal)
        dip, tot = _field_for(rf, cal)
        rev = int(base.revision) if base is not None and base.revision < 5 else 5
        probe = em.from_calibration(cal, dip, tot, acc_noise_g=an, mag_noise_nT=mn, noise_source=src, revision=rev)
    m = models.ErrorModel(base, probe, getattr(args, "ref_terms", None))
    if probe is not None:
        m.calibration = (cal, em.calibration_covariance(cal)[0])
    if add_reference and m.reference is None and not m.has_reference_terms() and rf is not None:
        m.reference = "srgm" if rf.ref_source.startswith(("IGRF", "WMM")) else "ifr1"
        m.notes.append(f"reference-field terms {m.reference} added (the model has none; --ref-terms sets them)")
    if base is not None:
        m.notes += base.notes
    if probe is not None:
        m.notes.append(f"noise per survey: acc {probe.source['acc_noise_g']:.3g} g, mag "
                       f"{probe.source['mag_noise_nT']:.3g} nT, from {probe.source['noise_source']}")
    return m


def _survey_calibration(path):
    """The calibration for a survey error model: both triads.  A one-triad
    calibration (calib.single) holds the other triad as an identity
    placeholder and a 12-term covariance: it had been refused as 'records no
    reading noise', and with the noise given as 'covariance must be a list of
    24' (exit 3)."""
    from inclino.formats.calfile import Calibration

    cal = Calibration.load(path)
    if cal.triads != "both":
        which = "an accelerometer" if cal.triads == "acc" else "a magnetometer"
        raise DataError(f"{path} is {which}-only calibration: the survey's error model needs both triads' terms "
                        "(the azimuth takes the accelerometer and the magnetometer); calibrate a run with both triads")
    return cal


def _cal_dip(cal) -> float:
    """The dip the calibration run saw (its fit report), else 60 deg."""
    v = ((cal.report or {}).get("residuals") or {}).get("dip_mean_deg")
    return float(v) if isinstance(v, (int, float)) and math.isfinite(v) and abs(v) < 90 else 60.0


def _cmd_reffield(args) -> int:
    _field_options(args)
    if not args.port and (args.baud is not None or args.timeout is not None):
        raise DataError("--baud and --timeout set the link of --port: give --port P (or leave them out)")
    rf = _reference(args)
    if args.output:
        from inclino.survey.wellpath import _write

        _write(args.output, rf.to_json() + "\n")
    stored = None
    if args.port:
        from inclino.survey import qcref

        with _open_link(args) as link:
            stored = qcref.write_probe(link, rf)
    if args.json:
        d = json.loads(rf.to_json())
        if stored is not None:
            from inclino.survey import qcref

            d["probe_qc_reference"] = {"port": args.port, "read_back": qcref.readable(stored)}
        print(json.dumps(d))
    else:
        for k, v in reffield_table(rf):
            print(f"{k:16s} {v}")
        if stored is not None:
            from inclino.survey import qcref

            print(f"probe QC reference on {args.port}, written and read back: {qcref.text(stored)}")
    return 0


def reffield_table(rf):
    """(key, text) rows of `inclino reffield`: the JSON's keys, in its order
    (an unknown value: `unknown`; the QC windows: key=value)."""
    fmt = {"declination_deg": ".4f", "dip_deg": ".4f", "field_nT": ".1f", "gravity_g": ".6f", "lat_deg": ".6f",
           "lon_deg": ".6f", "alt_m": "g", "convergence_deg": ".6f", "scale_factor": ".8f", "easting_m": ".3f",
           "northing_m": ".3f"}
    rows = []
    for k, v in rf.to_dict().items():
        if v is None:
            text = "unknown"
        elif isinstance(v, dict):
            text = " ".join(f"{a}={b:g}" for a, b in v.items())
        elif isinstance(v, float) and k in fmt:
            text = format(v, fmt[k])
        else:
            text = str(v)
        rows.append((k, text))
    return rows


def _open_link(args):
    from inclino.link.serial_link import ProbeLink, check_link_options

    baud = 115200 if args.baud is None else args.baud
    timeout = 1.0 if args.timeout is None else args.timeout
    check_link_options(baud, timeout)
    return ProbeLink(args.port, baud=baud, timeout=timeout)


def _cmd_toolmodel(args) -> int:
    _field_options(args)
    from inclino.survey import errormodel as em, models

    if args.tool_model and args.revision is not None:
        raise DataError("--revision: the model is written in --tool-model's revision; give one of them")
    require(args, "cal", "--cal CAL.json", "the calibration with its fit report")
    cal = _survey_calibration(args.cal)
    rf = _reference(args) if (args.lat is not None or args.declination is not None or args.ref) else None
    dip = rf.dip_deg if rf is not None and math.isfinite(rf.dip_deg) else \
        args.dip if args.dip is not None else _cal_dip(cal)
    tot = rf.field_nT if rf is not None and math.isfinite(rf.field_nT) else args.field or 50000.0
    if args.noise:
        from inclino.survey.wellpath import read_survey_rows

        na, nm = em.noise_from_survey(read_survey_rows(args.noise))
        an = na if args.acc_noise is None else args.acc_noise
        mn = nm if args.mag_noise is None else args.mag_noise
        src = f"repeated surveys at rest ({args.noise})"
        for name, v in (("--acc-noise", an), ("--mag-noise", mn)):
            if not (math.isfinite(v) and v >= 0):
                raise DataError(f"{name} must be >= 0")
    else:
        an, mn, src = _noise(args, cal)
    base = models.load(args.tool_model) if args.tool_model else None
    rev = (int(base.revision) if base.revision < 5 else 5) if base is not None else (args.revision or 5)
    tm = em.from_calibration(cal, dip, tot, acc_noise_g=an, mag_noise_nT=mn, name=args.name, noise_source=src,
                             revision=rev)
    if base is None:
        tm.save(args.output, reference=args.ref_terms or "none")
        what = f"the probe's terms, ISCWSA revision {rev}"
    else:
        m = models.ErrorModel(base, tm, args.ref_terms)
        d = m.to_iscwsa(args.name)
        d["inclino"] = json.loads(tm.to_json())
        d["inclino"]["base"] = base.label
        from inclino.survey.wellpath import _write

        _write(args.output, json.dumps(d, indent=2) + "\n")
        what = f"{base.label} (revision {base.revision:g}) with the probe's sensor terms in place of its own"
    f = tm.fit
    corr = [n for n in tm.correlated if n in tm.systematic]
    shown = [f"{g} {_show(g, v)}" for g, v in tm.systematic.items() if g not in tm.correlated and (v or not corr)]
    if corr:  # the combination terms' magnitudes are dimensionless (their weights carry the units)
        xy = [n for n in corr if n.startswith(em.CORRELATED_PREFIX_XY)]
        z = [n for n in corr if n not in xy]
        parts = [f"{len(v)} {what} ({v[0]}..{v[-1]})" for v, what in ((z, "toolface-independent"),
                                                                      (xy, "toolface-dependent")) if v]
        shown.append(" and ".join(parts) + " correlated combination terms: the calibration's bias, scale and "
                     "misalignment errors with their correlations")
    print(f"tool model {tm.name} -> {args.output}: {what}; " + ", ".join(shown))
    print(f"noise per survey: acc {an:.3g} g, mag {mn:.3g} nT, from {src}")
    print(f"projection of the calibration covariance: "
          f"sigma ratio {f['sigma_ratio_min']:.2f}-{f['sigma_ratio_max']:.2f} (RMS {f['sigma_ratio_rms']:.1%} off) "
          f"over {f['attitudes']} attitudes at dip {f['dip_deg']:.2f} deg, {f['field_nT']:.0f} nT")
    mc = f["monte_carlo"]
    print(f"Monte Carlo over the covariance ({mc['draws']} draws, {len(mc['inc_deg'])} attitudes, inclination "
          f"{min(mc['inc_deg']):g}-{max(mc['inc_deg']):g} deg): model/MC 1-sigma inclination "
          f"{min(mc['inc_ratio']):.2f}-{max(mc['inc_ratio']):.2f}, azimuth {min(mc['azi_ratio']):.2f}-"
          f"{max(mc['azi_ratio']):.2f} ({'within' if mc['within_20pct'] else 'NOT within'} +-20 %)")
    line = toolmodel_verdict(mc, args.output)
    print(line)
    if not mc["within_20pct"]:  # exit 1 says why on stderr too (the file is written either way)
        print(f"inclino: {line}", file=sys.stderr)
    return 0 if mc["within_20pct"] else 1


def toolmodel_verdict(mc, output) -> str:
    """`inclino toolmodel`'s last line: the Monte Carlo check's verdict and
    the ratio that decided it (the one furthest outside +-20 %, in the
    Monte Carlo's standard errors)."""
    from inclino.survey.errormodel import mc_worst

    q, r, se, inc, azi = mc_worst(mc)
    what = (f"model/Monte Carlo 1-sigma of {q} {r:.3f} (+-{se:.3f}) at inclination {inc:g} deg, azimuth {azi:g} "
            f"deg")
    if mc["within_20pct"]:
        return f"verdict: PASS: every ratio within +-20 %; the furthest out: {what}"
    return (f"verdict: FAIL: {what} is outside +-20 % by more than two of its standard errors; {output} is "
            "written, but its 1-sigma misstates the calibration's")


def _show(g, v):
    if g.startswith("AB"):
        return f"{v:.3g} m/s2"
    if g.startswith("MB"):
        return f"{v:.3g} nT"
    if g.startswith("XYM"):
        return f"{math.degrees(v):.3g} deg"
    return f"{v:.3g}"


def _cmd_trajectory(args) -> int:
    _field_options(args)
    from inclino.survey import wellpath as wp

    from inclino.formats import safeio

    if not args.uncertainty:
        given = [o for o, v in (("--tool-model", args.tool_model), ("--cal", args.cal),
                                ("--acc-noise", args.acc_noise), ("--mag-noise", args.mag_noise),
                                ("--ref-terms", args.ref_terms)) if v is not None]
        if given:
            raise DataError(f"{', '.join(given)} set the error model of --uncertainty: add --uncertainty "
                            "(or leave them out)")
    for out in (args.output, args.las):
        if out:
            safeio.check_output(out, args.input)  # never over a survey file it reads
    from inclino import progress

    with progress.phase(f"reading {len(args.input)} survey listing(s)"):  # long work shows its progress on stderr
        sv = wp.concat([wp.read_survey(p) for p in args.input])
    rf = _reference(args)
    from inclino.survey import models

    model = _error_model(args, rf, default_base=models.DEFAULT_BASE) if args.uncertainty else None
    if model is not None and len(sv) and sv.md_m[0] > 0:
        model.notes.append(tie_in_note(float(sv.md_m[0])))
    tf_note = model.toolface_note(sv.extra.get("tf_deg"), len(sv)) if model is not None else None
    if tf_note:
        model.notes.append(tf_note)
    with progress.phase(f"trajectory of {len(sv)} stations"):
        tr = wp.trajectory(sv, rf, model)
    with progress.phase(f"writing {len(tr)} stations"):
        if args.output.lower().endswith(".las"):
            wp.write_las(tr, args.output)
        else:
            wp.write_csv(tr, args.output)
        if args.las:
            wp.write_las(tr, args.las)
    if args.plot:
        import os

        from inclino.survey import wellplot

        folder, name = plot_target(args.plot, "trajectory.png")
        path = os.path.join(folder, name)
        try:
            os.makedirs(folder, exist_ok=True)
            wellplot.plot(tr, path, title=f"{' '.join(args.input)}: {len(tr)} stations")
        except OSError as e:
            raise DataError(f"cannot write {path}: {e.strerror}")
    s = tr.summary
    e = s["end"]
    stream = sys.stderr if args.output == "-" else sys.stdout
    parts = e.get("parts", {})
    msg = (f"{s['stations']} stations ({s.get('run') or 'survey'}), MD {s['md_m'][0]:g}-{s['md_m'][1]:g} m; "
           f"declination {rf.declination_deg:.2f} deg ({rf.ref_source})"
           + (f", grid convergence {rf.convergence_deg:.3f} deg (EPSG {rf.grid_epsg})" if rf.grid_epsg else "")
           + f"; end TVD {e['tvd_m']:.2f} m, N {e['north_m']:.2f} m, E {e['east_m']:.2f} m"
           + (f"; 1-sigma ellipse {e['ell_major_m']:.3f} x {e['ell_minor_m']:.3f} m" if model is not None else "")
           + (" (" + ", ".join(f"{model.part_label(k)} {v['ell_major_m']:.3f} x {v['ell_minor_m']:.3f} m"
                               for k, v in parts.items()) + ")" if len(parts) > 1 else "")
           + f"; QC: {s['stations'] - s['qc_fail']} pass, {s['qc_fail']} fail (checked: "
           + "; ".join(s.get("qc_checked", [])) + ")")
    print(msg, file=stream)
    if model is not None:
        print(model.describe(), file=stream)
        for n in model.notes:
            print(f"  {n}", file=stream)
    return 1 if (args.fail_on_qc and s["qc_fail"]) else 0


def tie_in_note(md0: float) -> str:
    """A listing that starts below the surface: its first station is the
    tie-in, taken as exact (the hole above it is not in the listing)."""
    return (f"the first station, MD {md0:g} m, is the tie-in: its position is taken as exact, so the ellipses hold "
            "the error from it down, not the hole's above it (add the tie-in's own covariance)")


def _cmd_compare(args) -> int:
    _field_options(args)
    from inclino.survey import compare as cmp
    from inclino.survey import geomag
    from inclino.survey import wellpath as wp

    from inclino import progress

    with progress.phase("reading the two survey listings"):  # long work shows its progress on stderr
        a, b = wp.read_survey(args.first), wp.read_survey(args.second)
    rf = _reference(args) if (args.lat is not None or args.ref or args.declination is not None) else None
    model = _error_model(args, rf, add_reference=False)  # the reference sets dip and field; --ref-terms adds its terms
    fit = model.probe or (model.base.inclino if model.base is not None else None)
    dip = rf.dip_deg if rf is not None and math.isfinite(rf.dip_deg) else \
        args.dip if args.dip is not None else (fit.fit.get("dip_deg", 60.0) if fit else 60.0)
    tot = rf.field_nT if rf is not None and math.isfinite(rf.field_nT) else \
        args.field if args.field is not None else (fit.fit.get("field_nT", 50000.0) if fit else 50000.0)
    ref = geomag.ReferenceField(rf.declination_deg if rf is not None else 0.0, dip, tot,
                                rf.gravity_g if rf is not None and math.isfinite(rf.gravity_g) else 1.0)
    with progress.phase(f"comparing {len(a)} and {len(b)} stations"):
        r = cmp.compare(a, b, model, ref, k=args.k, md_tol=args.md_tol, two_probes=args.two_probes,
                        noise_dof=_noise_dof(args))
    if args.json:
        r.write_json(sys.stdout)
        print()
    else:
        print(f"{args.first}: {r.runs[0] or 'survey'}; {args.second}: {r.runs[1] or 'survey'}; {model.describe()}")
        for n in model.notes:
            print(f"  {n}")
        if model.calibration is not None and not args.two_probes:
            print("  the probe's calibration terms: " + (
                "its covariance at each station's toolface in both surveys (their tf_deg): a station read twice at "
                "one toolface differs by the noise alone" if r.toolface != "averaged" else
                "toolface-averaged, counted as independent between the surveys (a survey without tf_deg at every "
                "paired station)"))
        print(f"{'MD m':>9} {'MD out m':>9} {'inc':>8} {'d inc':>9} {'k sig':>8} {'d azi':>9} {'k sig':>8}  verdict")
        for s in r.stations:
            da = "" if s["d_azi_deg"] is None else f"{s['d_azi_deg']:9.4f} {r.k_limit * s['sigma_d_azi_deg']:8.4f}"
            print(f"{s['md_m']:9.2f} {s['md_out_m']:9.2f} {s['inc_deg']:8.3f} {s['d_inc_deg']:9.4f} "
                  f"{r.k_limit * s['sigma_d_inc_deg']:8.4f} {da:18s}  {s['verdict']}")
        sm = r.summary
        kt = "" if r.noise_dof is None else (f", limit {r.k_limit:.3g} sigma: Student's t of k's probability, the "
                                             f"noise estimated on {r.noise_dof:g} degrees of freedom")
        print(f"{sm['pairs']} station pairs ({r.mode}, k = {r.k:g}{kt}): {sm['pairs'] - sm['failed']} pass, "
              f"{sm['failed']} fail; unmatched {sm['unmatched_in']} + {sm['unmatched_out']}; verdict: "
              + ("PASS" if r.passed else "FAIL"))
    return 0 if r.passed else 1


def add_parser(sub) -> None:
    p = command(sub, "reffield", "reference field of a survey: declination, dip, total field, gravity, grid",
                "The reference a survey is corrected and checked against: declination, dip and total field "
                "from a main-field model (IGRF or WMM) at the wellhead's position, height and date, or given "
                "by hand (in-field referencing: --declination, --dip, --field override the model), WGS 84 "
                "normal gravity, and with --grid the grid convergence of a projected CRS. -o keeps it as a "
                "file for trajectory --ref; --port writes it into the probe as its QC reference, reads it back "
                "and prints it.",
                ["inclino reffield --lat 52.1 --lon 4.3 --date 2024-06-01 -o ref.json",
                 "inclino reffield --declination 1.8 --dip 67.2 --field 49800 --json"])
    _add_reference(p)
    add_output(p, "write the reference field as JSON (stored with the run)", required=False, metavar="REF.json")
    p.add_argument("--port", action=Input, help="also write it to the probe as its QC reference (QCREF_WRITE), read it back "
                                  "and print it")
    p.add_argument("--baud", type=int, help="with --port: serial speed, bits/s (default 115200)")
    p.add_argument("--timeout", type=float, help="with --port: seconds to wait for an answer (default 1)")
    add_json(p)
    p.set_defaults(func=_cmd_reffield)

    p = command(sub, "toolmodel", "the calibrated probe's error model as an ISCWSA tool model (JSON)",
                "Turn a calibration's fit covariance into the probe's ISCWSA error terms (the systematic terms "
                "and the per-survey noise, from --noise, the given values or the fit report), checked by a "
                "Monte Carlo over the covariance; exit 1 when the model's 1-sigma misses the Monte Carlo's by "
                "more than 20 % (the file is written either way). With --tool-model the whole standard model "
                "is written with the probe's sensor terms in place of its own. `trajectory --uncertainty` and "
                "`compare` use it.",
                ["inclino toolmodel --cal cal.json --dip 67 --field 49800 --noise rest.csv -o tool.json",
                 "inclino toolmodel --cal cal.json --dip 67 --field 49800 --tool-model iscwsa-mwd-rev5 -o mwd.json"])
    add_cal(p, "calibration JSON with its fit report (inclino calibrate)", positional_alias=True)
    _add_reference(p, grid=False)
    p.add_argument("--noise", metavar="SURVEYS.csv", action=Input,
                   help="a survey listing of repeated surveys at rest (at least 3 with gt_g and bt_nT): the "
                        "per-survey noise (default: the calibration's fit report)")
    p.add_argument("--acc-noise", type=float, help="accelerometer noise per survey and axis, g (default: the "
                                                   "calibration's fit report)")
    p.add_argument("--mag-noise", type=float, help="fluxgate noise per survey and axis, nT (default: the "
                                                   "calibration's fit report)")
    p.add_argument("--tool-model", metavar="MODEL", action=Input,
                   help="write the complete model: this standard model (iscwsa-mwd-rev5, a name welleng ships, or "
                        "an ISCWSA JSON file) with the probe's sensor terms in place of its own")
    p.add_argument("--revision", type=int, choices=(4, 5), help="ISCWSA revision of the probe's terms (default 5: "
                                                                "XYM3E/XYM4E random, damped; 4: XYM3/XYM4 "
                                                                "systematic)")
    p.add_argument("--name", default="INCLINO", help="the tool model's short name (default %(default)s)")
    p.add_argument("--ref-terms", choices=("none", "srgm", "ifr1"),
                   help="reference-field terms to include (default: none for the probe's terms, trajectory adds "
                        "them per survey; with --tool-model its own)")
    add_output(p, "tool model JSON", metavar="TOOL.json")
    p.set_defaults(func=_cmd_toolmodel)

    p = command(sub, "trajectory", "well path by minimum curvature from a survey listing, with QC "
                                   "and position uncertainty",
                "Compute the well path (TVD, north, east, dogleg) by minimum curvature from survey listings, "
                "with azimuths referred to true or grid north, each station's QC against the reference field "
                "(naming the checks that ran), and with --uncertainty the position covariance and 1-sigma "
                "ellipse from an ISCWSA error model (a standard one, or the probe's from --cal). Writes CSV or "
                "LAS 2.0; exit 1 with --fail-on-qc when a station fails QC.",
                ["inclino trajectory stations.csv --ref ref.json -o path.csv",
                 "inclino trajectory stations.csv --ref ref.json --uncertainty --cal cal.json --plot figures "
                 "-o path.csv"])
    p.add_argument("input", nargs="+", action=Input, help="survey listing(s) (CSV, JSON lines or LAS) with md_m, inc_deg, azi_deg; "
                                            "several files are one survey, sorted by depth")
    _add_reference(p)
    p.add_argument("--uncertainty", action="store_true", help="position covariance (1-sigma ellipse) per station")
    p.add_argument("--tool-model", metavar="MODEL", action=Input,
                   help="with --uncertainty: the error model: a standard model by name (iscwsa-mwd-rev5, "
                        "iscwsa-mwd-rev4, any name welleng ships) or an ISCWSA JSON file (inclino toolmodel writes "
                        "one) (default with --cal: iscwsa-mwd-rev5)")
    add_cal(p, "with --uncertainty: the probe's calibration: its fitted sensor terms and measured noise replace "
               "the model's sensor terms (with the listing's tf_deg at every station: its covariance at each "
               "station's own toolface, not averaged over the toolface)")
    p.add_argument("--acc-noise", type=float, help="with --cal: accelerometer noise per survey and axis, g "
                                                   "(default: the calibration's fit report)")
    p.add_argument("--mag-noise", type=float, help="with --cal: fluxgate noise per survey and axis, nT "
                                                   "(default: the calibration's fit report)")
    p.add_argument("--ref-terms", choices=("none", "srgm", "ifr1"),
                   help="with --uncertainty: reference-field terms in place of the model's (default: the model's "
                        "own; for a model without them srgm for a main-field model, ifr1 for user values)")
    p.add_argument("--las", metavar="FILE.las", action=Output, help="also write the trajectory as LAS 2.0")
    p.add_argument("--fail-on-qc", action="store_true", help="exit 1 when a station fails QC")
    add_plot(p, "write a PNG of the path (plan view with the ellipses, vertical section) into this folder, "
                "as trajectory.png")
    add_output(p, "trajectory CSV ('-' for stdout; .las for LAS 2.0)", metavar="OUT.csv")
    p.set_defaults(func=_cmd_trajectory)

    p = command(sub, "compare", "repeatability QC of two surveys station by station",
                "Compare two surveys of the same stations (in-run and out-run, or two probes), paired by depth: "
                "each pair's inclination and azimuth difference against k times the spread the error model "
                "expects for it (the probe's terms from --cal, a standard model, or both). Exit 1 when a pair "
                "is outside.",
                ["inclino compare in.csv out.csv --cal cal.json",
                 "inclino compare a.csv b.csv --tool-model iscwsa-mwd-rev5 --cal cal.json --two-probes --json"])
    p.add_argument("first", action=Input, help="a survey listing (in-run or out-run)")
    p.add_argument("second", action=Input, help="the other survey listing of the same stations (out-run, in-run, second probe)")
    p.add_argument("--tool-model", metavar="MODEL", action=Input,
                   help="the error model: a standard model by name (iscwsa-mwd-rev5, ...) or an ISCWSA JSON file "
                        "(inclino toolmodel writes one)")
    add_cal(p, "the probe's calibration: its fitted sensor terms and measured noise (alone: the probe's terms "
               "only; with --tool-model: in place of its sensor terms)")
    p.add_argument("--acc-noise", type=float, help="with --cal: accelerometer noise per survey and axis, g "
                                                   "(default: the calibration's fit report)")
    p.add_argument("--mag-noise", type=float, help="with --cal: fluxgate noise per survey and axis, nT "
                                                   "(default: the calibration's fit report)")
    _add_reference(p, grid=False)
    p.add_argument("--ref-terms", choices=("none", "srgm", "ifr1"),
                   help="reference-field terms in place of the model's: their random terms (DECR, DBHR) enter the "
                        "expected spread (default: the model's own; none for --cal alone, whatever reference is "
                        "given)")
    p.add_argument("--two-probes", action="store_true", help="two probes: every sensor term differs")
    p.add_argument("--k", type=float, default=3.0,
                   help="pass within k x the expected sigma (default %(default)g; where the noise is the "
                        "calibration's residuals, Student's t quantile of k's probability with their degrees of "
                        "freedom)")
    p.add_argument("--md-tol", type=float, default=0.5,
                   help="pair stations within this many m of MD (default %(default)g)")
    add_json(p)
    p.set_defaults(func=_cmd_compare)
