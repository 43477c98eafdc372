"""`inclino accept --temperatures -5,25,55 --cal CAL.json`: the acceptance
grid at several chamber set points, with the calibration's temperature
terms and without them (docs/cli.md, docs/calibration.md).

At each set point in turn:

1. the chamber is set (the emulator's control channel `chamber` on a bench,
   the person otherwise; a ramp at --ramp-rate degC/min) and the probe is
   read at the grid's first position every --interval-min minutes until its own
   temperature has settled (acquire_temp.settled: within --soak-band of the
   set point, changed by at most --soak-tol over --soak-window-min minutes; a
   bench also waits for its air to reach the set point and gives up after
   --max-soak-min minutes, exit 4);
2. the grid (accept's li2021 or ren2014, or --inclinations/--azimuths) is
   taken with the usual stability check (--reads readings that agree).

Every reading's raw record (the Q6 means the correction receives and the
probe's averaged temperature, SURVEY_RAW) goes through the correction with
the temperature terms and through the same M, b without them (the
room-temperature-only calibration), by the temperature engine
(inclino.engines.temperature: the firmware's fixed-point correction; `engine` and
`terms_in_firmware` in the result say which -- while the firmware does not
apply the terms, host-terms applies them on the host before the firmware's
C).  The probe's own survey of each reading is checked bit for bit against
the prediction from what it stores (as `inclino accept`).

Takings (pooling): the grid is taken --takings times (default 1) at each set
point, and the positions within VERTICAL_DEG of vertical (Li's I = 2 deg,
Ren's +-3 deg tilts) --vertical-takings times in all (default 8).  Their
azimuth error is ~1/sin I times the reading noise, so they make most of the
azimuth RMS and nearly all of its sampling spread, and their noise is
independent at each set point: one taking's ratio scattered 0.71-1.63 for
probes whose expected ratio is ~1 (docs/calibration.md).  Each position's
squared error is the mean over its takings, and the RMS is over positions,
so the pooled RMS estimates the same expected figure as one taking with the
spread cut by about sqrt(takings) where it arises, at a cost of
(vertical-takings - 1) x 6 % more positions on the Li grid.

Per set point: azimuth and inclination RMS (pooled) and max with and without
the terms, the gain (without / with), the ratio to the reference set point's
figure (--reference-temp, default 25 degC, which must be one of the set
points) of the same column, and the ratio's standard uncertainty from the
reading noise (pooled_stats: each position's noise variance from the scatter
of its --reads readings).  Verdict (exit 1 when it fails): with the terms,
no set point's azimuth or inclination ratio above --target-ratio (default
1.2) by more than --significance-z (default 2) of its standard
uncertainties, and every survey equal to the prediction; a ratio above the
target within that margin passes with a note (`above_within_uncertainty`)
saying to take more takings for a sharper figure.
"""
from __future__ import annotations

import json
import math
import sys
import time
from dataclasses import asdict, dataclass, field

import numpy as np

from inclino.procedures.accept import GRIDS, GridPoint, _measure, grid_points, stored_calibration
from inclino.formats.jsonout import dumps
from inclino.procedures.poses import Step
from inclino.procedures.readings import Tolerance, read_stable
from inclino.procedures.acquire_temp import TEMP_RANGE_C, ThermalPlan, _Chamber, settled
from inclino.errors import DataError

DEFAULT_TARGET_RATIO = 1.2
DEFAULT_REFERENCE_C = 25.0
DEFAULT_TOOLFACES = (0.0, 120.0, 240.0)  # --temperatures without --toolfaces
MAX_SETPOINTS = 20
DEFAULT_TAKINGS = 1  # of the whole grid per set point
DEFAULT_VERTICAL_TAKINGS = 8  # of the positions within VERTICAL_DEG of vertical, in all
DEFAULT_SIGNIFICANCE_Z = 2.0  # a ratio fails when above the target by more than this many standard uncertainties
VERTICAL_DEG = 5.0  # |set inclination or tilt| below this: near vertical, the azimuth noise ~1/sin I
MAX_TAKINGS = 50
DEFAULT_AVERAGE = 16  # samples per reading unless --average: the probe's default, as the bench reads the grid


