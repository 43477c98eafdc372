"""`inclino accept`: the papers' check grids on the probe, before and after
calibration, printed in the papers' layout.

    inclino accept --port P [--cal CAL.json] [--bench HOST:PORT] [--grid li2021|ren2014]

Grids (turntable poses in our conventions, docs/conventions.md):

* li2021 -- Li 2021 Table 4/5: inclinations 2, 5, 10, 20, 30 ... 90 deg,
  azimuths 0-300 deg every 60 deg (66 positions), toolface 0.
* ren2014 -- Ren 2014 Table 1/2: tilts +-3, +-15, +-30, +-60 deg, azimuths
  0-315 deg every 45 deg (64 positions), toolface 0.  Ren's turntable tilts
  the probe either way; a tilt of -t at azimuth A is the same orientation as
  our pose (I = t, A + 180, T + 180) (C(-I, A, T) = C(I, A + 180, T + 180)),
  which is what the table is set to; the readings are mapped back to Ren's
  signed tilt (-I) and azimuth (A - 180) for the table.
* --inclinations / --azimuths / --toolfaces replace the grid's lists (for
  ren2014 the inclinations are signed tilts).  A grid the turntable cannot
  reach (inclination outside 0-180 deg, a tilt beyond +-180) is refused
  before the port is opened (exit 2).

Before and after: at every position the stability check of `inclino
acquire` takes --reads readings (SURVEY_RAW: the probe's survey and the raw
counts of the same acquisition).  "after" is the probe's own survey;
"before" is the same raw counts through the before calibration in the
firmware's C (inclino.engines.firmware, bit for bit what the probe computes with it),
so both columns see the same readings.  The before calibration is the
probe's calibration as found when --cal is given (downloaded first, with
read-back and activation, as `inclino download`), the identity calibration
otherwise (--before identity|as-found to choose).  Every survey is also
checked against the prediction from the calibration stored in the probe
(bit for bit).  A cell is the mean error of the readings at that position.

Layouts.  Li 2021: Table 4 (inclination error per inclination: the mean over
the azimuths; RMS and max over all positions) and Table 5 (azimuth error per
inclination and azimuth, RMS per row).  Ren 2014: Table 1 (per tilt, the
reading with the largest tilt deviation over the azimuths) and Table 2 (per
azimuth, the largest azimuth deviation over the tilts), as Ren recorded
them.  Azimuth is undefined where the probe flags near-vertical (I < 0.5
deg); such positions count for inclination only.

Verdict (exit 1 when it fails): after calibration azimuth RMS <= --max-azi-rms
(default 0.5 deg), inclination RMS <= --max-inc-rms (default 0.1 deg), and
every survey equal to the stored calibration's prediction.

--circles adds Li 2021's horizontal-circle check (Fig. 2): body X, Y and Z
up in turn, turned about the vertical every 30 deg.  --plot DIR writes the
error maps (errors_<grid>.png) and, with --circles, circles.png
(inclino.procedures.plots); -o FILE keeps everything as JSON for `inclino plot`.
"""
from __future__ import annotations

import contextlib
import math
import sys
import time
from dataclasses import dataclass

import numpy as np

from inclino.procedures.accept_result import AcceptResult  # noqa: F401 (the result type lives where plots can import it)
from inclino.procedures.poses import Step, wrap_deg
from inclino.procedures.readings import Tolerance, mean_row, read_stable
from inclino.errors import DataError, InclinoError
from inclino.engines.golden import F_NEAR_VERTICAL as NEAR_VERTICAL  # the firmware's ATT_F_NEAR_VERTICAL

GRIDS = ("li2021", "ren2014")
LI_INC = (2.0, 5.0, 10.0, 20.0, 30.0, 40.0, 50.0, 60.0, 70.0, 80.0, 90.0)
LI_AZI = (0.0, 60.0, 120.0, 180.0, 240.0, 300.0)
REN_TILT = (3.0, 15.0, 30.0, 60.0, -3.0, -15.0, -30.0, -60.0)
REN_AZI = (0.0, 45.0, 90.0, 135.0, 180.0, 225.0, 270.0, 315.0)
CIRCLE_STEP_DEG = 30.0
DEFAULT_MAX_AZI_RMS = 0.5
DEFAULT_MAX_INC_RMS = 0.1


@dataclass
class GridPoint:
    set_inc: float  # li2021: inclination; ren2014: signed tilt
    set_azi: float
    tf: float
    pose: tuple  # the turntable's (I, A, T)


