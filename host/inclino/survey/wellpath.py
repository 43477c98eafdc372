"""Survey listing -> well path: azimuth references, minimum curvature,
station QC, position uncertainty.

Input: a survey listing as `inclino survey` writes it (CSV, JSON lines or
LAS) plus measured depth -- at least md_m, inc_deg and azi_deg (magnetic
azimuth; azi_mag_deg is read as well, so a trajectory listing reads back).
gt_g, bt_nT, dip_deg, flags and qc are used for QC when present.

The trajectory is welleng's minimum curvature (welleng.survey.Survey; the
first station at the origin, north/east/TVD in metres from it).  Dogleg
severity is the dogleg between a station and the one above it per 30 m of
measured depth, listed at the lower station (0 at the first).

Azimuths (docs/conventions.md section 8): A_true = A_mag + declination,
A_grid = A_true - convergence.  Grid easting/northing = the wellhead's
projected coordinates + the scale factor x the local offsets turned into the
grid frame.
"""
from __future__ import annotations

import csv
import io
import json
import math
from dataclasses import asdict, dataclass, field

import numpy as np

from inclino.errors import DataError
from inclino.survey.geomag import ReferenceField
from inclino.formats.jsonout import dumps

HOST_QC = (("G", "gt_g", "gravity_g"), ("B", "bt_nT", "field_nT"), ("dip", "dip_deg", "dip_deg"))
# what a survey log's header says about the run, carried into the trajectory's outputs
SURVEY_META = ("run", "file", "start_utc", "product", "probe_serial", "firmware", "calibration_slot",
               "calibration_sequence", "calibration_crc")
FT = 0.3048


@dataclass
class Survey:
    md_m: np.ndarray
    inc_deg: np.ndarray
    azi_mag_deg: np.ndarray
    extra: dict = field(default_factory=dict)  # gt_g, bt_nT, dip_deg, flags, qc: arrays (NaN when absent)
    meta: dict = field(default_factory=dict)

    def __len__(self):
        return len(self.md_m)


def _num(v, what, where):
    try:
        x = float(v)
    except (TypeError, ValueError):
        raise DataError(f"{where}: {what} {v!r} is not a number")
    if not math.isfinite(x):
        raise DataError(f"{where}: {what} is not finite")
    return x


def _where(path, i, md=None):
    """'FILE: row N (MD x m)': the place of a station in an input file."""
    return f"{path}: row {i + 1}" + (f" (MD {md:g} m)" if md is not None and math.isfinite(md) else "")


def run_direction(md, path: str = "survey") -> str:
    """'in-run' (measured depth increasing down the file), 'out-run'
    (decreasing: the probe pulled out of the hole) or 'station' (one depth);
    DataError naming the row and depth where a file turns."""
    d = np.diff(np.asarray(md, float))
    up, down = np.flatnonzero(d > 0), np.flatnonzero(d < 0)
    if len(up) and len(down):
        first = min(up[0], down[0])
        turn = int(max(up[0], down[0]))  # the first step against the file's direction
        what = "increases" if first == down[0] else "decreases"
        raise DataError(f"{_where(path, turn + 1, float(md[turn + 1]))}: measured depth {what} against the run's "
                        f"direction (from {md[turn]:g} m): a file is an in-run (depth increasing) or an out-run "
                        "(decreasing), not both; split it")
    return "out-run" if len(down) else "in-run" if len(up) else "station"


