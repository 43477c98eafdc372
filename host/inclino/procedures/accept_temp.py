"""`inclino accept --temperatures -5,25,55 --cal CAL.json`: the acceptance
grid at several chamber set points, with the calibration's temperature
terms and without them (docs/cli.md, docs/calibration.md).

At each set point in turn:

1. the chamber is set (the emulator's control channel `chamber` on a bench,
   the person otherwise; a ramp at --ramp-rate degC/min) and the probe is
   read at the grid's first position every --interval minutes until its own
   temperature has settled (acquire_temp.settled: within --soak-band of the
   set point, changed by at most --soak-tol over --soak-window minutes; a
   bench also waits for its air to reach the set point and gives up after
   --max-soak minutes, exit 4);
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

Per set point: azimuth and inclination RMS and max with and without the
terms, the gain (without / with), and the ratio to the reference set point's
figure (--reference-temp, default 25 degC, which must be one of the set
points) of the same column.  Verdict (exit 1 when it fails): with the terms,
azimuth and inclination RMS at every set point <= --target-ratio (default
1.2) x the reference set point's, and every survey equal to the prediction.
"""
from __future__ import annotations

import json
import math
import sys
import time
from dataclasses import asdict, dataclass, field

import numpy as np

from inclino.procedures.accept import GRIDS, GridPoint, _measure, _stats, grid_points, stored_calibration
from inclino.formats.jsonout import dumps
from inclino.procedures.poses import Step
from inclino.procedures.readings import Tolerance, read_stable
from inclino.procedures.acquire_temp import TEMP_RANGE_C, ThermalPlan, _Chamber, settled
from inclino.errors import DataError

DEFAULT_TARGET_RATIO = 1.2
DEFAULT_REFERENCE_C = 25.0
DEFAULT_TOOLFACES = (0.0, 120.0, 240.0)  # --temperatures without --toolfaces
MAX_SETPOINTS = 20


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
    errs = [_measure((float(i), float(a)), int(f), p, decl) for i, a, f in zip(inc, azi, flags)]
    az = [e["azi_err"] for e in errs if e["azi_err"] is not None]
    return {"inc_err": float(np.mean([e["inc_err"] for e in errs])),
            "azi_err": float(np.mean(az)) if len(az) == len(errs) else None}


def _predict(acc, mag, tq6, stored_fc):
    """The probe's surveys from what it stores: the firmware's C with the
    stored image (its temperature terms when it holds them)."""
    from inclino.engines import firmware as core

    if getattr(stored_fc, "temp", None) is not None:
        return core.survey(acc, mag, stored_fc, temp_q6=tq6)
    return core.survey(acc, mag, stored_fc)


def _errors(points: list, which: str):
    ei = np.array([p[which]["inc_err"] for p in points], float)
    ea = np.array([np.nan if p[which]["azi_err"] is None else p[which]["azi_err"] for p in points], float)
    return ei, ea


