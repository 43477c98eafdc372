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
import math
from dataclasses import dataclass, field

import numpy as np

from inclino.errors import DataError
from inclino.survey.geomag import ReferenceField
from inclino.formats.jsonout import dumps

QC_DIFF = ("dgt_g", "dbt_nT", "ddip_deg")
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


# One rule per column of a survey listing (lo, hi), every value finite: a
# measured depth within 100 km (the deepest wells are about 15 km), angles
# as docs/conventions.md gives them, field values a probe can report.
RULES = {"md_m": (-1.0e4, 1.0e5), "inc_deg": (0.0, 180.0), "azi_deg": (-360.0, 720.0),
         "azi_mag_deg": (-360.0, 720.0), "gt_g": (0.0, 4.0), "bt_nT": (0.0, 2.0e5), "dip_deg": (-90.0, 90.0),
         "tf_deg": (-360.0, 720.0), "flags": (0.0, 2.0**32), "qc": (0.0, 2.0**32)}
LABELS = {"inc_deg": ("inclination", " deg"), "md_m": ("md_m", " m")}
MAX_LISTING_BYTES = 256 * 2**20  # a listing of 10^6 stations with every column is about 100 MB


def _check_rules(cols: dict, path: str) -> None:
    """Each column within its rule (RULES); NaN stands for an absent
    optional value.  DataError naming the station (row) and the column."""
    for k, v in cols.items():
        if k not in RULES or v is None:
            continue
        v = np.asarray(v, float)
        lo, hi = RULES[k]
        with np.errstate(invalid="ignore"):
            bad = (v < lo) | (v > hi) | np.isinf(v)
        if k in ("md_m", "inc_deg", "azi_deg", "azi_mag_deg"):
            bad |= np.isnan(v)
        if bad.any():
            i = int(np.argmax(bad))
            span = f"{lo:g}-{hi:g}" if lo >= 0 else f"{lo:g} to {hi:g}"
            md = cols.get("md_m")
            at = _where(path, i, float(md[i]) if md is not None and k != "md_m" else None)
            name, unit = LABELS.get(k, (k, ""))
            raise DataError(f"{at}: {name} {float(v[i]):g}{unit} is outside {span}")


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


EXTRA = ("gt_g", "bt_nT", "dip_deg", "tf_deg", "flags", "qc", "utc_s")
TEXT_OK = ("qc", "flags")  # a trajectory listing's qc column is text: read as absent


def _numbers(vals, key: str, path: str, lines=None, md=None, text_ok: bool = False) -> np.ndarray:
    """A column's values (a list of cells or values, or an array) as floats:
    empty or absent cells NaN; a cell that is not a number a DataError
    naming its row (and the file's line), unless text_ok (then NaN)."""
    if isinstance(vals, np.ndarray) and vals.dtype.kind == "f":
        return vals
    try:
        out = np.array([np.nan if v is None or v == "" else v for v in vals], dtype=float)
    except (TypeError, ValueError, OverflowError):
        out = np.empty(len(vals))
        for i, v in enumerate(vals):
            try:
                out[i] = np.nan if v is None or v == "" else float(v)
            except (TypeError, ValueError, OverflowError):
                if text_ok:
                    out[i] = np.nan
                    continue
                where = _where(path, i, None if md is None else float(md[i]))
                if lines is not None:
                    where = f"{path}:{lines[i]}" + where[len(path):]
                raise DataError(f"{where}: {key} {str(v)[:40]!r} is not a number") from None
    return out


def _rows_to_survey(rows: list[dict], path: str, meta: dict) -> Survey:
    """Stations given as objects (JSON, LAS): their columns."""
    if not rows:
        raise DataError(f"{path}: no survey stations")
    keys = set().union(*(r.keys() for r in rows))
    cols = {k: [r.get(k) for r in rows] for k in ("md_m", "inc_deg", "azi_deg", "azi_mag_deg") + EXTRA if k in keys}
    utc_text = [r.get("utc") for r in rows] if all(isinstance(r.get("utc"), str) for r in rows) else None
    return _cols_to_survey(cols, len(rows), path, meta, utc_text=utc_text)