def _rows_to_survey(rows: list[dict], path: str, meta: dict) -> Survey:
    if not rows:
        raise DataError(f"{path}: no survey stations")
    keys = set().union(*(r.keys() for r in rows))
    azk = "azi_deg" if "azi_deg" in keys else "azi_mag_deg" if "azi_mag_deg" in keys else None
    mdk = "md_m" if "md_m" in keys else None
    missing = [k for k, v in (("md_m", mdk), ("inc_deg", "inc_deg" if "inc_deg" in keys else None),
                              ("azi_deg", azk)) if v is None]
    if missing:
        raise DataError(f"{path}: missing column {', '.join(missing)} (a survey listing needs md_m, inc_deg, azi_deg)")
    md, inc, azi = [], [], []
    extra = {k: [] for k in ("gt_g", "bt_nT", "dip_deg", "flags", "qc", "utc_s")}
    for i, r in enumerate(rows):
        m = _num(r.get(mdk), "md_m", _where(path, i))
        where = _where(path, i, m)
        md.append(m)
        inc.append(_num(r.get("inc_deg"), "inc_deg", where))
        if not 0.0 <= inc[-1] <= 180.0:
            raise DataError(f"{where}: inclination {inc[-1]:g} deg is outside 0-180")
        azi.append(_num(r.get(azk), azk, where))
        for k in extra:
            v = r.get(k)
            try:
                x = float(v)
            except (TypeError, ValueError):
                if k in ("qc", "flags"):  # a trajectory listing's qc column is text
                    x = float("nan")
                elif v in (None, ""):
                    x = float("nan")
                else:
                    raise DataError(f"{where}: {k} {v!r} is not a number")
            extra[k].append(x)
    md, inc, azi = np.array(md), np.array(inc), np.array(azi)
    meta = {**meta, "run": run_direction(md, path), "file": path}
    order = np.argsort(md, kind="stable")  # an out-run reads bottom up: the path is computed top down
    ex = {k: np.array(v)[order] for k, v in extra.items()}
    utc = ex.pop("utc_s")
    from inclino.formats.survey_log import parse_utc

    if np.any(np.isfinite(utc)) and meta.get("start_utc"):
        ex["utc"] = parse_utc(meta["start_utc"], path) + utc  # POSIX seconds, UTC
    elif all(isinstance(r.get("utc"), str) for r in rows):  # JSON lines: each reading's time in ISO 8601
        ex["utc"] = np.array([parse_utc(r["utc"], _where(path, i)) for i, r in enumerate(rows)])[order]
    return _merge_repeats(Survey(md[order], inc[order], np.mod(azi[order], 360.0), ex, meta))


def _merge_repeats(sv: Survey) -> Survey:
    """Repeated surveys at one depth (`inclino survey --count N --md M`) as one
    station: inclination and the field values averaged, azimuth the mean
    direction, flags and QC bits or-ed."""
    md, first = np.unique(sv.md_m, return_index=True)
    if len(md) == len(sv.md_m):
        return sv
    grp = np.searchsorted(md, sv.md_m)
    n = len(md)
    inc = np.bincount(grp, sv.inc_deg, n) / np.bincount(grp, None, n)
    a = np.radians(sv.azi_mag_deg)
    azi = np.degrees(np.arctan2(np.bincount(grp, np.sin(a), n), np.bincount(grp, np.cos(a), n))) % 360.0
    extra = {}
    for k, v in sv.extra.items():
        out = np.full(n, np.nan)
        for g in range(n):
            x = v[grp == g]
            x = x[np.isfinite(x)]
            if len(x):
                out[g] = float(np.bitwise_or.reduce(x.astype(np.int64))) if k in ("flags", "qc") else float(x.mean())
        extra[k] = out
    return Survey(md, inc, azi, extra, sv.meta)


def concat(surveys: list) -> Survey:
    """Several listings (one file a station, or runs in pieces) as one survey,
    sorted by measured depth; repeated depths merged."""
    if len(surveys) == 1:
        return surveys[0]
    md = np.concatenate([s.md_m for s in surveys])
    order = np.argsort(md, kind="stable")
    keys = set().union(*(s.extra.keys() for s in surveys))
    extra = {k: np.concatenate([s.extra.get(k, np.full(len(s), np.nan)) for s in surveys])[order] for k in keys}
    meta = {}
    for s in surveys:
        meta.update({k: v for k, v in s.meta.items() if k not in ("run", "file")})
    runs = sorted({s.meta.get("run", "") for s in surveys} - {"", "station"})
    meta["run"] = runs[0] if len(runs) == 1 else "in-run and out-run" if runs else "stations"
    meta["file"] = ", ".join(s.meta.get("file", "?") for s in surveys)
    return _merge_repeats(Survey(md[order], np.concatenate([s.inc_deg for s in surveys])[order],
                                 np.concatenate([s.azi_mag_deg for s in surveys])[order], extra, meta))