@dataclass
class TempAcceptResult:
    grid: str
    probe_serial: int
    setpoints_c: list
    reference_c: float
    target_ratio: float
    engine: str
    terms_in_firmware: bool
    calibration: str  # what the "with" column is
    declination_deg: float
    download: dict | None = None
    setpoints: list = field(default_factory=list)  # per set point: soak, probe temperature, stats, ratios, gains
    points: list = field(default_factory=list)  # per set point and grid position: errors with / without
    surveys_checked: int = 0
    survey_mismatches: list = field(default_factory=list)
    with_equals_probe: int = 0  # readings whose "with" survey is the probe's own, bit for bit
    passed: bool = False
    reasons: list = field(default_factory=list)
    world: dict = field(default_factory=dict)
    elapsed_s: float = 0.0
    takings: int = 1  # of the whole grid per set point
    vertical_takings: int = 1  # of the positions within VERTICAL_DEG of vertical, in all
    significance_z: float = 0.0  # the verdict's margin, in standard uncertainties of the ratio
    above_within_uncertainty: list = field(default_factory=list)  # ratios above the target, not significantly

    def to_json(self) -> str:
        return dumps(asdict(self))

    @staticmethod
    def from_json(text: str) -> "TempAcceptResult":
        d = json.loads(text)
        if not isinstance(d, dict):
            raise DataError("not an accept --temperatures result")
        try:
            return TempAcceptResult(**d)
        except TypeError as e:
            raise DataError(f"not an accept --temperatures result: {str(e)[:80]}") from None


def parse_setpoints(text: str, reference_c: float = DEFAULT_REFERENCE_C) -> tuple:
    """The --temperatures list, checked: numbers within the ADIS16210's
    operating range, no repeats, at most MAX_SETPOINTS, the reference among
    them."""
    items = [x.strip() for x in str(text).split(",")]
    if not any(items):
        raise DataError("--temperatures needs comma-separated set points in degC, e.g. -5,25,55")
    try:
        vals = tuple(float(x) for x in items)
    except ValueError:
        raise DataError(f"--temperatures wants comma-separated set points in degC, got {text!r}") from None
    for v in vals:
        if not math.isfinite(v) or not TEMP_RANGE_C[0] <= v <= TEMP_RANGE_C[1]:
            raise DataError(f"--temperatures: {v:g} degC is outside the probe's {TEMP_RANGE_C[0]:g} to "
                            f"{TEMP_RANGE_C[1]:g} degC")
    if len(set(vals)) != len(vals):
        raise DataError("--temperatures lists a set point twice")
    if len(vals) > MAX_SETPOINTS:
        raise DataError(f"--temperatures: at most {MAX_SETPOINTS} set points")
    if not math.isfinite(reference_c) or reference_c not in vals:
        raise DataError(f"--reference-temp {reference_c:g} degC must be one of the set points "
                        f"({', '.join(f'{v:g}' for v in vals)})")
    if len(vals) < 2:
        raise DataError("--temperatures needs the reference set point and at least one other")
    return vals


def _soak(link, table, chamber: _Chamber, sp: float, plan: ThermalPlan, tol, max_reads, first: Step, say):
    """Set the chamber and wait until the probe has settled at sp; returns
    (minutes, probe temperature)."""
    from inclino.procedures.readings import Unsettled

    table.move(Step(first.inc, first.azi, first.tf, f"{sp:g} degC: soak at {first.label}"), 0, 0)
    chamber.set(sp, plan.ramp_rate)
    history, minutes = [], 0.0
    while True:
        win = read_stable(link, tol, max_reads if table.unattended else None)
        history.append((minutes, sum(w.temp_c for w in win) / len(win)))
        if say is not None:
            say(f"  set point {sp:g} degC: probe at {history[-1][1]:.2f} degC after {minutes:g} min")
        if settled(history, sp, plan) and chamber.air_at(sp):
            return minutes, history[-1][1]
        if table.unattended and minutes >= plan.max_soak_min:
            raise Unsettled(f"set point {sp:g} degC: the probe did not settle in {plan.max_soak_min:g} min "
                            f"(at {history[-1][1]:.2f} degC)")
        chamber.wait(plan.interval_min)
        minutes += plan.interval_min