def _depth_hint(cols, missing: list) -> str:
    """For a listing without md_m: the depth column it has instead, and how
    to give it (a CSV's depth is in metres; LAS files carry their unit)."""
    if "md_m" not in missing:
        return ""
    other = [k for k in cols if str(k).lower().startswith(("md", "depth", "dept"))]
    if not other:
        return ""
    return (f"; it has {', '.join(other)}: give the depth in metres as md_m (feet x 0.3048, US survey feet x "
            "1200/3937), or as a LAS file whose depth curve states its unit (DEPT.FT)")


def _cols_to_survey(cols: dict, n: int, path: str, meta: dict, lines=None, utc_text=None, columns=None) -> Survey:
    """A survey from its columns (lists of cells or float arrays, n
    stations; `lines`: each station's line in the file, for the errors;
    `columns`: every column the file has, for the error naming them),
    every value by its rule (RULES), in linear time."""
    if not n:
        raise DataError(f"{path}: no survey stations")
    azk = "azi_deg" if "azi_deg" in cols else "azi_mag_deg" if "azi_mag_deg" in cols else None
    missing = [k for k, v in (("md_m", "md_m" in cols), ("inc_deg", "inc_deg" in cols), ("azi_deg", azk)) if not v]
    if missing:
        raise DataError(f"{path}: missing column {', '.join(missing)} (a survey listing needs md_m, inc_deg, azi_deg)"
                        + _depth_hint(columns if columns is not None else cols, missing))
    md = _numbers(cols["md_m"], "md_m", path, lines)
    inc = _numbers(cols["inc_deg"], "inc_deg", path, lines, md)
    azi = _numbers(cols[azk], azk, path, lines, md)
    extra = {k: (_numbers(cols[k], k, path, lines, md, text_ok=k in TEXT_OK) if k in cols else np.full(n, np.nan))
             for k in EXTRA}
    for k, v in (("md_m", md), ("inc_deg", inc), (azk, azi)):
        bad = ~np.isfinite(v)
        if bad.any():
            i = int(np.argmax(bad))
            raise DataError(f"{_where(path, i, md[i] if k != 'md_m' else None)}: {k} is not a finite number")
    _check_rules({"md_m": md, "inc_deg": inc, azk: azi, **extra}, path)
    meta = {**meta, "run": run_direction(md, path), "file": path}
    order = np.argsort(md, kind="stable")  # an out-run reads bottom up: the path is computed top down
    ex = {k: v[order] for k, v in extra.items()}
    utc = ex.pop("utc_s")
    from inclino.formats.survey_log import parse_utc

    if np.any(np.isfinite(utc)) and meta.get("start_utc"):
        ex["utc"] = parse_utc(meta["start_utc"], path) + utc  # POSIX seconds, UTC
    elif utc_text is not None:  # JSON lines: each reading's time in ISO 8601
        ex["utc"] = np.array([parse_utc(t, _where(path, i)) for i, t in enumerate(utc_text)])[order]
    return _merge_repeats(Survey(md[order], inc[order], np.mod(azi[order], 360.0), ex, meta))


# repeated surveys at one depth keep a toolface when theirs agree within about 5 deg (their mean resultant
# length cos 5 deg); turned between them, the station's sensor error is an average over toolfaces: none is kept
TF_MERGE_RESULTANT = math.cos(math.radians(5.0))


def _merge_repeats(sv: Survey) -> Survey:
    """Repeated surveys at one depth (`inclino survey --count N --md M`) as one
    station: inclination and the field values averaged, azimuth the mean
    direction, flags and QC bits or-ed (linear time: sums by group)."""
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
        ok = np.isfinite(v)
        cnt = np.bincount(grp[ok], None, n)
        if k in ("flags", "qc"):
            out = np.zeros(n, np.int64)
            np.bitwise_or.at(out, grp[ok], v[ok].astype(np.int64))
            out = out.astype(float)
        elif k == "tf_deg":  # the mean direction where the repeats share a toolface, else none (NaN)
            t = np.radians(v[ok])
            c, s_ = np.bincount(grp[ok], np.cos(t), n), np.bincount(grp[ok], np.sin(t), n)
            with np.errstate(invalid="ignore", divide="ignore"):
                out = np.where(np.hypot(c, s_) >= TF_MERGE_RESULTANT * cnt, np.degrees(np.arctan2(s_, c)) % 360.0,
                               np.nan)
        else:
            with np.errstate(invalid="ignore", divide="ignore"):
                out = np.bincount(grp[ok], v[ok], n) / cnt
        extra[k] = np.where(cnt > 0, out, np.nan)
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
    cols, n, lines, meta = _csv_columns(text, path, ("md_m", "inc_deg", "azi_deg", "azi_mag_deg") + EXTRA)
    header = next((ln for ln in text.splitlines() if ln.strip() and not ln.lstrip().startswith("#")), "")
    return _cols_to_survey(cols, n, path, meta, lines=lines, columns=[h.strip() for h in header.split(",")])