def grid_points(grid: str, inclinations=None, azimuths=None, toolfaces=(0.0,)) -> list[GridPoint]:
    if grid not in GRIDS:
        raise DataError(f"unknown grid {grid!r} (one of {', '.join(GRIDS)})")
    incs = tuple(inclinations) if inclinations is not None else (LI_INC if grid == "li2021" else REN_TILT)
    azis = tuple(azimuths) if azimuths is not None else (LI_AZI if grid == "li2021" else REN_AZI)
    tfs = tuple(toolfaces)
    if not incs or not azis or not tfs:
        raise DataError("the grid is empty")
    for v in incs + azis + tfs:
        if not math.isfinite(v):
            raise DataError("the grid has a value that is not a finite number")
    pts = []
    for i in incs:
        if grid == "li2021" and not 0.0 <= i <= 180.0:
            raise DataError(f"the turntable cannot reach inclination {i:g} deg (0-180)")
        if grid == "ren2014" and not -180.0 <= i <= 180.0:
            raise DataError(f"the turntable cannot reach tilt {i:g} deg (-180 to 180)")
        for a in azis:
            for t in tfs:
                if i >= 0:
                    pose = (float(i), wrap_deg(a), wrap_deg(t))
                else:
                    pose = (float(-i), wrap_deg(a + 180.0), wrap_deg(t + 180.0))
                pts.append(GridPoint(float(i), float(a), float(t), pose))
    if all(abs(p.pose[0]) < 0.5 or abs(p.pose[0]) > 179.5 for p in pts):
        raise DataError("every position of the grid is within 0.5 deg of vertical, where the probe's azimuth "
                        "is undefined: nothing to check the azimuth on")
    return pts


def circle_steps() -> list[Step]:
    """Li 2021 Fig. 2: X up (I 90, T 0), Y up (I 90, T 270), Z up (I 180),
    each turned about the vertical every 30 deg."""
    a = np.arange(0.0, 360.0, CIRCLE_STEP_DEG)
    n = len(a)
    steps = [Step(90.0, float(x), 0.0, f"circle X up {j + 1}/{n}") for j, x in enumerate(a)]
    steps += [Step(90.0, float(x), 270.0, f"circle Y up {j + 1}/{n}") for j, x in enumerate(a)]
    steps += [Step(180.0, 0.0, float(x), f"circle Z up {j + 1}/{n}") for j, x in enumerate(a)]
    return steps


def _stats(ei, ea) -> dict:
    ea = ea[np.isfinite(ea)]
    return {"azi_rms_deg": float(np.sqrt(np.mean(ea ** 2))) if ea.size else None,
            "azi_max_deg": float(np.abs(ea).max()) if ea.size else None,
            "inc_rms_deg": float(np.sqrt(np.mean(ei ** 2))), "inc_max_deg": float(np.abs(ei).max()),
            "azi_points": int(ea.size), "inc_points": int(ei.size)}


def _cal_dict(fc) -> dict:
    from inclino.formats.calfile import Calibration

    c = Calibration.from_fixed(fc)
    return {"acc_m": c.acc_m, "acc_b": c.acc_b, "mag_m": c.mag_m, "mag_b": c.mag_b}


def stored_calibration(link, ident=None):
    """(FixedCal, description) of the calibration the probe runs now."""
    from inclino.formats.calimage import CalImage
    from inclino.engines.firmware import FixedCal
    from inclino.errors import CalibrationError
    from inclino.link.serial_link import ProbeError

    ident = ident or link.identify()
    if ident.cal_slot == 0xFF:
        return FixedCal.identity(), "identity (no calibration active)"
    _slot, _valid, seq, stored = link.cal_read(ident.cal_slot)
    try:
        img = CalImage.unpack(stored)
    except CalibrationError as e:
        raise ProbeError(f"the probe's active calibration slot cannot be read back: {e}")
    slot = {0: "A", 1: "B"}.get(ident.cal_slot, str(ident.cal_slot))
    return img.cal, f"{img.method} (slot {slot}, sequence {seq})"


def _measure(rec_units, flags, set_pt: GridPoint, decl: float) -> dict:
    """Errors of one survey in the grid's layout."""
    I, A = rec_units
    if set_pt.set_inc < 0:  # Ren's negative tilt: signed tilt -I, azimuth A - 180
        inc_l, azi_l = -I, A - 180.0
    else:
        inc_l, azi_l = I, A
    inc_err = inc_l - set_pt.set_inc
    azi_err = None
    if not flags & NEAR_VERTICAL:
        azi_err = float((azi_l - (set_pt.set_azi - decl) + 180.0) % 360.0 - 180.0)
    return {"inc_err": float(inc_err), "azi_err": azi_err}