def _read_csv(text: str, path: str) -> Survey:
    rows, meta = _csv_rows(text, path)
    return _rows_to_survey(rows, path, meta)


def _csv_rows(text: str, path: str):
    meta, lines = {}, []
    for line in text.splitlines():
        s = line.strip()
        if s.startswith("#"):
            if "=" in s:
                k, v = s[1:].split("=", 1)
                meta[k.strip()] = v.strip()
            continue
        if s:
            lines.append(line)
    if not lines:
        raise DataError(f"{path}: no header row")
    rdr = csv.reader(lines)
    header = [h.strip() for h in next(rdr)]
    rows = []
    for n, rec in enumerate(rdr, start=2):
        rec = [c.strip() for c in rec]
        if rec == header:  # several `inclino survey --csv` outputs appended
            continue
        if len(rec) != len(header):
            raise DataError(f"{path}: row {n} has {len(rec)} fields, the header {len(header)}")
        rows.append(dict(zip(header, rec)))
    return rows, meta


def _read_json(text: str, path: str) -> Survey:
    rows = _json_rows(text, path)
    probe = rows[0].get("probe") if rows else None
    return _rows_to_survey(rows, path, {k: str(v) for k, v in probe.items()} if isinstance(probe, dict) else {})


def _json_rows(text: str, path: str) -> list:
    s = text.strip()
    try:
        if s.startswith("["):
            rows = json.loads(s)
        else:
            rows = [json.loads(line) for line in s.splitlines() if line.strip()]
    except json.JSONDecodeError as e:
        raise DataError(f"{path}: not JSON ({e.msg} at line {e.lineno})")
    if not isinstance(rows, list) or not all(isinstance(r, dict) for r in rows):
        raise DataError(f"{path}: each station must be a JSON object")
    return rows


LAS_CURVES = {"INC": "inc_deg", "AZI": "azi_deg", "AZIM": "azi_deg", "GTOT": "gt_g", "BTOT": "bt_nT",
              "DIP": "dip_deg", "FLAGS": "flags", "QC": "qc"}


LAS_META = {"PSERIAL": "probe_serial", "PRODUCT": "product", "FWVER": "firmware", "CALSLOT": "calibration_slot",
            "CALSEQ": "calibration_sequence", "CALCRC": "calibration_crc", "TSTART": "start_utc"}


def _read_las(text: str, path: str) -> Survey:
    from inclino.formats import las as lasfmt

    las = lasfmt.read(text, path)
    curves = {c.mnemonic.upper(): c for c in las.curves}
    md = None
    for m in ("DEPT", "DEPTH", "MD"):
        if m in curves:
            c = curves[m]
            md = np.asarray(c.data, float) * lasfmt.depth_factor(c.unit, f"{path}: curve {c.mnemonic}")
            break
    if md is None:
        raise DataError(f"{path}: no measured-depth curve (DEPT, DEPTH or MD)")
    n = len(md)
    rows = [{"md_m": md[i]} for i in range(n)]
    for m, key in {**LAS_CURVES, "TIME": "utc_s"}.items():
        if m in curves:
            d = np.asarray(curves[m].data, float)
            for i in range(n):
                if not math.isnan(d[i]):
                    rows[i].setdefault(key, d[i])
    meta = {}
    for p in las.params:
        if p.mnemonic.upper() in LAS_META and str(p.value).strip():
            meta[LAS_META[p.mnemonic.upper()]] = str(p.value).strip()
    return _rows_to_survey(rows, path, meta)


def _text(path: str) -> str:
    try:
        with open(path, encoding="utf-8") as f:
            return f.read()
    except OSError as e:
        raise DataError(f"cannot read {path}: {e.strerror}")
    except UnicodeDecodeError:
        raise DataError(f"{path}: not a text file")