def _point_errors(inc, azi, flags, p: GridPoint, decl: float) -> dict:
    """The position's error (the mean over its readings) and the variance of
    that mean from the readings' scatter (None with one reading)."""
    errs = [_measure((float(i), float(a)), int(f), p, decl) for i, a, f in zip(inc, azi, flags)]
    az = [e["azi_err"] for e in errs if e["azi_err"] is not None]
    ie = [e["inc_err"] for e in errs]

    def var_mean(x):
        return float(np.var(x, ddof=1) / len(x)) if len(x) > 1 else None

    full = len(az) == len(errs)
    return {"inc_err": float(np.mean(ie)), "azi_err": float(np.mean(az)) if full else None,
            "inc_var": var_mean(ie), "azi_var": var_mean(az) if full else None}


def pooled_stats(points: list, which: str) -> dict:
    """One set point's figures for one column ("with" / "without") from its
    rows (every taking of every position): RMS over positions of each
    position's root-mean-square error over its takings (the expected RMS of
    one taking, estimated with the spread of all of them), max over rows,
    and the relative standard uncertainty of each RMS from the reading
    noise.

    With e_p the error of a taking (the mean of its R readings), sigma_p^2
    the variance of that mean (the readings' scatter / R, averaged over the
    takings) and m_p the mean of e_p^2 over the position's K_p takings:
    Q = mean_p m_p, RMS = sqrt(Q); Var(e^2) = 4 s^2 sigma^2 + 2 sigma^4 for
    e ~ N(s, sigma^2), i.e. 4 E[e^2] sigma^2 - 2 sigma^4, estimated without
    bias as 4 m_p sigma_p^2 - 2 c_p sigma_p^4 (c_p = nu / (nu + 2), nu the
    degrees of freedom of sigma_p^2: the sum over takings of R - 1);
    Var(Q) = sum_p Var(e_p^2) / K_p / P^2, not below its noise-only part;
    u(RMS) / RMS = sqrt(Var Q) / (2 Q).  Covers the reading noise only (not
    a turntable that does not return to the same pose; none on the
    emulator); None with one reading per position."""
    out = {}
    for q in ("azi", "inc"):
        groups: dict = {}
        for r in points:
            e = r[which][f"{q}_err"]
            if e is None:
                continue
            v = r[which].get(f"{q}_var")
            groups.setdefault((r["set_inc"], r["set_azi"], r["tf"]), []).append((e, v, int(r.get("reads", 1))))
        rows = [x[0] for g in groups.values() for x in g]
        if not groups:
            out.update({f"{q}_rms_deg": None, f"{q}_max_deg": None, f"{q}_points": 0, f"{q}_rows": 0,
                        f"{q}_rms_rel_u": None})
            continue
        gs = list(groups.values())
        m = np.array([np.mean([x[0] ** 2 for x in g]) for g in gs])
        k = np.array([len(g) for g in gs], float)
        s2 = np.array([np.mean([x[1] for x in g]) if all(x[1] is not None for x in g) else np.nan for g in gs])
        nu = np.array([sum(x[2] - 1 for x in g) for g in gs], float)
        Q = float(m.mean())
        rel = None
        if Q > 0 and np.all(np.isfinite(s2)) and np.all(nu > 0):
            c = nu / (nu + 2.0)  # E[s2^2] = sigma^4 (nu + 2) / nu
            var_q = float(np.sum((4.0 * m * s2 - 2.0 * c * s2 ** 2) / k)) / len(m) ** 2
            var_q = max(var_q, float(np.sum(2.0 * c * s2 ** 2 / k)) / len(m) ** 2)
            rel = float(np.sqrt(var_q) / (2.0 * Q))
        out.update({f"{q}_rms_deg": float(np.sqrt(Q)), f"{q}_max_deg": float(np.max(np.abs(rows))),
                    f"{q}_points": len(groups), f"{q}_rows": len(rows), f"{q}_rms_rel_u": rel})
    return out