def accept_temperatures(link, table, cal, setpoints=(-5.0, 25.0, 55.0), grid: str = "li2021",
                        reference_c: float = DEFAULT_REFERENCE_C, target_ratio: float = DEFAULT_TARGET_RATIO,
                        plan: ThermalPlan | None = None, engine: str = "auto", inclinations=None, azimuths=None,
                        toolfaces=DEFAULT_TOOLFACES, tol: Tolerance | None = None, max_reads: int = 30,
                        declination: float | None = None, download: bool = True, force: bool = False,
                        quiet: bool = False,
                        average: int | None = None, sleep=time.sleep) -> TempAcceptResult:
    """The grid at each set point on `table` (turntable_emulated.EmulatedTurntable
    or turntable.ManualTurntable); cal: the Calibration with temperature terms (CAL.json),
    downloaded first unless download is False."""
    from inclino.link import operations as calops
    from inclino.engines import temperature as temp_engine
    from inclino.procedures.readings import progress_bar, set_average

    tol = tol or Tolerance()
    tol.check()
    sps = tuple(float(t) for t in setpoints)
    parse_setpoints(",".join(repr(t) for t in sps), reference_c)
    if not temp_engine.has_terms(cal):
        raise DataError("the calibration has no temperature terms (fit them: inclino calibrate --method joint "
                        "--temperature on, from a chamber run)")
    if not (math.isfinite(target_ratio) and target_ratio >= 1.0):
        raise DataError("--target-ratio must be a number >= 1")
    plan = plan or ThermalPlan(setpoints=sps)
    plan.setpoints = sps
    plan.check()
    eng = temp_engine.get(engine)
    eng.check(cal)  # the firmware engine: refused when the image cannot hold the terms
    pts = grid_points(grid, inclinations, azimuths, toolfaces)
    t0 = time.monotonic()
    set_average(link, average)
    ident = link.identify()
    world = table.world()
    decl = float(declination if declination is not None else world.get("declination_deg", 0.0))
    res = TempAcceptResult(grid, ident.serial, list(sps), float(reference_c), float(target_ratio), eng.name,
                           eng.terms_in_firmware, "", decl, world=world)
    if download:
        d = calops.download(link, cal, force=force)
        res.download = {"slot": d.slot, "sequence": d.sequence, "image_crc": f"{d.image_crc:04X}"}
    stored_fc, stored_desc = stored_calibration(link)
    res.calibration = (f"{cal.method} with its temperature terms (order {cal.temperature['order']} about "
                       f"{cal.temperature['t_ref_c']:g} degC) from the file; the probe holds {stored_desc}")
    steps = [Step(*p.pose, f"{grid} grid: {'tilt' if grid == 'ren2014' else 'inclination'} {p.set_inc:g}, "
                  f"azimuth {p.set_azi:g}" + (f", toolface {p.tf:g}" if len(toolfaces) > 1 or p.tf else ""))
             for p in pts]
    bar = progress_bar(len(sps) * len(steps), "accept temperatures", quiet)

    def say(m):
        bar.write(m, file=sys.stderr)

    if not table.unattended and getattr(table, "default_say", False):
        table.say = say
    tell = table.say if not table.unattended else (None if quiet else say)
    chamber = _Chamber(table, sleep)
    try:
        for sp in sps:
            soak_min, probe_c = _soak(link, table, chamber, sp, plan, tol, max_reads, steps[0], tell)
            sp_points, temps = [], []
            for i, (p, st) in enumerate(zip(pts, steps), start=1):
                table.move(Step(st.inc, st.azi, st.tf, f"{sp:g} degC: {st.label}"), i, len(steps))
                win = read_stable(link, tol, max_reads if table.unattended else None)
                acc = np.array([[round(v * 64) for v in r.acc] for r in win], np.int64)
                mag = np.array([[round(v * 64) for v in r.mag] for r in win], np.int64)
                tq6 = np.array([r.temp_q6 if r.temp_q6 is not None else
                                int(temp_engine.temp_q6_from_centi(round(r.temp_c * 100.0))) for r in win], np.int64)
                temps += [r.temp_c for r in win]
                cols = {}
                for key, terms in (("with", True), ("without", False)):
                    cols[key] = eng.survey(acc, mag, tq6, cal, terms=terms)
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
                row = {"setpoint_c": sp, "set_inc": p.set_inc, "set_azi": p.set_azi, "tf": p.tf,
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
                ei, ea = _errors(sp_points, key)
                entry[key] = _stats(ei, ea)
            res.setpoints.append(entry)
    finally:
        bar.close()
    _verdict(res)
    res.elapsed_s = time.monotonic() - t0
    return res


def _verdict(res: TempAcceptResult) -> None:
    ref = next(s for s in res.setpoints if s["setpoint_c"] == res.reference_c)
    for s in res.setpoints:
        for q in ("azi", "inc"):
            for key in ("with", "without"):
                v, r0 = s[key][f"{q}_rms_deg"], ref[key][f"{q}_rms_deg"]
                s[f"{q}_ratio_{key}"] = (v / r0) if v is not None and r0 else None
            w, wo = s["with"][f"{q}_rms_deg"], s["without"][f"{q}_rms_deg"]
            s[f"{q}_gain"] = (wo / w) if w and wo is not None else None
        bad = [f"{name} RMS {s['with'][f'{q}_rms_deg']:.4f} deg is {s[f'{q}_ratio_with']:.2f}x the "
               f"{res.reference_c:g} degC figure {ref['with'][f'{q}_rms_deg']:.4f}"
               for q, name in (("azi", "azimuth"), ("inc", "inclination"))
               if s[f"{q}_ratio_with"] is not None and s[f"{q}_ratio_with"] > res.target_ratio]
        s["within_target"] = not bad
        res.reasons += [f"at {s['setpoint_c']:g} degC with the terms: {b} (target {res.target_ratio:g}x)"
                        for b in bad]
    if res.survey_mismatches:
        res.reasons.append(f"{len(res.survey_mismatches)} of {res.surveys_checked} surveys differ from the stored "
                           "calibration's prediction")
    res.passed = not res.reasons


def render(res: TempAcceptResult) -> str:
    def f(v, p=4):
        return "-" if v is None else f"{v:.{p}f}"

    out = [f"Acceptance at {len(res.setpoints_c)} chamber set points on the {res.grid} grid, probe "
           f"{res.probe_serial}: {len(res.points) // max(1, len(res.setpoints_c))} positions each",
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
                   f"azimuth {f(s['azi_ratio_with'], 2)} / {f(s['azi_ratio_without'], 2)}, inclination "
                   f"{f(s['inc_ratio_with'], 2)} / {f(s['inc_ratio_without'], 2)}")
    out.append(f"the probe's surveys against its stored calibration: {res.surveys_checked - len(res.survey_mismatches)}"
               f" of {res.surveys_checked} equal bit for bit; the \"with\" column is the probe's own survey in "
               f"{res.with_equals_probe} of them")
    out.append(f"verdict: {'PASS' if res.passed else 'FAIL'} (with the terms, azimuth and inclination RMS at every "
               f"set point <= {res.target_ratio:g}x the {res.reference_c:g} degC figure; surveys bit for bit)"
               + ("" if res.passed else ": " + "; ".join(res.reasons)))
    return "\n".join(out)


__all__ = ["TempAcceptResult", "accept_temperatures", "parse_setpoints", "render", "GRIDS"]