def read_survey_rows(path: str) -> list[dict]:
    """The rows of a survey listing (CSV or JSON) as they are, numbers parsed
    where a value is one (for a noise run: no measured depth needed)."""
    text = _text(path)
    s = text.lstrip()
    if s.startswith("~"):
        import lasio

        try:
            las = lasio.read(io.StringIO(text))
        except Exception as e:
            raise DataError(f"{path}: not a readable LAS file ({e})")
        cur = {c.mnemonic.upper(): np.asarray(c.data, float) for c in las.curves}
        n = len(las.index)
        return [{key: float(cur[m][i]) for m, key in LAS_CURVES.items() if m in cur} for i in range(n)]
    rows = _json_rows(text, path) if s.startswith(("{", "[")) else _csv_rows(text, path)[0]
    out = []
    for i, r in enumerate(rows):
        d = {}
        for k, v in r.items():
            if k in ("gt_g", "bt_nT", "inc_deg", "azi_deg", "dip_deg"):
                d[k] = _num(v, k, f"{path}: row {i + 1}")
        out.append(d)
    return out


def read_survey(path: str) -> Survey:
    """A survey listing from CSV, JSON (lines or an array) or LAS 2.0,
    told apart by content."""
    text = _text(path)
    s = text.lstrip()
    if s.startswith("~"):
        return _read_las(text, path)
    if s.startswith("{") or s.startswith("["):
        return _read_json(text, path)
    return _read_csv(text, path)


# ------------------------------------------------------------- trajectory

@dataclass
class Trajectory:
    rows: list  # one dict per station (columns of COLUMNS + optional ones)
    columns: list
    reference: dict
    survey: dict | None = None  # the survey's header (probe, calibration, run direction, start time)
    summary: dict = field(default_factory=dict)

    def to_json(self) -> str:
        d = asdict(self)
        d["summary"].pop("parts", None)
        return dumps(d)


def _welleng_survey(md, inc, azi_mag, rf: ReferenceField, error_model=None, fallback=(60.0, 50000.0)):
    from inclino.survey.models import welleng_survey

    return welleng_survey(md, inc, azi_mag, rf, error_model, fallback)


def dogleg_deg(inc1, azi1, inc2, azi2):
    """Dogleg between two attitudes (deg), the angle between the tangents."""
    i1, a1, i2, a2 = (np.radians(x) for x in (inc1, azi1, inc2, azi2))
    c = np.cos(i2 - i1) - np.sin(i1) * np.sin(i2) * (1 - np.cos(a2 - a1))
    return np.degrees(np.arccos(np.clip(c, -1.0, 1.0)))


def ellipse(cov_ne):
    """Horizontal 1-sigma ellipse of a 2x2 north/east covariance:
    (semi-major m, semi-minor m, azimuth of the major axis deg 0-180)."""
    w, v = np.linalg.eigh(cov_ne)
    major = v[:, 1]
    az = math.degrees(math.atan2(major[1], major[0])) % 180.0
    return math.sqrt(max(w[1], 0.0)), math.sqrt(max(w[0], 0.0)), az