def near_vertical(p: GridPoint) -> bool:
    return abs(p.set_inc) < VERTICAL_DEG


def taking_plan(pts: list, takings: int, vertical_takings: int) -> list:
    """(taking, index into pts) in the order they are taken: the whole grid
    `takings` times, then the near-vertical positions until each has
    max(takings, vertical_takings) takings."""
    order = [(t, i) for t in range(takings) for i in range(len(pts))]
    order += [(t, i) for t in range(takings, max(takings, vertical_takings))
              for i, p in enumerate(pts) if near_vertical(p)]
    return order


def _predict(acc, mag, tq6, stored_fc):
    """The probe's surveys from what it stores: the firmware's C with the
    stored image (its temperature terms when it holds them)."""
    from inclino.engines import firmware as core

    if getattr(stored_fc, "temp", None) is not None:
        return core.survey(acc, mag, stored_fc, temp_q6=tq6)
    return core.survey(acc, mag, stored_fc)


def accept_temperatures(link, table, cal, setpoints=(-5.0, 25.0, 55.0), grid: str = "li2021",
                        reference_c: float = DEFAULT_REFERENCE_C, target_ratio: float = DEFAULT_TARGET_RATIO,
                        plan: ThermalPlan | None = None, engine: str = "auto", inclinations=None, azimuths=None,
                        toolfaces=DEFAULT_TOOLFACES, tol: Tolerance | None = None, max_reads: int = 30,
                        declination: float | None = None, download: bool = True, force: bool = False,
                        quiet: bool = False,
                        average: int | None = None, sleep=time.sleep, takings: int = DEFAULT_TAKINGS,
                        vertical_takings: int = DEFAULT_VERTICAL_TAKINGS,
                        significance_z: float = DEFAULT_SIGNIFICANCE_Z) -> TempAcceptResult:
    """The grid at each set point on `table` (turntable_emulated.EmulatedTurntable
    or turntable.ManualTurntable); cal: the Calibration with temperature terms (CAL.json),
    downloaded first unless download is False.  average None: the probe's
    default 16 samples per reading (what the ratio's figures are for)."""
    from inclino.link import operations as calops
    from inclino.engines import temperature as temp_engine
    from inclino.procedures.readings import progress_bar, set_average

    tol = tol or Tolerance()
    tol.check()
    sps = tuple(float(t) for t in setpoints)
    parse_setpoints(",".join(repr(t) for t in sps), reference_c)
    if not temp_engine.has_terms(cal):
        raise DataError("the calibration has no temperature terms (fit them: inclino calibrate --method joint "
                        "--temperature-terms on, from a chamber run)")
    if not (math.isfinite(target_ratio) and target_ratio >= 1.0):
        raise DataError("--target-ratio must be a number >= 1")
    check_takings(takings, vertical_takings, significance_z)
    plan = plan or ThermalPlan(setpoints=sps)
    plan.setpoints = sps
    plan.check()
    eng = temp_engine.get(engine)
    eng.check(cal)  # the firmware engine: refused when the image cannot hold the terms
    pts = grid_points(grid, inclinations, azimuths, toolfaces)
    t0 = time.monotonic()
    set_average(link, DEFAULT_AVERAGE if average is None else average)
    ident = link.identify()
    world = table.world()
    decl = float(declination if declination is not None else world.get("declination_deg", 0.0))
    res = TempAcceptResult(grid, ident.serial, list(sps), float(reference_c), float(target_ratio), eng.name,
                           eng.terms_in_firmware, "", decl, world=world, takings=int(takings),
                           vertical_takings=max(int(takings), int(vertical_takings)),
                           significance_z=float(significance_z))
    if download:
        d = calops.download(link, cal, force=force)
        res.download = {"slot": d.slot, "sequence": d.sequence, "image_crc": f"{d.image_crc:04X}"}
    stored_fc, stored_desc = stored_calibration(link)
    res.calibration = (f"{cal.method} with its temperature terms (order {cal.temperature['order']} about "
                       f"{cal.temperature['t_ref_c']:g} degC) from the file; the probe holds {stored_desc}")
    steps = [Step(*p.pose, f"{grid} grid: {'tilt' if grid == 'ren2014' else 'inclination'} {p.set_inc:g}, "
                  f"azimuth {p.set_azi:g}" + (f", toolface {p.tf:g}" if len(toolfaces) > 1 or p.tf else ""))
             for p in pts]
    order = taking_plan(pts, int(takings), int(vertical_takings))
    bar = progress_bar(len(sps) * len(order), "accept temperatures", quiet)

    def say(m):
        bar.write(m, file=sys.stderr)

    if not table.unattended and getattr(table, "default_say", False):
        table.say = say
    tell = table.say if not table.unattended else (None if quiet else say)
    chamber = _Chamber(table, sleep)
    fixed = {terms: eng.prepare(cal, terms) for terms in (True, False)}  # converted once, not per window
    try:
        for sp in sps:
            soak_min, probe_c = _soak(link, table, chamber, sp, plan, tol, max_reads, steps[0], tell)
            sp_points, temps = [], []
            for n, (t, i) in enumerate(order, start=1):
                p, st = pts[i], steps[i]
                again = f", taking {t + 1}" if t else ""
                table.move(Step(st.inc, st.azi, st.tf, f"{sp:g} degC: {st.label}{again}"), n, len(order))
                win = read_stable(link, tol, max_reads if table.unattended else None)
                acc = np.array([[round(v * 64) for v in r.acc] for r in win], np.int64)
                mag = np.array([[round(v * 64) for v in r.mag] for r in win], np.int64)
                tq6 = np.array([r.temp_q6 if r.temp_q6 is not None else
                                int(temp_engine.temp_q6_from_centi(round(r.temp_c * 100.0))) for r in win], np.int64)
                temps += [r.temp_c for r in win]
                cols = {}
                for key, terms in (("with", True), ("without", False)):
                    cols[key] = eng.survey(acc, mag, tq6, cal, terms=terms, fixed=fixed[terms])
                # the probe's own surveys against what it stores (its terms too, image version 2)
                want = _predict(acc, mag, tq6, stored_fc)
                keys = ("inc", "azi", "gtf", "mtf", "gt", "bt", "dip", "flags")
                for j, r in enumerate(win):
                    res.surveys_checked += 1
                    res.with_equals_probe += all(int(cols["with"][k][j]) == int(getattr(r.record, k)) for k in keys)
                    bad = [k for k in keys if int(want[k][j]) != int(getattr(r.record, k))]
                    if bad:
                        res.survey_mismatches.append(f"{sp:g} degC, {st.label}: " + ", ".join(
                            f"{k} probe {getattr(r.record, k)} predicted {int(want[k][j])}" for k in bad))
                row = {"setpoint_c": sp, "set_inc": p.set_inc, "set_azi": p.set_azi, "tf": p.tf, "taking": t + 1,
                       "pose": list(p.pose), "probe_c": float(np.mean([r.temp_c for r in win])),
                       "temp_q6": [int(v) for v in tq6], "reads": len(win)}
                for key in ("with", "without"):
                    inc, azi, flags = temp_engine.units(cols[key])
                    row[key] = _point_errors(inc, azi, flags, p, decl)
                # the probe's own survey (what it applies today)
                inc = [r.survey["inc_deg"] for r in win]
                azi = [r.survey["azi_deg"] for r in win]
                row["probe"] = _point_errors(inc, azi, [int(r.survey["flags"]) for r in win], p, decl)
                sp_points.append(row)
                bar.update(1)
            res.points += sp_points
            entry = {"setpoint_c": sp, "soak_min": soak_min, "probe_c_at_settle": probe_c,
                     "probe_c_mean": float(np.mean(temps)), "probe_c_min": float(np.min(temps)),
                     "probe_c_max": float(np.max(temps))}
            for key in ("with", "without"):
                entry[key] = pooled_stats(sp_points, key)
            res.setpoints.append(entry)
    finally:
        bar.close()
    _verdict(res)
    res.elapsed_s = time.monotonic() - t0
    return res