@contextlib.contextmanager
def _saying_downloaded(download: dict | None):
    """A Ctrl-C or an error after accept downloaded --cal: the line says the
    file's calibration is now the probe's (an accept cut short leaves it
    active, not the one it found)."""
    if not download:
        yield
        return
    note = (f"the file's calibration stays active on the probe (downloaded to slot {download['slot']}, "
            f"sequence {download['sequence']})")
    try:
        yield
    except KeyboardInterrupt as e:
        raise KeyboardInterrupt("; ".join(x for x in (str(e), note) if x)) from None
    except InclinoError as e:
        e.args = (f"{e}; {note}",)
        raise

def accept(link, table, grid: str = "li2021", cal=None, before: str = "auto", inclinations=None,
           azimuths=None, toolfaces=(0.0,), tol: Tolerance | None = None, max_reads: int = 30,
           circles: bool = False, declination: float | None = None, limits: dict | None = None,
           quiet: bool = False, average: int | None = None) -> AcceptResult:
    """Run the grid (and the circles) on `table` (a turntable:
    turntable.ManualTurntable or turntable_emulated.EmulatedTurntable).  cal: a Calibration to download first."""
    from inclino.link import operations as calops
    from inclino.engines import firmware as core
    from inclino.procedures.readings import progress_bar, set_average
    from inclino.engines.firmware import FixedCal

    tol = tol or Tolerance()
    tol.check()
    pts = grid_points(grid, inclinations, azimuths, toolfaces)
    if before not in ("auto", "identity", "as-found"):
        raise DataError("--before is identity or as-found")
    t0 = time.monotonic()
    set_average(link, average)
    ident = link.identify()
    found, found_desc = stored_calibration(link, ident)
    world = table.world()
    decl = float(declination if declination is not None else world.get("declination_deg", 0.0))
    res = AcceptResult(grid, ident.serial, "", "", decl, world=world,
                       limits=limits or {"max_azi_rms_deg": DEFAULT_MAX_AZI_RMS,
                                         "max_inc_rms_deg": DEFAULT_MAX_INC_RMS})
    if cal is not None:
        d = calops.download(link, cal)
        res.download = {"slot": d.slot, "sequence": d.sequence, "image_crc": f"{d.image_crc:04X}"}
    with _saying_downloaded(res.download):
        after_fc, after_desc = stored_calibration(link)
        if before == "identity" or (before == "auto" and cal is None):
            before_fc, res.before = FixedCal.identity(), "identity"
        else:
            before_fc, res.before = found, f"as found: {found_desc}"
        res.after = (f"{cal.method} from the file, downloaded: {after_desc}" if cal is not None
                     else f"as found: {after_desc}")
        res.before_cal, res.after_cal = _cal_dict(before_fc), _cal_dict(after_fc)

        steps = [Step(*p.pose, f"{grid} grid: {'tilt' if grid == 'ren2014' else 'inclination'} {p.set_inc:g}, "
                      f"azimuth {p.set_azi:g}" + (f", toolface {p.tf:g}" if len(toolfaces) > 1 or p.tf else ""))
                 for p in pts]
        csteps = circle_steps() if circles else []
        bar = progress_bar(len(steps) + len(csteps), f"accept {grid}", quiet)
        if getattr(table, "default_say", False):
            table.say = lambda m: bar.write(m, file=sys.stderr)
        keys = ("inc", "azi", "gtf", "mtf", "gt", "bt", "dip", "flags")
        try:
            for i, (p, st) in enumerate(zip(pts, steps), start=1):
                table.move(st, i, len(steps) + len(csteps))
                win = read_stable(link, tol, max_reads if table.unattended else None)
                eb, ea = [], []
                for r in win:
                    # the probe's Q6 means (the reading holds them / 64, exactly)
                    raw_a, raw_m = [round(v * 64) for v in r.acc], [round(v * 64) for v in r.mag]
                    b = core.survey_one(raw_a, raw_m, before_fc)
                    want = core.survey_one(raw_a, raw_m, after_fc)
                    got = {k: getattr(r.record, k) for k in keys}
                    res.surveys_checked += 1
                    bad = [k for k in keys if int(want[k]) != int(got[k])]
                    if bad:
                        res.survey_mismatches.append(f"{st.label}: {', '.join(f'{k} probe {got[k]} predicted {want[k]}' for k in bad)}")
                    eb.append(_measure((b["inc"] / 65536.0, b["azi"] / 65536.0), int(b["flags"]), p, decl))
                    ea.append(_measure((r.survey["inc_deg"], r.survey["azi_deg"]), int(r.survey["flags"]), p, decl))
                res.points.append({"set_inc": p.set_inc, "set_azi": p.set_azi, "tf": p.tf, "pose": list(p.pose),
                                   "before": _mean_err(eb), "after": _mean_err(ea), "reads": len(win),
                                   "temp_c": mean_row(win).get("temp_c")})
                bar.update(1)
            for i, st in enumerate(csteps, start=len(steps) + 1):
                table.move(st, i, len(steps) + len(csteps))
                win = read_stable(link, tol, max_reads if table.unattended else None)
                res.circles.append({**mean_row(win), "inc_deg": st.inc, "azi_deg": st.azi, "tf_deg": st.tf})
                bar.update(1)
        finally:
            bar.close()
        for which in ("before", "after"):
            _, _, ei, ea = res.errors(which)
            res.stats[which] = _stats(ei, ea)
        a = res.stats["after"]
        lim = res.limits
        if a["azi_rms_deg"] is not None and a["azi_rms_deg"] > lim["max_azi_rms_deg"]:
            res.reasons.append(f"azimuth RMS {a['azi_rms_deg']:.3f} deg exceeds {lim['max_azi_rms_deg']:g}")
        if a["inc_rms_deg"] > lim["max_inc_rms_deg"]:
            res.reasons.append(f"inclination RMS {a['inc_rms_deg']:.3f} deg exceeds {lim['max_inc_rms_deg']:g}")
        if res.survey_mismatches:
            res.reasons.append(f"{len(res.survey_mismatches)} of {res.surveys_checked} surveys differ from the stored "
                               "calibration's prediction")
        res.passed = not res.reasons
    res.elapsed_s = time.monotonic() - t0
    return res