def _csv_lines(text: str, meta: dict, numbers: list):
    """The listing's lines that are not comments or blank; its `# key=value`
    lines into meta; each line's number (from 1) appended to numbers."""
    for n, line in enumerate(io.StringIO(text), start=1):
        s = line.strip()
        if s.startswith("#"):
            if "=" in s:
                k, v = s[1:].split("=", 1)
                meta[k.strip()] = v.strip()
            continue
        if s:
            numbers.append(n)
            yield line


CHUNK = 1 << 16  # rows converted to numbers at a time (bounded memory on a long listing)


def _csv_columns(text: str, path: str, wanted):
    """(columns: name -> float array, with text cells of TEXT_OK columns
    NaN; stations; each station's line; meta) of a CSV listing, read in
    linear time and bounded memory (cells converted a chunk at a time)."""
    meta, numbers = {}, []
    rdr = csv.reader(_csv_lines(text, meta, numbers))
    try:
        head = next(rdr, None)
        if head is None:
            raise DataError(f"{path}: no header row")
        header = [h.strip() for h in head]
        idx = {k: header.index(k) for k in wanted if k in header}
        cols = {k: [] for k in idx}
        lines, buf = [], {k: [] for k in idx}

        def flush():
            n0 = len(lines) - len(next(iter(buf.values()))) if buf else 0
            md = None
            if "md_m" in buf:  # first: the other columns' errors name the station's depth
                md = _numbers(buf["md_m"], "md_m", path, lines[n0:])
                cols["md_m"].append(md)
                buf["md_m"].clear()
            for k, cells in buf.items():
                if k != "md_m":
                    cols[k].append(_numbers(cells, k, path, lines[n0:], md, text_ok=k in TEXT_OK))
                    cells.clear()
        for rec in rdr:
            line = numbers[-1]
            rec = [c.strip() for c in rec]
            if rec == header:  # several `inclino survey --csv` outputs appended
                continue
            if len(rec) != len(header):
                raise DataError(f"{path}:{line}: {len(rec)} fields, the header {len(header)}")
            lines.append(line)
            for k, j in idx.items():
                buf[k].append(rec[j])
            if idx and len(buf[next(iter(idx))]) >= CHUNK:
                flush()
        if idx:
            flush()
    except csv.Error as e:
        raise DataError(f"{path}:{numbers[-1] if numbers else 1}: not CSV ({e})") from None
    n = len(lines)
    return {k: (np.concatenate(v) if v else np.empty(0)) for k, v in cols.items()}, n, lines, meta


def _csv_rows(text: str, path: str):
    """The rows of a CSV listing as objects (a noise run's few rows)."""
    meta, numbers = {}, []
    rdr = csv.reader(_csv_lines(text, meta, numbers))
    try:
        head = next(rdr, None)
        if head is None:
            raise DataError(f"{path}: no header row")
        header = [h.strip() for h in head]
        rows = []
        for rec in rdr:
            rec = [c.strip() for c in rec]
            if rec == header:
                continue
            if len(rec) != len(header):
                raise DataError(f"{path}:{numbers[-1]}: {len(rec)} fields, the header {len(header)}")
            rows.append(dict(zip(header, rec)))
    except csv.Error as e:
        raise DataError(f"{path}:{numbers[-1] if numbers else 1}: not CSV ({e})") from None
    return rows, meta