def trajectory(sv: Survey, rf: ReferenceField, model=None) -> Trajectory:
    """The well path of a survey: azimuth references, minimum curvature,
    station QC and, with an error model (inclino.survey.models.ErrorModel),
    the position covariance at each station."""
    if not math.isfinite(rf.declination_deg):
        raise DataError("the declination is not known")
    if len(sv) < 2:
        raise DataError("a trajectory needs at least two stations at different measured depths")
    import warnings

    fit = (getattr(model, "probe", None) or getattr(getattr(model, "base", None), "inclino", None))
    fb = (fit.fit.get("dip_deg", 60.0), fit.fit.get("field_nT", 50000.0)) if fit is not None else (60.0, 50000.0)
    with warnings.catch_warnings():
        warnings.simplefilter("ignore")
        try:
            ws = _welleng_survey(sv.md_m, sv.inc_deg, sv.azi_mag_deg, rf, None, fb)
        except (ValueError, AssertionError, ArithmeticError, KeyError, IndexError, np.linalg.LinAlgError) as e:
            raise DataError(f"the survey cannot be computed: {e}")
    prop = model.propagate(sv.md_m, sv.inc_deg, sv.azi_mag_deg, rf, fb) if model is not None else None
    n = len(sv)
    north, east, tvd = np.asarray(ws.n, float) - ws.n[0], np.asarray(ws.e, float) - ws.e[0], \
        np.asarray(ws.tvd, float) - ws.tvd[0]
    azi_true = np.mod(sv.azi_mag_deg + rf.declination_deg, 360.0)
    dls = np.zeros(n)
    if n > 1:
        dls[1:] = dogleg_deg(sv.inc_deg[:-1], azi_true[:-1], sv.inc_deg[1:], azi_true[1:]) / np.diff(sv.md_m) * 30.0
    cols = ["md_m", "inc_deg", "azi_mag_deg", "azi_true_deg"]
    grid = rf.grid_epsg is not None
    if grid:
        cols.append("azi_grid_deg")
    cols += ["tvd_m", "north_m", "east_m"]
    if grid:
        cols += ["northing_m", "easting_m"]
    cols += ["dls_deg_per_30m"]
    g = math.radians(rf.convergence_deg)
    rows = []
    ex = sv.extra
    nq = {"G": 0, "B": 0, "dip": 0, "probe": 0, "near-vertical": 0}
    for i in range(n):
        r = {"md_m": sv.md_m[i], "inc_deg": sv.inc_deg[i], "azi_mag_deg": sv.azi_mag_deg[i],
             "azi_true_deg": azi_true[i], "tvd_m": tvd[i], "north_m": north[i], "east_m": east[i],
             "dls_deg_per_30m": dls[i]}
        if grid:
            r["azi_grid_deg"] = (azi_true[i] - rf.convergence_deg) % 360.0
            k = rf.scale_factor
            r["northing_m"] = rf.northing_m + k * (north[i] * math.cos(g) + east[i] * math.sin(g))
            r["easting_m"] = rf.easting_m + k * (east[i] * math.cos(g) - north[i] * math.sin(g))
        fails, checked = [], []
        for name, key, refkey in HOST_QC:
            v, ref = ex.get(key, [float("nan")] * n)[i], getattr(rf, refkey)
            if math.isfinite(v) and math.isfinite(ref):
                checked.append(name)
                r[f"d{key}"] = v - ref
                if abs(v - ref) > rf.tol[key]:
                    fails.append(name)
                    nq[name] += 1
        fl, pq = ex.get("flags", [float("nan")] * n)[i], ex.get("qc", [float("nan")] * n)[i]
        near_vertical = (math.isfinite(fl) and int(fl) & 1) or sv.inc_deg[i] < 0.5 or sv.inc_deg[i] > 179.5
        if near_vertical:
            nq["near-vertical"] += 1
        if math.isfinite(pq):
            checked.append("probe (G only)" if int(pq) & 0x80 else "probe")
            if int(pq) & 0x7F:
                fails.append("probe")
                nq["probe"] += 1
        what = ",".join(checked) if checked else "nothing: no field values or no reference"
        r["qc_checked"] = what
        r["qc"] = (f"FAIL {','.join(fails)} (checked {what})" if fails else
                   f"PASS {what}" if checked else f"not checked ({what})")
        r["note"] = "near-vertical: azimuth undefined" if near_vertical else ""
        rows.append(r)
    for key in ("gt_g", "bt_nT", "dip_deg"):
        if any(f"d{key}" in r for r in rows):
            cols.append(f"d{key}")
    cols += ["qc", "note"]
    summary = {"stations": n, "qc_fail": sum(r["qc"].startswith("FAIL") for r in rows), "qc_fail_by": nq,
               "qc_checked": sorted({r["qc_checked"] for r in rows}),
               "md_m": [float(sv.md_m[0]), float(sv.md_m[-1])],
               "end": {"tvd_m": float(tvd[-1]), "north_m": float(north[-1]), "east_m": float(east[-1])}}
    if "utc" in ex:
        t0 = float(np.nanmin(ex["utc"]))
        from inclino.formats.survey_log import utc_iso

        summary["start_utc"] = utc_iso(t0)
        for i, r in enumerate(rows):
            r["utc_s"] = float(ex["utc"][i] - t0)
        cols[cols.index("qc"):cols.index("qc")] = ["utc_s"]
    summary["run"] = sv.meta.get("run", "")
    if prop is not None:
        cov = prop.cov_nev
        dia = prop.cov_dia
        for i, r in enumerate(rows):
            c = cov[i]
            a, b, az = ellipse(c[:2, :2])
            s_azi = math.degrees(math.sqrt(max(dia[i, 2, 2], 0)))
            r.update(sigma_inc_deg=math.degrees(math.sqrt(max(dia[i, 1, 1], 0))),
                     sigma_azi_deg=s_azi if (r["note"] == "" and math.isfinite(s_azi) and s_azi < 360) else math.nan,
                     sigma_north_m=math.sqrt(max(c[0, 0], 0)), sigma_east_m=math.sqrt(max(c[1, 1], 0)),
                     sigma_tvd_m=math.sqrt(max(c[2, 2], 0)), ell_major_m=a, ell_minor_m=b, ell_azi_deg=az,
                     cov_nn=c[0, 0], cov_ne=c[0, 1], cov_nv=c[0, 2], cov_ee=c[1, 1], cov_ev=c[1, 2],
                     cov_vv=c[2, 2])
        cols[cols.index("qc"):cols.index("qc")] = ["sigma_inc_deg", "sigma_azi_deg", "sigma_north_m",
                                                   "sigma_east_m", "sigma_tvd_m", "ell_major_m", "ell_minor_m",
                                                   "ell_azi_deg", "cov_nn", "cov_ne", "cov_nv", "cov_ee",
                                                   "cov_ev", "cov_vv"]
        summary["end"].update(ell_major_m=rows[-1]["ell_major_m"], ell_minor_m=rows[-1]["ell_minor_m"],
                              parts={k: dict(zip(("ell_major_m", "ell_minor_m"), ellipse(c[-1][:2, :2])[:2]))
                                     for k, c in prop.parts.items()})
        summary["error_model"] = model.describe()
        summary["parts"] = prop.parts
    meta = {k: v for k, v in sv.meta.items() if k in SURVEY_META}
    return Trajectory([{k: (float(v) if not isinstance(v, str) else v) for k, v in r.items()} for r in rows],
                      cols, rf.header(), {"survey": meta, "start_utc": summary.get("start_utc")}, summary)