def _mean_err(errs: list[dict]) -> dict:
    inc = float(np.mean([e["inc_err"] for e in errs]))
    az = [e["azi_err"] for e in errs if e["azi_err"] is not None]
    return {"inc_err": inc, "azi_err": float(np.mean(az)) if len(az) == len(errs) else None}


# ---------------------------------------------------------------- layout
def _f(v, w=7, p=2) -> str:
    return f"{'-':>{w}}" if v is None or (isinstance(v, float) and not math.isfinite(v)) else f"{v:{w}.{p}f}"


def _rms(x) -> float | None:
    x = np.asarray([v for v in x if v is not None and math.isfinite(v)], float)
    return float(np.sqrt(np.mean(x ** 2))) if x.size else None


def _worst(x) -> float | None:
    x = [v for v in x if v is not None and math.isfinite(v)]
    return max(x, key=abs) if x else None


def render(res: AcceptResult) -> str:
    out = [f"Acceptance on the {res.grid} grid, probe {res.probe_serial}: {len(res.points)} positions"
           + (f", declination {res.declination_deg:g} deg" if res.declination_deg else "")]
    out.append(f"  before = {res.before}")
    out.append(f"  after  = {res.after}")
    if res.download:
        out.append(f"  downloaded to slot {res.download['slot']}, sequence {res.download['sequence']}")
    out.append("")
    out += _render_li(res) if res.grid == "li2021" else _render_ren(res)
    out.append("")
    b, a = res.stats["before"], res.stats["after"]

    ratio = change
    out.append(f"azimuth     RMS {_f(b['azi_rms_deg'], 0, 3)} -> {_f(a['azi_rms_deg'], 0, 3)} deg "
               f"({ratio(b['azi_rms_deg'], a['azi_rms_deg'])}), max {_f(b['azi_max_deg'], 0, 3)} -> "
               f"{_f(a['azi_max_deg'], 0, 3)} deg over {a['azi_points']} positions")
    out.append(f"inclination RMS {_f(b['inc_rms_deg'], 0, 3)} -> {_f(a['inc_rms_deg'], 0, 3)} deg "
               f"({ratio(b['inc_rms_deg'], a['inc_rms_deg'])}), max {_f(b['inc_max_deg'], 0, 3)} -> "
               f"{_f(a['inc_max_deg'], 0, 3)} deg")
    out.append(f"the probe's surveys against its stored calibration: {res.surveys_checked - len(res.survey_mismatches)}"
               f" of {res.surveys_checked} equal bit for bit")
    if res.circles:
        out.append(f"horizontal circles (Li 2021 Fig. 2): {len(res.circles)} readings, X/Y/Z up")
    lim = res.limits
    if res.passed:
        out.append(f"verdict: PASS: after, azimuth RMS {a['azi_rms_deg']:.3f} deg <= {lim['max_azi_rms_deg']:g}, "
                   f"inclination RMS {a['inc_rms_deg']:.3f} deg <= {lim['max_inc_rms_deg']:g}, "
                   f"{res.surveys_checked} of {res.surveys_checked} surveys bit for bit")
    else:
        out.append("verdict: FAIL: " + "; ".join(res.reasons))
    return "\n".join(out)