def _read_json(text: str, path: str) -> Survey:
    rows = _json_rows(text, path)
    probe = rows[0].get("probe") if rows else None
    return _rows_to_survey(rows, path, {k: str(v) for k, v in probe.items()} if isinstance(probe, dict) else {})


def _json_rows(text: str, path: str) -> list:
    """A JSON array of objects or JSON lines, through safeio's bounded
    parser (nesting, number size): every defect one line."""
    from inclino.formats import safeio

    s = text.strip()
    if s.startswith("["):
        rows = safeio.parse_json(s, path)
    else:
        rows = [safeio.parse_json(line, f"{path}:{n}") for n, line in enumerate(s.splitlines(), start=1)
                if line.strip()]
    if not isinstance(rows, list) or not all(isinstance(r, dict) for r in rows):
        raise DataError(f"{path}: each station must be a JSON object")
    return rows


LAS_CURVES = {"INC": "inc_deg", "AZI": "azi_deg", "AZIM": "azi_deg", "GTOT": "gt_g", "BTOT": "bt_nT",
              "DIP": "dip_deg", "GTF": "tf_deg", "FLAGS": "flags", "QC": "qc"}


def _las_numbers(c, path: str) -> np.ndarray:
    """A LAS curve's values as numbers (a value lasio could not read as one:
    DataError naming the curve and the data line)."""
    try:
        return np.asarray(c.data, float)
    except (TypeError, ValueError):
        for i, v in enumerate(c.data):
            try:
                float(v)
            except (TypeError, ValueError):
                raise DataError(f"{path}: curve {c.mnemonic}, data line {i + 1}: {str(v)[:20]!r} is not a "
                                "number") from None
        raise DataError(f"{path}: curve {c.mnemonic} is not numbers") from None


LAS_META = {"PSERIAL": "probe_serial", "PRODUCT": "product", "FWVER": "firmware", "CALSLOT": "calibration_slot",
            "CALSEQ": "calibration_sequence", "CALCRC": "calibration_crc", "TSTART": "start_utc"}


def _las_survey_curves(curves: dict, path: str) -> None:
    """A LAS listing names inclination INC and magnetic azimuth AZI or AZIM;
    another tool's file (DEVI, HAZI, ...) is refused naming the curves it
    has, not a CSV's columns."""
    lack = [w for w, names in (("inclination INC", ("INC",)), ("magnetic azimuth AZI or AZIM", ("AZI", "AZIM")))
            if not any(n in curves for n in names)]
    if lack:
        raise DataError(f"{path}: no {' and no '.join(lack)} curve (its curves: {', '.join(curves)}); a file of "
                        "another tool needs its curves renamed, its azimuth referred to magnetic north")


def _read_las(text: str, path: str) -> Survey:
    from inclino.formats import las as lasfmt

    las = lasfmt.read(text, path)
    curves = {c.mnemonic.upper(): c for c in las.curves}
    md = None
    for m in ("DEPT", "DEPTH", "MD"):
        if m in curves:
            c = curves[m]
            md = _las_numbers(c, path) * lasfmt.depth_factor(c.unit, f"{path}: curve {c.mnemonic}")
            break
    if md is None:
        raise DataError(f"{path}: no measured-depth curve (DEPT, DEPTH or MD)")
    _las_survey_curves(curves, path)
    n = len(md)
    rows = [{"md_m": md[i]} for i in range(n)]
    for m, key in {**LAS_CURVES, "TIME": "utc_s"}.items():
        if m in curves:
            d = _las_numbers(curves[m], path)
            for i in range(n):
                if not math.isnan(d[i]):
                    rows[i].setdefault(key, d[i])
    meta = {}
    for p in las.params:
        if p.mnemonic.upper() in LAS_META and str(p.value).strip():
            meta[LAS_META[p.mnemonic.upper()]] = str(p.value).strip()
    return _rows_to_survey(rows, path, meta)


def _text(path: str) -> str:
    """The listing's text: UTF-8 (a byte-order mark dropped), bounded
    (inclino.formats.safeio.read_text)."""
    from inclino.formats import safeio

    return safeio.read_text(path, "survey listing", MAX_LISTING_BYTES)