def _fmt(v):
    if isinstance(v, str):
        return v
    if v is None or (isinstance(v, float) and not math.isfinite(v)):
        return ""
    return f"{v:.10g}"


def write_csv(tr: Trajectory, path: str) -> None:
    """The trajectory listing: '# key=value' lines (the reference field),
    then a header row and one row per station."""
    buf = io.StringIO()
    for k, v in tr.reference.items():
        buf.write(f"# {k}={v}\n")
    for k, v in _survey_header(tr).items():
        buf.write(f"# {k}={v}\n")
    w = csv.writer(buf, lineterminator="\n")
    w.writerow(tr.columns)
    for r in tr.rows:
        w.writerow([_fmt(r.get(c)) for c in tr.columns])
    _write(path, buf.getvalue())


def _write(path: str, text: str) -> None:
    """Through inclino.formats.safeio: '-' is stdout; atomic, never over a device or
    a symlink's place, the target's mode kept."""
    from inclino.formats import safeio

    safeio.write_output(path, text)


LAS_OUT = (("inc_deg", "INC", "deg", "inclination"), ("azi_mag_deg", "AZIM", "deg", "azimuth, magnetic north"),
           ("azi_true_deg", "AZIT", "deg", "azimuth, true north"),
           ("azi_grid_deg", "AZIG", "deg", "azimuth, grid north"), ("tvd_m", "TVD", "m", "true vertical depth"),
           ("north_m", "NORTH", "m", "north of the first station"), ("east_m", "EAST", "m", "east of the first station"),
           ("northing_m", "NORTHING", "m", "grid northing"), ("easting_m", "EASTING", "m", "grid easting"),
           ("dls_deg_per_30m", "DLS", "deg/30m", "dogleg severity"),
           ("ell_major_m", "ELLMAJ", "m", "1-sigma horizontal ellipse, semi-major"),
           ("ell_minor_m", "ELLMIN", "m", "1-sigma horizontal ellipse, semi-minor"),
           ("ell_azi_deg", "ELLAZI", "deg", "ellipse major-axis azimuth (true)"),
           ("sigma_tvd_m", "SIGTVD", "m", "1-sigma TVD"))