def change(before, after) -> str:
    """How an error changed, worded the right way round: `4.2x smaller`,
    `1.6x larger`, `about the same` (within 5 %)."""
    if before is None or after is None or not (before == before and after == after) or before < 0 or after < 0:
        return "-"
    if after == 0 or before == 0:
        return "about the same" if before == after else ("down to 0" if after == 0 else "up from 0")
    r = before / after
    if 1 / 1.05 <= r <= 1.05:
        return "about the same"
    return f"{r:.1f}x smaller" if r > 1 else f"{1 / r:.1f}x larger"


def _cells(res, key_inc, key_azi, which, what):
    """{(set_inc, set_azi): [errors over toolfaces]}"""
    d: dict = {}
    for p in res.points:
        d.setdefault((p["set_inc"], p["set_azi"]), []).append(p[which][what])
    return d


def _render_li(res) -> list[str]:
    incs = sorted({p["set_inc"] for p in res.points})
    azis = sorted({p["set_azi"] for p in res.points})
    multi_tf = len({p["tf"] for p in res.points}) > 1
    out = ["Li 2021 Table 4 layout -- inclination error (deg), mean over the azimuths at each inclination"]
    out.append(f"{'state':8s}" + "".join(f"{i:>7g}" for i in incs) + f"{'RMS':>7}{'max':>7}")
    for which in ("before", "after"):
        c = _cells(res, None, None, which, "inc_err")
        row = [float(np.mean([v for (i, _a), vs in c.items() if i == inc for v in vs])) for inc in incs]
        s = res.stats[which]
        out.append(f"{which:8s}" + "".join(_f(v) for v in row) + _f(s["inc_rms_deg"]) + _f(s["inc_max_deg"]))
    out.append("")
    out.append("Li 2021 Table 5 layout -- azimuth error (deg) by inclination and azimuth, RMS per row"
               + (" (cells: the largest over the toolfaces)" if multi_tf else ""))
    out.append(f"{'incl':>5} {'state':7s}" + "".join(f"{a:>7g}" for a in azis) + f"{'RMS':>7}")
    cb = _cells(res, None, None, "before", "azi_err")
    ca = _cells(res, None, None, "after", "azi_err")
    for inc in incs:
        for which, c in (("before", cb), ("after", ca)):
            vals = [_worst(c.get((inc, a), [])) for a in azis]
            allv = [v for a in azis for v in c.get((inc, a), [])]
            out.append(f"{(f'{inc:g}' if which == 'before' else ''):>5} {which:7s}" + "".join(_f(v) for v in vals)
                       + _f(_rms(allv)))
    return out


def _render_ren(res) -> list[str]:
    tilts = []
    for p in res.points:
        if p["set_inc"] not in tilts:
            tilts.append(p["set_inc"])
    azis = sorted({p["set_azi"] for p in res.points})
    out = ["Ren 2014 Table 1 layout -- tilt (deg): per tilt, the reading with the largest deviation over the azimuths",
           f"{'standard':>9} {'dev0':>8} {'v_err0':>8} {'dev':>8} {'v_err':>8}"]
    for t in tilts:
        eb = _worst([p["before"]["inc_err"] for p in res.points if p["set_inc"] == t])
        ea = _worst([p["after"]["inc_err"] for p in res.points if p["set_inc"] == t])
        out.append(f"{t:9g} {t + eb:8.2f} {eb:8.2f} {t + ea:8.2f} {ea:8.2f}")
    out.append("")
    out.append("Ren 2014 Table 2 layout -- azimuth (deg): per azimuth, the reading with the largest deviation over "
               "the tilts")
    out.append(f"{'standard':>9} {'daz0':>8} {'z_err0':>8} {'daz':>8} {'z_err':>8}")
    for a in azis:
        eb = _worst([p["before"]["azi_err"] for p in res.points if p["set_azi"] == a])
        ea = _worst([p["after"]["azi_err"] for p in res.points if p["set_azi"] == a])

        def m(e):
            return f"{'-':>8}" if e is None else f"{(a + e) % 360.0:8.2f}"
        out.append(f"{a:9g} {m(eb)} {_f(eb, 8)} {m(ea)} {_f(ea, 8)}")
    return out


# ---------------------------------------------------------------- CLI