def read_survey_rows(path: str) -> list[dict]:
    """The rows of a survey listing (CSV or JSON) as they are, numbers parsed
    where a value is one (for a noise run: no measured depth needed)."""
    text = _text(path)
    s = text.lstrip()
    if s.startswith("~"):
        from inclino.formats import las as lasfmt

        las = lasfmt.read(text, path)
        cur = {c.mnemonic.upper(): _las_numbers(c, path) for c in las.curves}
        n = len(las.index)
        return [{key: float(cur[m][i]) for m, key in LAS_CURVES.items() if m in cur} for i in range(n)]
    rows = _json_rows(text, path) if s.startswith(("{", "[")) else _csv_rows(text, path)[0]
    if not isinstance(rows, list) or not all(isinstance(r, dict) for r in rows):
        raise DataError(f"{path}: each survey must be a JSON object")
    out = []
    for i, r in enumerate(rows):
        d = {}
        for k, v in r.items():
            if k in ("gt_g", "bt_nT", "inc_deg", "azi_deg", "dip_deg"):
                d[k] = _num(v, k, f"{path}: row {i + 1}")
        out.append(d)
    _check_rules({k: [r.get(k, float("nan")) for r in out] for k in ("gt_g", "bt_nT", "dip_deg")}, path)
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
    data: dict  # column -> one value per station (a float array, or a list of text)
    columns: list
    reference: dict
    survey: dict | None = None  # the survey's header (probe, calibration, run direction, start time)
    summary: dict = field(default_factory=dict)

    def __len__(self) -> int:
        return len(self.data["md_m"])

    def column(self, key) -> np.ndarray:
        """One column as floats (NaN where a station has none)."""
        v = self.data.get(key)
        return np.full(len(self), np.nan) if v is None else np.asarray(v, float)

    @property
    def rows(self) -> list:
        """One dict per station (a view built on demand: the trajectory
        itself is held column by column); a QC difference (dgt_g, ...) only
        where the station has one."""
        keys = list(self.data)
        out = []
        for i in range(len(self)):
            r = {}
            for k in keys:
                v = self.data[k][i]
                if isinstance(v, str):
                    r[k] = v
                else:
                    v = float(v)
                    if k in QC_DIFF and not math.isfinite(v):
                        continue
                    r[k] = v
            out.append(r)
        return out

    def to_json(self) -> str:
        d = {"rows": self.rows, "columns": self.columns, "reference": self.reference, "survey": self.survey,
             "summary": {k: v for k, v in self.summary.items() if k != "parts"}}
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
    prop = model.propagate(sv.md_m, sv.inc_deg, sv.azi_mag_deg, rf, fb, tf=sv.extra.get("tf_deg")) \
        if model is not None else None
    n = len(sv)
    north, east, tvd = np.asarray(ws.n, float) - ws.n[0], np.asarray(ws.e, float) - ws.e[0], \
        np.asarray(ws.tvd, float) - ws.tvd[0]
    del ws  # welleng's survey holds many arrays per station: freed before the columns are built
    azi_true = np.mod(sv.azi_mag_deg + rf.declination_deg, 360.0)
    dls = np.zeros(n)
    if n > 1:
        dls[1:] = dogleg_deg(sv.inc_deg[:-1], azi_true[:-1], sv.inc_deg[1:], azi_true[1:]) / np.diff(sv.md_m) * 30.0
    cols = ["md_m", "inc_deg", "azi_mag_deg", "azi_true_deg"]
    data = {"md_m": sv.md_m, "inc_deg": sv.inc_deg, "azi_mag_deg": sv.azi_mag_deg, "azi_true_deg": azi_true}
    grid = rf.grid_epsg is not None
    if grid:
        cols.append("azi_grid_deg")
        data["azi_grid_deg"] = (azi_true - rf.convergence_deg) % 360.0
    cols += ["tvd_m", "north_m", "east_m"]
    data.update(tvd_m=tvd, north_m=north, east_m=east)
    if grid:
        cols += ["northing_m", "easting_m"]
        g, k = math.radians(rf.convergence_deg), rf.scale_factor
        data["northing_m"] = rf.northing_m + k * (north * math.cos(g) + east * math.sin(g))
        data["easting_m"] = rf.easting_m + k * (east * math.cos(g) - north * math.sin(g))
    cols += ["dls_deg_per_30m"]
    data["dls_deg_per_30m"] = dls
    # station QC, column by column (linear time)
    ex = sv.extra
    nan = np.full(n, np.nan)
    nq = {"G": 0, "B": 0, "dip": 0, "probe": 0, "near-vertical": 0}
    checked = np.zeros((n, 5), bool)  # G, B, dip, probe, probe (G only)
    failed = np.zeros((n, 4), bool)   # G, B, dip, probe
    for j, (name, key, refkey) in enumerate(HOST_QC):
        v, ref = np.asarray(ex.get(key, nan), float), getattr(rf, refkey)
        if not math.isfinite(ref):
            continue
        ok = np.isfinite(v)
        checked[:, j] = ok
        d = np.where(ok, v - ref, np.nan)
        if ok.any():
            data[f"d{key}"] = d
        with np.errstate(invalid="ignore"):
            failed[:, j] = ok & (np.abs(d) > rf.tol[key])
        nq[name] = int(failed[:, j].sum())
    fl, pq = np.asarray(ex.get("flags", nan), float), np.asarray(ex.get("qc", nan), float)
    flv = np.where(np.isfinite(fl), fl, 0).astype(np.int64)
    near_vertical = (np.isfinite(fl) & (flv & 1 != 0)) | (sv.inc_deg < 0.5) | (sv.inc_deg > 179.5)
    nq["near-vertical"] = int(near_vertical.sum())
    pok = np.isfinite(pq)
    pqv = np.where(pok, pq, 0).astype(np.int64)
    checked[:, 3] = pok & (pqv & 0x80 == 0)
    checked[:, 4] = pok & (pqv & 0x80 != 0)
    failed[:, 3] = pok & (pqv & 0x7F != 0)
    nq["probe"] = int(failed[:, 3].sum())
    names = ("G", "B", "dip", "probe", "probe (G only)")
    qc_of = {}
    qc_checked, qc = [], []
    codes = checked.astype(np.int64) @ (1 << np.arange(5)) * 16 + failed.astype(np.int64) @ (1 << np.arange(4))
    for c in codes.tolist():  # one text per distinct combination: a dictionary lookup a station
        t = qc_of.get(c)
        if t is None:
            ck = [names[j] for j in range(5) if c >> (4 + j) & 1]
            fs = [names[j] for j in range(4) if c >> j & 1]
            what = ",".join(ck) if ck else "nothing: no field values or no reference"
            t = qc_of[c] = (what, f"FAIL {','.join(fs)} (checked {what})" if fs else
                            f"PASS {what}" if ck else f"not checked ({what})")
        qc_checked.append(t[0])
        qc.append(t[1])
    data["qc_checked"] = qc_checked
    data["qc"] = qc
    data["note"] = np.where(near_vertical, "near-vertical: azimuth undefined", "").tolist()
    for key in ("gt_g", "bt_nT", "dip_deg"):
        if f"d{key}" in data:
            cols.append(f"d{key}")
    cols += ["qc", "note"]
    summary = {"stations": n, "qc_fail": int(failed.any(axis=1).sum()), "qc_fail_by": nq,
               "qc_checked": sorted(set(what for what, _ in qc_of.values())),
               "md_m": [float(sv.md_m[0]), float(sv.md_m[-1])],
               "end": {"tvd_m": float(tvd[-1]), "north_m": float(north[-1]), "east_m": float(east[-1])}}
    if "utc" in ex:
        t0 = float(np.nanmin(ex["utc"]))
        from inclino.formats.survey_log import utc_iso

        summary["start_utc"] = utc_iso(t0)
        data["utc_s"] = np.asarray(ex["utc"], float) - t0
        cols[cols.index("qc"):cols.index("qc")] = ["utc_s"]
    summary["run"] = sv.meta.get("run", "")
    if prop is not None:
        cov = np.asarray(prop.cov_nev, float)
        dia = np.asarray(prop.cov_dia, float)
        maj, mnr, az = ellipses(cov[:, :2, :2])
        with np.errstate(invalid="ignore"):
            s_azi = np.degrees(np.sqrt(np.maximum(dia[:, 2, 2], 0)))
        data.update(sigma_inc_deg=np.degrees(np.sqrt(np.maximum(dia[:, 1, 1], 0))),
                    sigma_azi_deg=np.where(~near_vertical & np.isfinite(s_azi) & (s_azi < 360), s_azi, np.nan),
                    sigma_north_m=np.sqrt(np.maximum(cov[:, 0, 0], 0)), sigma_east_m=np.sqrt(np.maximum(cov[:, 1, 1], 0)),
                    sigma_tvd_m=np.sqrt(np.maximum(cov[:, 2, 2], 0)), ell_major_m=maj, ell_minor_m=mnr, ell_azi_deg=az,
                    cov_nn=cov[:, 0, 0], cov_ne=cov[:, 0, 1], cov_nv=cov[:, 0, 2], cov_ee=cov[:, 1, 1],
                    cov_ev=cov[:, 1, 2], cov_vv=cov[:, 2, 2])
        cols[cols.index("qc"):cols.index("qc")] = ["sigma_inc_deg", "sigma_azi_deg", "sigma_north_m",
                                                   "sigma_east_m", "sigma_tvd_m", "ell_major_m", "ell_minor_m",
                                                   "ell_azi_deg", "cov_nn", "cov_ne", "cov_nv", "cov_ee",
                                                   "cov_ev", "cov_vv"]
        summary["end"].update(ell_major_m=float(maj[-1]), ell_minor_m=float(mnr[-1]),
                              parts={k: dict(zip(("ell_major_m", "ell_minor_m"), ellipse(c[-1][:2, :2])[:2]))
                                     for k, c in prop.parts.items()})
        summary["error_model"] = model.describe()
        summary["parts"] = prop.parts
    meta = {k: v for k, v in sv.meta.items() if k in SURVEY_META}
    order = cols + [k for k in data if k not in cols]
    return Trajectory({k: data[k] for k in order}, cols, rf.header(),
                      {"survey": meta, "start_utc": summary.get("start_utc")}, summary)