def check_takings(takings, vertical_takings, significance_z) -> None:
    for name, v in (("--takings", takings), ("--vertical-takings", vertical_takings)):
        if isinstance(v, bool) or int(v) != v or not 1 <= int(v) <= MAX_TAKINGS:
            raise DataError(f"{name} must be a whole number within 1-{MAX_TAKINGS}, got {v}")
    if not (math.isfinite(significance_z) and 0.0 <= significance_z <= 10.0):
        raise DataError(f"--significance-z must be within 0-10 standard uncertainties, got {significance_z}")


def _ratio_u(r, rel_t, rel_ref):
    """Standard uncertainty of r = RMS_T / RMS_ref from the two RMS's
    relative uncertainties (independent readings at the two set points)."""
    if r is None or rel_t is None or rel_ref is None:
        return None
    return float(r * math.hypot(rel_t, rel_ref))


def _verdict(res: TempAcceptResult) -> None:
    ref = next(s for s in res.setpoints if s["setpoint_c"] == res.reference_c)
    names = (("azi", "azimuth"), ("inc", "inclination"))
    for s in res.setpoints:
        is_ref = s is ref
        for q in ("azi", "inc"):
            for key in ("with", "without"):
                v, r0 = s[key][f"{q}_rms_deg"], ref[key][f"{q}_rms_deg"]
                s[f"{q}_ratio_{key}"] = (v / r0) if v is not None and r0 else None
                s[f"{q}_ratio_{key}_u"] = (0.0 if is_ref and s[f"{q}_ratio_{key}"] is not None else
                                           _ratio_u(s[f"{q}_ratio_{key}"], s[key][f"{q}_rms_rel_u"],
                                                    ref[key][f"{q}_rms_rel_u"]))
            w, wo = s["with"][f"{q}_rms_deg"], s["without"][f"{q}_rms_deg"]
            s[f"{q}_gain"] = (wo / w) if w and wo is not None else None
        bad, near = [], []
        for q, name in names:
            r, u = s[f"{q}_ratio_with"], s[f"{q}_ratio_with_u"]
            if r is None or r <= res.target_ratio:
                continue
            what = (f"{name} RMS {s['with'][f'{q}_rms_deg']:.4f} deg is {r:.2f}x"
                    + (f" (+-{u:.2f})" if u is not None else "")
                    + f" the {res.reference_c:g} degC figure {ref['with'][f'{q}_rms_deg']:.4f}")
            if u is not None and r - res.significance_z * u <= res.target_ratio:
                near.append(what)
            else:
                bad.append(what)
        s["within_target"] = not bad and not near
        s["fails_target"] = bool(bad)
        res.reasons += [f"at {s['setpoint_c']:g} degC with the terms: {b} (target {res.target_ratio:g}x, by more "
                        f"than {res.significance_z:g} standard uncertainties)" for b in bad]
        res.above_within_uncertainty += [
            f"at {s['setpoint_c']:g} degC with the terms: {x}: above the target {res.target_ratio:g}x but within "
            f"{res.significance_z:g} standard uncertainties (more --takings or --vertical-takings sharpen it)"
            for x in near]
    if res.survey_mismatches:
        res.reasons.append(f"{len(res.survey_mismatches)} of {res.surveys_checked} surveys differ from the stored "
                           "calibration's prediction")
    res.passed = not res.reasons