def _survey_header(tr: Trajectory) -> dict:
    """What the trajectory's outputs say about the survey and the error model."""
    d = {}
    sv = (tr.survey or {}).get("survey") or {}
    for k in SURVEY_META:
        if k == "start_utc":
            continue
        if sv.get(k) not in (None, ""):
            d["survey_file" if k == "file" else k] = sv[k]
    if (tr.survey or {}).get("start_utc"):
        d["start_utc"] = tr.survey["start_utc"]
        d["utc_s"] = "seconds since start_utc of each station's reading"
    if tr.summary.get("error_model"):
        d["error_model"] = tr.summary["error_model"]
    return d


def write_las(tr: Trajectory, path: str) -> None:
    """The trajectory as LAS 2.0, indexed by measured depth (DEPT, M), with
    the reference field, the survey's probe and the error model in the
    ~Parameter section."""
    from inclino.formats import las as lasfmt

    md = np.array([r["md_m"] for r in tr.rows])
    curves = [(mnem, unit, descr, np.array([r.get(key, np.nan) for r in tr.rows], float))
              for key, mnem, unit, descr in LAS_OUT if key in tr.columns]
    if "utc_s" in tr.columns:
        curves.append(("TIME", "s", "time of the station's reading since the survey's start (DATE, UTC)",
                       np.array([r.get("utc_s", np.nan) for r in tr.rows], float)))
    pmap = {"declination_deg": ("MAGDEC", "deg", "magnetic declination, east positive"),
            "dip_deg": ("MAGDIP", "deg", "magnetic dip, down positive"), "field_nT": ("MAGFLD", "nT", "total field"),
            "gravity_g": ("GRAV", "g", "reference gravity"), "lat_deg": ("LAT", "deg", "latitude WGS 84"),
            "lon_deg": ("LON", "deg", "longitude WGS 84"), "alt_m": ("ALT", "m", "height above the ellipsoid"),
            "date": ("DATE", "", "survey date"), "ref_source": ("MAGREF", "", "reference-field source"),
            "grid_epsg": ("GRIDEPSG", "", "projected CRS"),
            "convergence_deg": ("GRIDCONV", "deg", "grid convergence: A_grid = A_true - GRIDCONV"),
            "scale_factor": ("GRIDSF", "", "grid point scale factor"),
            "easting_m": ("WHEAST", "m", "wellhead easting"), "northing_m": ("WHNORTH", "m", "wellhead northing")}
    params = [(pmap[k][0], pmap[k][1], v, pmap[k][2]) for k, v in tr.reference.items() if k in pmap]
    smap = {"run": ("RUN", "in-run (depth increasing), out-run (decreasing)"), "product": ("PRODUCT", "probe product"),
            "probe_serial": ("PSERIAL", "probe serial"), "firmware": ("FWVER", "probe firmware version"),
            "calibration_slot": ("CALSLOT", "active calibration slot"),
            "calibration_sequence": ("CALSEQ", "active calibration sequence"),
            "calibration_crc": ("CALCRC", "active calibration image CRC (hex)"),
            "start_utc": ("TSTART", "the survey's first reading, UTC (ISO 8601)"),
            "error_model": ("ERRMODEL", "error model of the ellipses")}
    for k, v in _survey_header(tr).items():
        if k in smap:
            params.append((smap[k][0], "", ("0x" + str(v)) if k == "calibration_crc" else v, smap[k][1]))
    text = lasfmt.render("DEPT", "M", "measured depth", md, curves, params,
                         date=(tr.survey or {}).get("start_utc") or tr.reference.get("date", "") or "",
                         other="Trajectory by inclino (minimum curvature, welleng); first station at the origin.")
    _write(path, text)


def read_trajectory(path: str) -> list[dict]:
    """The rows of a trajectory CSV (inclino trajectory's output)."""
    try:
        with open(path, encoding="utf-8") as f:
            lines = [ln for ln in f if ln.strip() and not ln.lstrip().startswith("#")]
    except OSError as e:
        raise DataError(f"cannot read {path}: {e.strerror}")
    rows = list(csv.DictReader(lines))
    if not rows:
        raise DataError(f"{path}: no stations")
    return rows