def ellipses(cov_ne):
    """`ellipse` for a stack of 2x2 covariances (n, 2, 2), vectorised:
    (semi-major, semi-minor, azimuth of the major axis 0-180) arrays."""
    a, b, d = cov_ne[:, 0, 0], cov_ne[:, 0, 1], cov_ne[:, 1, 1]
    half = 0.5 * (a + d)
    r = np.sqrt(np.maximum((0.5 * (a - d)) ** 2 + b ** 2, 0.0))
    major = np.sqrt(np.maximum(half + r, 0.0))
    minor = np.sqrt(np.maximum(half - r, 0.0))
    az = np.degrees(0.5 * np.arctan2(2 * b, a - d)) % 180.0
    return major, minor, az


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
    from inclino.formats import safeio

    n = len(tr)
    with safeio.output_file(path) as f:  # written a chunk of stations at a time (bounded memory)
        f.write(buf.getvalue())
        for lo in range(0, n, CHUNK):
            hi = min(n, lo + CHUNK)
            cells = [_texts(tr.data.get(c), lo, hi) for c in tr.columns]
            chunk = io.StringIO()
            csv.writer(chunk, lineterminator="\n").writerows(zip(*cells))
            f.write(chunk.getvalue())


def _texts(v, lo, hi) -> list:
    """Cells of one column for stations lo..hi: text as it is, numbers as
    _fmt writes them (10 significant digits, empty for none)."""
    if v is None:
        return [""] * (hi - lo)
    part = v[lo:hi]
    if isinstance(part, list):
        return part
    x = np.asarray(part, float)
    out = np.char.mod("%.10g", np.where(np.isfinite(x), x, 0.0)).tolist()
    if not np.all(np.isfinite(x)):
        out = [t if ok else "" for t, ok in zip(out, np.isfinite(x).tolist())]
    return out


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

    md = tr.column("md_m")
    curves = [(mnem, unit, descr, tr.column(key)) for key, mnem, unit, descr in LAS_OUT if key in tr.columns]
    if "utc_s" in tr.columns:
        curves.append(("TIME", "s", "time of the station's reading since the survey's start (DATE, UTC)",
                       tr.column("utc_s")))
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