def render(res: TempAcceptResult) -> str:
    def f(v, p=4):
        return "-" if v is None else f"{v:.{p}f}"

    def pm(u):
        return "" if not u else f" +-{u:.2f}"

    out = [f"Acceptance at {len(res.setpoints_c)} chamber set points on the {res.grid} grid, probe "
           f"{res.probe_serial}: {res.setpoints[0]['with']['inc_points'] if res.setpoints else 0} positions each, "
           f"{len(res.points) // max(1, len(res.setpoints_c))} takings of them (the grid {res.takings}x, "
           f"within {VERTICAL_DEG:g} deg of vertical {res.vertical_takings}x; each position's error pooled over its "
           "takings)",
           f"  with    = {res.calibration}",
           "  without = the same M, b without the temperature terms (room-temperature-only)",
           f"  engine  = {res.engine}" + ("" if res.terms_in_firmware else
                                          " (the terms on the host, then the firmware's C with M, b)")]
    if res.download:
        out.append(f"  downloaded to slot {res.download['slot']}, sequence {res.download['sequence']}")
    out.append("")
    out.append(f"{'set':>6} {'probe':>7} {'soak':>6} | {'azimuth RMS deg':^25} | {'inclination RMS deg':^25}")
    out.append(f"{'degC':>6} {'degC':>7} {'min':>6} | {'with':>7} {'without':>8} {'gain':>7} | "
               f"{'with':>7} {'without':>8} {'gain':>7} | ratio with / without (to {res.reference_c:g} degC)")
    for s in res.setpoints:
        out.append(f"{s['setpoint_c']:6g} {s['probe_c_mean']:7.2f} {s['soak_min']:6g} | "
                   f"{f(s['with']['azi_rms_deg']):>7} {f(s['without']['azi_rms_deg']):>8} {f(s['azi_gain'], 1):>6}x | "
                   f"{f(s['with']['inc_rms_deg']):>7} {f(s['without']['inc_rms_deg']):>8} {f(s['inc_gain'], 1):>6}x | "
                   f"azimuth {f(s['azi_ratio_with'], 2)}{pm(s['azi_ratio_with_u'])} / {f(s['azi_ratio_without'], 2)}, "
                   f"inclination {f(s['inc_ratio_with'], 2)}{pm(s['inc_ratio_with_u'])} / "
                   f"{f(s['inc_ratio_without'], 2)}")
    out.append(f"the probe's surveys against its stored calibration: {res.surveys_checked - len(res.survey_mismatches)}"
               f" of {res.surveys_checked} equal bit for bit; the \"with\" column is the probe's own survey in "
               f"{res.with_equals_probe} of them")
    out.append(f"rule: with the terms, azimuth and inclination RMS at every set point <= {res.target_ratio:g}x the "
               f"{res.reference_c:g} degC figure, or above it by at most {res.significance_z:g} standard "
               "uncertainties of the ratio (+-, from the reading noise); surveys bit for bit")
    out += [f"note: {x}" for x in res.above_within_uncertainty]
    if res.passed:
        worst = _worst_ratio(res)
        out.append("verdict: PASS" + (f": worst ratio with the terms {worst}, target {res.target_ratio:g}x" if worst
                                      else ""))
    else:
        out.append("verdict: FAIL: " + "; ".join(res.reasons))
    return "\n".join(out)


def _worst_ratio(res) -> str:
    """`1.08 +- 0.05 (azimuth, -5 degC)`: the largest ratio with the terms
    away from the reference set point, the figure a PASS rests on."""
    best = None
    for s in res.setpoints:
        if s["setpoint_c"] == res.reference_c:
            continue
        for q, name in (("azi", "azimuth"), ("inc", "inclination")):
            r, u = s.get(f"{q}_ratio_with"), s.get(f"{q}_ratio_with_u")
            if r is not None and (best is None or r > best[0]):
                best = (r, u, name, s["setpoint_c"])
    if best is None:
        return ""
    r, u, name, sp = best
    return f"{r:.2f}" + (f" +- {u:.2f}" if u is not None else "") + f" ({name}, {sp:g} degC)"


__all__ = ["TempAcceptResult", "accept_temperatures", "check_takings", "near_vertical", "parse_setpoints",
           "pooled_stats", "render", "taking_plan", "GRIDS"]
