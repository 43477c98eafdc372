"""`inclino import`: a log of any sensor, through its sensor description,
into the canonical dataset (docs/dataset.md).

    ds, rep = import_log("log.csv", sensor.load("my_imu.toml"))
    dataset.write_raw("run.csv", ds)

The log is delimited text: comma, semicolon, tab or whitespace (sniffed from
the header line, or [log].delimiter), comment lines and blank lines skipped,
the columns named by its first line ([log].header = true) or numbered from 1
(header = false).  Every row's readings go through the description
(inclino.formats.sensor: unit, scale, gravity sign, axis map) into g and nT in
the body frame.  A row with a missing value in a used column ("", NaN, NA,
null) is dropped and counted under the columns that had none; any other
text in a used column is an error naming the row and the column.  Counts of
an axis that read as signed words logged unsigned (near 0 and near 2^16,
nothing between) are refused unless the description declares their word
(counts = "int16"), and filler rows (a run of rows identical, time stamp and
all, or a time stamp that stops) unless the bad rows are dropped: both
before the checks (inclino.checks) see any reading.  The header of the
canonical file records
the log (path, SHA-256), the description (name, SHA-256, axis maps, units,
resolution, noise, range) and what was dropped.
"""
from __future__ import annotations

import csv
import dataclasses
import hashlib
import json
import math
import os
import re
from dataclasses import dataclass, field

import numpy as np

from inclino.errors import DataError

from . import dataset
from .dataset import ACC_COLS, GYRO_COLS, MAG_COLS, MAX_LINE_CHARS, RawDataset
from .sensor import FIELD_UNIT, NS_PER_S, SensorDescription, split_stamp

MAX_LOG_BYTES = 2 << 30  # a log is read whole into memory (8 bytes a value kept)
MAX_BAD_ROWS_FRACTION = 0.05  # dropping more malformed rows than this: the description does not fit the log
MISSING = {"", "nan", "na", "n/a", "null", "none", "-", "--"}


@dataclass
class ImportReport:
    log: str
    sensor: str
    rows_read: int
    rows: int
    dropped: dict = field(default_factory=dict)   # reason -> count
    triads: str = "both"
    notes: list = field(default_factory=list)
    row_index: list | None = field(default=None, repr=False)  # each row's index among the rows read (pairing)
    time_origin: int | None = field(default=None, repr=False)  # whole seconds taken from a stamp in two columns
                                                                # read with its own clock (pairing two files)

    def to_dict(self) -> dict:
        return {"log": self.log, "sensor": self.sensor, "rows_read": self.rows_read, "rows": self.rows,
                "dropped": self.dropped, "triads": self.triads, "notes": self.notes}


# the canonical header keys a log's own '# key=value' lines carry into the dataset (the site and the run; never
# the import's record of a description, which the import writes itself)
LOG_META = ("field_nT", "dip_deg", "declination_deg", "gravity_g", "lat_deg", "lon_deg", "date", "probe_serial",
            "samples_averaged", "start_utc")


def _sha256(path: str) -> str:
    h = hashlib.sha256()
    with open(path, "rb") as f:
        for block in iter(lambda: f.read(1 << 20), b""):
            h.update(block)
    return h.hexdigest()


def _split(line: str, delim: str | None) -> list:
    if delim == "whitespace":
        return line.split()
    return next(csv.reader([line], delimiter=delim))


def _sniff(line: str, decimal: str = ".") -> str:
    for d in ((";", "\t") if decimal == "," else (",", ";", "\t")):
        if d in line:
            return d
    return "whitespace"


def _numeric(text: str) -> bool:
    t = text.strip().replace(",", ".")
    try:
        float(t)
        return True
    except ValueError:
        return t.lower() in MISSING


def _bracket_hint(cell: str, line: str) -> str:
    """The hint for a cell that is a number inside brackets or quotes (a
    tuple or a list printed as text: "((-0.51, -0.07, 10.55), (-38.8, ...))"
    was "'((-0.51' is not a number"), naming every such mark on its line,
    else ''."""
    marks = "".join(c for c in "()[]{}<>'\"" if c in line)
    if not marks or not _numeric(cell.translate(str.maketrans("", "", marks))):
        return ""
    return (f" (a number inside brackets or quotes: a tuple or a list printed as text; [log] strip = "
            f"{json.dumps(marks)} takes them out of every line)")


def _clock(text: str):
    """Seconds of a date-time (ISO 8601: '2024-05-01T12:00:00.125Z',
    '2024-05-01 12:00:00') or of a time of day ('12:00:00.125'); None when
    the text is neither."""
    from datetime import datetime, time, timezone

    t = text.strip()
    if t.endswith(("Z", "z")):
        t = t[:-1] + "+00:00"
    try:
        d = datetime.fromisoformat(t)
        if d.tzinfo is None:
            d = d.replace(tzinfo=timezone.utc)
        return d.timestamp()
    except ValueError:
        pass
    try:
        c = time.fromisoformat(t)
        return c.hour * 3600.0 + c.minute * 60.0 + c.second + c.microsecond * 1e-6
    except ValueError:
        return None


def _index(col, names, what, path, lineno):
    """The 0-based index of a column named `col` (or numbered, from 1)."""
    if isinstance(col, int):
        if names is not None and not 1 <= col <= len(names):
            raise DataError(f"{path}:{lineno}: {what}: column number {col}, the log has {len(names)} columns")
        if col < 1:
            raise DataError(f"{what}: column numbers start at 1")
        return col - 1
    if names is None:
        raise DataError(f"{what}: {col!r}: the log has no header line ([log].header = false): number the columns")
    stripped = [n.strip() for n in names]
    low = [n.lower() for n in stripped]
    for seq, key in ((stripped, col), (low, col.lower())):
        hits = [i for i, n in enumerate(seq) if n == key]
        if len(hits) > 1:  # which copy the description means is unknown: never the first by chance
            raise DataError(f"{path}:{lineno}: {what}: {col!r} names {len(hits)} columns of the log (numbers "
                            f"{', '.join(str(i + 1) for i in hits)}): give the column by its number, or the "
                            f"header line that names it apart ([log] skip_rows)")
        if hits:
            return hits[0]
    numeric = sum(_is_number(n) for n in stripped)
    numbers = bool(stripped) and numeric == len(stripped)
    # a data row read as the header (its line lost) keeps a label or a date among its numbers: an ESP32 six-face
    # log with its header line cut, "513222,17092,...,posX", was named its columns and no cause
    mostly = not numbers and len(stripped) >= 2 and numeric >= max(2, (len(stripped) + 1) // 2)
    raise DataError(f"{path}:{lineno}: {what}: no column {col!r} (the log's columns: "
                    f"{', '.join(stripped[:20])}{' ...' if len(stripped) > 20 else ''})"
                    + ("; every name is a number: the log has no header line ([log] header = false, and the "
                       "columns by number)" if numbers else
                       f"; {numeric} of its {len(stripped)} names are numbers: the line read as the header is a data "
                       f"row, the header line lost? (put the log's header line back, or [log] header = false and "
                       f"the columns by number)" if mostly else ""))


def _line_delimiter(line: str, desc: SensorDescription) -> str:
    """The delimiter a line is split at: the declared one, else sniffed."""
    d = desc.delimiter if desc.delimiter is not None else _sniff(line, desc.decimal)
    return "\t" if d == "\\t" else d


def _named_columns(desc: SensorDescription) -> list:
    """The columns the description gives by name (triads, time, temperature)."""
    named = [c for t in desc.triads + ((desc.gyro,) if desc.gyro else ()) for c in t.columns if isinstance(c, str)]
    times = list(desc.time) if split_stamp(desc.time) else [desc.time]
    return named + [c for c in times + [desc.temperature] if isinstance(c, str)]


def _names_found(named: list, names) -> int:
    """How many of the named columns a split line names, as _index finds a
    name (stripped, case aside)."""
    low = {n.strip().lower() for n in names}
    return sum(c.strip().lower() in low for c in named)


def _skipped_header(skipped: list, names, desc: SensorDescription, path: str, lineno: int) -> None:
    """[log] skip_rows that skipped the header line: a column the description
    names is not in the line read as the header, but a line skip_rows skipped
    names every column the description gives.  One error line with the
    skip_rows to write (x-io's log with skip_rows = 1 was told its header
    line was missing, to number its columns)."""
    wanted = _named_columns(desc)
    if not wanted or _names_found(wanted, names) == len(wanted):
        return
    for k, (no, line) in enumerate(skipped):
        if _names_found(wanted, _split(line, _line_delimiter(line, desc))) == len(wanted):
            raise DataError(f"{path}:{no}: [log] skip_rows = {desc.skip_rows} skips this line, the header line "
                            f"that names the columns the description gives (line {lineno} was read as the header "
                            f"instead); skip_rows = {k}")
DELIM_TEXT = {",": "commas", ";": "semicolons", "\t": "tabs", "whitespace": "whitespace"}


def _check_split(first: str, delim: str, names, desc: SensorDescription, path: str, lineno: int) -> None:
    """A header line that names none of the description's columns when split
    at the delimiter used, and every one of them when split at another: the
    log's delimiter is that other.  A phyphox export "CSV (Comma, decimal
    point)" read with decimal = "," (whose delimiter then is a semicolon, tab
    or whitespace) was "no column 'Acceleration x (m/s^2)'" listing columns
    cut at its spaces; refused naming the delimiter, and the decimal mark
    when that is what moved it."""
    named = _named_columns(desc)
    if not named or _names_found(named, names):
        return
    _header_further(path, lineno, desc, named)
    for d in (",", ";", "\t", "whitespace"):
        if d == delim or _names_found(named, _split(first, d)) < len(named):
            continue
        if desc.delimiter is None and desc.decimal == "," and d == ",":
            raise DataError(f"{path}:{lineno}: the header line names the description's columns when split at commas, "
                            f"but [log] decimal = \",\" makes the comma the decimal mark (and the delimiter a "
                            f"semicolon, tab or whitespace): a comma-delimited log writes its decimals with a point; "
                            f"[log] decimal = \".\" (or leave it out)")
        how = f"declared: [log] delimiter = {json.dumps(delim)}" if desc.delimiter is not None else "sniffed"
        raise DataError(f"{path}:{lineno}: the header line names none of the description's columns split at "
                        f"{DELIM_TEXT.get(delim, repr(delim))} ({how}), and every one of them split at "
                        f"{DELIM_TEXT[d]}: [log] delimiter = {json.dumps(d)}")


LABELLED = re.compile(r"\s*([A-Za-z_][A-Za-z0-9_.]*)\s*:\s*(\S*)\s*")


def _labels(cells):
    """The labels of a line whose every cell is "label:number" (Arduino's
    Serial Plotter format, "ax:0.01,ay:-0.02,az:0.98": each value printed
    after its name), two or more, all different; else None."""
    if len(cells) < 2:
        return None
    found = [LABELLED.fullmatch(c) for c in cells]
    if not all(found):
        return None
    labels = [m.group(1) for m in found]
    if len(set(labels)) < len(labels) or not all(m.group(2) and _numeric(m.group(2)) for m in found):
        return None
    return labels


def _unlabel(cells, labels, path: str, lineno: int, drop_bad: bool):
    """The values of a row of "label:value" cells whose labels are the first
    line's, in its order; a row whose labels differ (a line cut or garbled
    on the serial link, a label printed in another order) is malformed:
    None with drop_bad, else refused naming the cell."""
    out = []
    for j, c in enumerate(cells):
        m = LABELLED.fullmatch(c)
        if m is None or j >= len(labels) or m.group(1) != labels[j]:
            if drop_bad:
                return None
            want = f"'{labels[j]}:'" if j < len(labels) else f"no cell (the first line has {len(labels)})"
            raise DataError(f"{path}:{lineno}: cell {j + 1} {c.strip()[:40]!r}: the first line's labels give "
                            f"{want} there (a line of label:value cells, its labels in the first line's order); a "
                            f"garbled or cut line? [log] bad_rows = \"drop\" (or --drop-bad-rows) drops such rows")
        out.append(m.group(2))
    return out


HEADER_SEARCH_LINES = 200  # lines searched past the one read as the header for the line that names the columns


def _header_further(path: str, lineno: int, desc: SensorDescription, named: list) -> None:
    """The line that names every column the description names, further down
    than the line read as the header: the lines between are a preamble (an
    Xsens MT Manager export's "// General information:" lines, a vendor
    tool's notes); refused naming that line and the comment mark they share
    ([log] comment = "//"), else the skip_rows that reaches it.  An Xsens
    export read with the default comment "#" was "no column 'Acc_X' (the
    log's columns: //, General, information:)"."""
    try:
        with open(path, encoding=_encoding(path), errors="replace", newline="") as f:
            head = [next(f, "") for _ in range(lineno + HEADER_SEARCH_LINES)]
    except OSError:
        return
    for i in range(lineno, len(head)):
        line = head[i].rstrip("\r\n").translate(str.maketrans("", "", desc.strip))
        if not line.strip():
            continue
        if _names_found(named, _split(line, _line_delimiter(line, desc))) < len(named):
            continue
        before = [h.strip() for h in head[lineno - 1:i] if h.strip()]
        mark = os.path.commonprefix(before)
        mark = mark[:len(mark) - len(mark.lstrip("/#%;!*-=<>'"))] if before else ""
        fix = (f"[log] comment = {json.dumps(mark)} (the mark its lines start with)" if mark else
               f"[log] skip_rows = {i} (the lines before it)")
        n = i + 1 - lineno
        raise DataError(f"{path}:{i + 1}: this line names the description's columns, and the {n} "
                        f"line{'s' if n > 1 else ''} before it from line {lineno} ({before[0][:40]!r}"
                        f"{' ...' if n > 1 else ''}) {'are a preamble' if n > 1 else 'is a preamble line'}, not "
                        f"the header: {fix}")


def _header_is_data(names) -> bool:
    """Whether a header line is a row of readings: every name a number, and
    either one at least with a fraction or an exponent, or whole numbers that
    are no run of column indices (0, 1, 2 as pandas writes one, or 1, 2, 3:
    each one more than the last, from 0 or 1).  A magnetometer logged in
    whole counts, "-163 64 1" (aleksandrbazhin/ellipsoid_fit_python's
    mag_out.txt), has no fraction, and its first row had been read as the
    names and left out in silence."""
    cells = [n.strip() for n in names if n.strip()]
    if len(cells) < 2 or not all(_is_number(c) for c in cells):
        return False
    x = [float(c) for c in cells]
    if not all(math.isfinite(v) for v in x):
        return any(("." in c or "e" in c.lower()) and math.isfinite(v) for c, v in zip(cells, x))
    if any("." in c or "e" in c.lower() for c in cells):
        return True
    return not (x[0] in (0.0, 1.0) and all(b - a == 1.0 for a, b in zip(x, x[1:])))


def _is_number(text: str) -> bool:
    try:
        float(text)
    except ValueError:
        return False
    return True


def _missed(missing_rows: dict, columns: list, lineno: int) -> None:
    """Count a row dropped for a missing value under the columns it had none in."""
    m = missing_rows.setdefault(tuple(columns), [0, lineno, lineno])
    m[0] += 1
    m[2] = lineno


def _column_text(key: str, j: int, names) -> str:
    """A used column as the messages name it: the canonical name and the log's ("temp_c (column 13)")."""
    what = {"t_s": "time", "t_ns": "time (nanoseconds)", "temp_c": "temperature", "inc_deg": "pose inc", "azi_deg": "pose azi",
            "tf_deg": "pose tf"}.get(key)
    if what is None:  # a sensor axis as logged, before the axis map
        c = key.lstrip("_")
        what = f"{'accelerometer' if c in ACC_COLS else 'gyroscope' if c in GYRO_COLS else 'magnetometer'} {c[1]}"
    return f"{what} ({repr(names[j].strip()) if names is not None else f'column {j + 1}'})"


SIGNED_WIDTHS = (8, 16, 24, 32)  # the words a logger writes two's-complement counts in
SIGNED_SPREAD = 0.5  # read signed, an axis' counts spread less than this fraction of their spread read unsigned


def _check_counts(t, data, keys, line_no, names, wanted, path) -> None:
    """A triad in counts: declared two's complement (counts = "intN"), every
    count within the word; not declared, an axis whose counts cluster near 0
    and near 2^N with nothing between (signed counts logged as unsigned:
    65404 is -132) is refused with the declaration that reads them, before
    any unit check computes an lsb from them."""
    if t.unit != "counts":
        return
    section = "accelerometer" if t.kind == "acc" else "magnetometer"
    cols = ACC_COLS if t.kind == "acc" else MAG_COLS
    for i, c in enumerate(cols):
        k = f"_{c}"
        v = data[:, keys.index(k)]
        where = _column_text(k, wanted[k], names)
        bits = t.signed_bits
        if bits:
            bad = (v < -2.0 ** (bits - 1)) | (v >= 2.0 ** bits)
            if bad.any():
                r = int(np.argmax(bad))
                raise DataError(f"{path}:{line_no[r]}: {where}: {v[r]:.10g} is no {t.counts} count "
                                f"({-2 ** (bits - 1)} ... {2 ** bits - 1}, the upper half read as negative): check "
                                f"[{section}] counts and columns")
            continue
        if t.counts is not None or t.zero or len(v) < 3 or v.min() < 0 or np.any(v != np.round(v)):
            continue
        n = next((b for b in SIGNED_WIDTHS if v.max() < 2.0 ** b), None)
        if n is None:
            continue
        half = 2.0 ** (n - 1)
        upper = v >= half
        if min(upper.sum(), (~upper).sum()) < max(3, 0.01 * len(v)):  # both halves of the word read, not a glitch
            continue
        w = np.where(upper, v - 2.0 ** n, v)
        if np.std(w) < SIGNED_SPREAD * np.std(v):
            r = int(np.argmax(upper))
            raise DataError(
                f"{path}: {where}: {upper.mean():.0%} of its counts read {half:.0f} or more and the rest "
                f"near 0, few between: {n}-bit two's-complement counts read as unsigned (line {line_no[r]}: "
                f"{v[r]:.0f} is {w[r]:.0f}); declare them: counts = \"int{n}\" in [{section}] (or counts = "
                f"\"uint{n}\" if they are unsigned)")


STAMP_MAX_S = 9e9  # a stamp's whole seconds beyond this (year 2255 as Unix time) do not fit int64 nanoseconds
STAMP_SHARED = 0.5  # a time column of whole seconds shared by more than this share of the rows with the row before:
                    # the stamp's fraction of a second in a column of its own (ROS 2's header.stamp.sec, .nanosec)
STAMP_RISING = 0.9  # ... the column after it, joined as its nanoseconds, rises on at least this share of the rows
STAMP_SPAN = (0.3, 3.0)  # ... and its median step within a second x the rows a second is this share of a second
                         # (ROS 2 at 100 Hz: 1e7 ns x 100 rows = 1; a sample index 0..99 within the second: 1e-7)


def _cell_text(j: int, names) -> str:
    """A column as a description names it: its name (JSON) or its number."""
    return json.dumps(names[j].strip()) if names is not None else str(j + 1)


def _join_stamp(data, keys, line_no, names, wanted, path, absolute_time, time_origin):
    """A stamp in two columns, whole seconds and nanoseconds (ROS 2's
    header.stamp.sec and .nanosec, ROS 1's .secs and .nsecs), joined into one
    time exactly: integer nanoseconds from a whole second, then seconds as
    float64 (sec + nanosec x 1e-9 as float64 rounds an epoch stamp to 0.24 us;
    counted from the first row it keeps the nanosecond over 104 days).  From
    the first row's time; with absolute_time from the whole second
    time_origin (the log's, when a second file is paired with it; else this
    file's first).  A nanoseconds cell outside 0 ... 999 999 999, or a
    seconds cell that is not a whole number, is refused naming its line (the
    columns swapped, or not the stamp's).  (data with the one time column,
    keys, the whole second the times count from, or None)."""
    i_s, i_ns = keys.index("t_s"), keys.index("t_ns")
    sec, ns = data[:, i_s], data[:, i_ns]
    s_text, ns_text = _column_text("t_s", wanted["t_s"], names), _column_text("t_ns", wanted["t_ns"], names)
    swap = f"[log] time = [{_cell_text(wanted['t_ns'], names)}, {_cell_text(wanted['t_s'], names)}]"
    bad = (ns != np.round(ns)) | (ns < 0) | (ns >= NS_PER_S)
    if bad.any():
        r = int(np.argmax(bad))
        swapped = ns[r] >= NS_PER_S and np.all((sec == np.round(sec)) & (sec >= 0) & (sec < NS_PER_S))
        raise DataError(f"{path}:{line_no[r]}: {ns_text}: {ns[r]:.10g} is no nanoseconds of a second (a stamp's "
                        f"nanoseconds read 0 ... 999 999 999): "
                        + (f"the two columns swapped? time = [whole seconds, nanoseconds]: {swap}" if swapped else
                           "not the stamp's nanoseconds column? [log] time = [whole seconds, nanoseconds]"))
    bad = (sec != np.round(sec)) | (np.abs(sec) > STAMP_MAX_S)
    if bad.any():
        r = int(np.argmax(bad))
        raise DataError(f"{path}:{line_no[r]}: {s_text}: {sec[r]:.10g} is no whole second: a stamp in two columns is "
                        f"[whole seconds, nanoseconds]; a time in one column is [log] time = its column alone, with "
                        f"its time_unit")
    origin = int(sec[0]) if time_origin is None else int(time_origin)
    total = (sec.astype(np.int64) - origin) * NS_PER_S + ns.astype(np.int64)
    if not absolute_time:
        total = total - total[0]
    data = data.copy()
    data[:, i_s] = total / 1e9
    return np.delete(data, i_ns, axis=1), [k for k in keys if k != "t_ns"], (origin if absolute_time else None)


def _whole_second_stamp(t, cells, j: int, names, path: str) -> None:
    """A time column of whole seconds that most rows share with the row
    before (more than STAMP_SHARED), and the column after it reading the
    nanoseconds of each (whole numbers 0 ... 999 999 999 that, joined to the
    seconds, rise on STAMP_RISING of the rows, never go back, and spread the
    rows of a second over it, STAMP_SPAN): a stamp in
    two columns (ros2 topic echo --csv writes header.stamp.sec and
    .nanosec) read as its seconds alone, every row's time cut to its second.
    Refused with the line that reads it whole."""
    n = len(t)
    if n < 10 or np.any(t != np.round(t)):
        return
    steps = np.diff(t)
    if np.any(steps < 0) or not np.mean(steps == 0) > STAMP_SHARED:
        return
    try:
        pairs = [(float(c[j]), float(c[j + 1])) for c in cells if len(c) > j + 1]
    except ValueError:
        return
    if len(pairs) < 10:
        return
    sec, ns = np.array(pairs).T
    if np.any(ns != np.round(ns)) or np.any(ns < 0) or np.any(ns >= NS_PER_S):
        return
    joined = np.diff((sec - sec[0]) * NS_PER_S + ns)
    if np.any(joined < 0) or np.mean(joined > 0) < STAMP_RISING:
        return
    within = joined[(np.diff(sec) == 0) & (joined > 0)]
    rows_a_second = len(steps) / max(1, np.count_nonzero(steps))
    if within.size == 0 or not STAMP_SPAN[0] <= np.median(within) * rows_a_second / NS_PER_S <= STAMP_SPAN[1]:
        return  # the rows of a second do not spread over it: no nanoseconds (a sample index within the second)
    raise DataError(f"{path}: the time column {_cell_text(j, names)} holds whole seconds, {np.mean(steps == 0):.0%} of "
                    f"the rows sharing theirs with the row before, and the column after it, {_cell_text(j + 1, names)}, "
                    f"the nanoseconds of each (0 ... 999 999 999): a stamp in two columns (ROS 2's header.stamp.sec "
                    f"and .nanosec, ROS 1's .secs and .nsecs), read as its seconds alone; read it whole: [log] time = "
                    f"[{_cell_text(j, names)}, {_cell_text(j + 1, names)}]")


FILLER_MIN_ROWS = 10  # identical rows, time stamp and all, that are no samples
FILLER_MIN_ROWS_UNTIMED = 1000  # ... without a time column (a sensor at rest in coarse counts repeats a few rows)
STUCK_MIN_ROWS = 100  # a time stamp repeated on this many rows (and 20x its usual run) has stopped
COUNTER_MAX = {16: "a 16-bit counter's maximum", 31: "a 31-bit counter's maximum",
               32: "a 32-bit counter's maximum", 64: "a 64-bit counter's maximum"}


def _counter_max(t: float) -> str:
    """'(2^32 - 1 thousandths: a 32-bit counter's maximum)' when a time as
    logged is 2^k - 1 in a decimal subunit, else ''."""
    for k, what in COUNTER_MAX.items():
        for j in range(10):
            if math.isclose(t * 10.0 ** j, 2.0 ** k - 1, rel_tol=1e-12, abs_tol=1e-6):
                sub = ("", " tenths", " hundredths", " thousandths", " ten-thousandths")[j] if j < 5 else f" 1e-{j}"
                return f" (2^{k} - 1{sub}: {what}, the value of a counter that is not counting)"
    return ""


def _runs(same: np.ndarray) -> list:
    """[(start, stop)) of the runs of rows each equal to the one before (same[i]: row i + 1 equals row i)."""
    edges = np.flatnonzero(np.diff(np.r_[0, same.astype(np.int8), 0]))
    return [(int(a), int(b) + 1) for a, b in zip(edges[::2], edges[1::2])]


def _filler(data, keys, line_no, read, path, drop_bad, dropped):
    """Rows a logger wrote that are no samples: a run of rows identical in
    every used column with the time stamp and all (a buffer's filler, a
    counter's 0xFFFF..), or a time stamp that stops (the same on many more
    rows than its usual run).  Refused naming the lines and the fix; with
    drop_bad dropped and counted.  None when there are none, else the
    indices of the rows to keep."""
    n = len(data)
    if n < 2:
        return None
    timed = "t_s" in keys
    found = []  # (start, stop, what)
    same = np.all(data[1:] == data[:-1], axis=1)
    least = FILLER_MIN_ROWS if timed else FILLER_MIN_ROWS_UNTIMED
    for a, b in _runs(same):
        if b - a >= least:
            t = f" with the time stuck at {data[a, keys.index('t_s')]:.10g}" if timed else ""
            found.append((a, b, f"repeat one row{t}{_counter_max(data[a, keys.index('t_s')]) if timed else ''}"))
    if timed:
        tcol = data[:, keys.index("t_s")]
        runs = _runs(tcol[1:] == tcol[:-1])
        usual = float(np.median(np.diff(np.r_[0, np.flatnonzero(tcol[1:] != tcol[:-1]) + 1, n])))  # rows a stamp
        for a, b in runs:
            if b - a >= max(STUCK_MIN_ROWS, 20 * usual) and not any(a < fb and fa < b for fa, fb, _ in found):
                found.append((a, b, f"share one time stamp, {tcol[a]:.10g}{_counter_max(tcol[a])}: the time stops"))
    if not found:
        return None
    found.sort(key=lambda r: r[0] - r[1])  # the longest first
    a, b, what = found[0]
    rows = sum(fb - fa for fa, fb, _ in found)
    more = (f" (and {len(found) - 1} more such run{'s' if len(found) > 2 else ''}, {rows} rows in all)"
            if len(found) > 1 else "")
    if not drop_bad:
        raise DataError(f"{path}:{line_no[a]}-{line_no[b - 1]}: {b - a} rows ({(b - a) / max(read, 1):.0%} of the rows "
                        f"read) {what}{more}: no samples (a logger's filler, or its clock stopped), and read as "
                        f"readings they would pass for the sensor's; drop them: --drop-bad-rows ([log] bad_rows = "
                        f"\"drop\"), or cut them from the log")
    keep = np.ones(n, bool)
    for fa, fb, fwhat in found:
        keep[fa:fb] = False
        dropped[f"filler: rows that {fwhat} (lines {line_no[fa]}-{line_no[fb - 1]})"] = fb - fa
    if not keep.any():
        raise DataError(f"{path}: no usable data rows: every row is filler ({what})")
    return np.flatnonzero(keep)


INTERLEAVE_MIN_ROWS = 20
INTERLEAVE_MAX = 4  # sensors (or instances of one) taking turns row by row that are looked for
INTERLEAVE_RATIO = 0.5  # row i nearer row i + k than row i + 1 by this factor (median |difference| of the triad)
INTERLEAVE_CELLS = 400  # rows whose cells are searched for the column that tells the sensors apart


def _interleaved(data, keys, desc: SensorDescription, cells, used: set, names, path: str) -> None:
    """Rows of k sensors, or k instances of one, taking turns in one log (an
    ArduPilot IMU message of two IMUs, I = 0 and 1, written one after the
    other): a triad's reading lies nearer the one k rows on than the next
    (one sensor's readings change with time, so a reading k rows on, later,
    is never much nearer than the next: noise alike, motion further), the
    median |difference| INTERLEAVE_RATIO or less.  Read as one sensor the
    log jumps between the sensors' offsets every row, and its time column
    steps by a fraction of the period (the time unit then misjudged by the
    checks, two files paired on no sample).  Refused, naming the column whose
    values take turns with the same period, when one does, and the keep
    that reads one sensor."""
    n = len(data)
    if n < INTERLEAVE_MIN_ROWS:
        return
    for t in desc.triads:
        cols = ACC_COLS if t.kind == "acc" else MAG_COLS
        v = data[:, [keys.index(f"_{c}") for c in cols]]
        d1 = float(np.median(np.linalg.norm(v[1:] - v[:-1], axis=1)))
        if not d1 > 0:
            continue
        for k in range(2, INTERLEAVE_MAX + 1):
            if n < k * INTERLEAVE_MIN_ROWS // 2:
                break
            dk = float(np.median(np.linalg.norm(v[k:] - v[:-k], axis=1)))
            if dk > INTERLEAVE_RATIO * d1 or np.array_equal(v[k:], v[:-k]):
                continue  # (rows that repeat a cycle exactly carry no sensor's noise: a made-up log, not k sensors)
            section = "accelerometer" if t.kind == "acc" else "magnetometer"
            col = _turn_column(cells, used, k, names)
            fix = (f"keep the rows of one: [log] keep = {{ {col[0]} = [{json.dumps(col[1])}] }} (its column "
                   f"{col[0]} takes turns with them)" if col else
                   "keep the rows of one ([log] keep = { COLUMN = [\"VALUE\"] } on a column that tells them "
                   "apart), or export one sensor alone")
            raise DataError(f"{path}: the {section}'s readings come back every {k} rows: a row lies a median "
                            f"{dk:.4g} from the row {k} on and {d1:.4g} (in the logged unit) from the next: rows of "
                            f"{k} sensors, or {k} instances of one, taking turns in one log, read as one sensor "
                            f"that jumps between their offsets every row; {fix}")


def _turn_column(cells, used: set, k: int, names):
    """(name, the first row's value) of a column not read whose values
    repeat every k rows, the k of a turn all different (an instance
    number), else None."""
    if len(cells) < 2 * k:
        return None
    width = min(len(c) for c in cells)
    for j in range(width):
        if j in used:
            continue
        col = [c[j] for c in cells]
        if not all(_instance(x) for x in col[:k]):
            continue
        if len(set(col[:k])) == k and all(col[i] == col[i + k] for i in range(len(col) - k)):
            name = names[j].strip() if names is not None else None
            if name and re.fullmatch(r"[A-Za-z_][A-Za-z0-9_]*", name):
                return name, col[0]
            return (json.dumps(name) if name else str(j + 1)), col[0]
    return None


def _instance(text: str) -> bool:
    """Whether a cell reads as a sensor's number or name: a whole number
    0-255, or a word (not a reading)."""
    if re.fullmatch(r"\d{1,3}", text):
        return int(text) < 256
    return bool(re.fullmatch(r"[A-Za-z_][\w.-]*", text))


def _triads_in_turn(missing_rows: dict, desc: SensorDescription, kept: int, path: str) -> str:
    """The cause when most rows hold one triad and not the other (two
    sensors' streams at their own times in one file, a row for each sample
    of either, the other's cells empty: PlotJuggler's CSV of two ROS
    topics, a logger writing each sensor as it reads it): the two are never
    read together, and a row with both is a coincidence of their clocks.
    The fix reads the other triad from the same file and pairs it by time;
    '' when the rows are not so."""
    if len(desc.triads) != 2 or desc.time is None:
        return ""
    gone = {}
    for cols, (n, _, _) in missing_rows.items():
        kinds = {"acc" if c.lstrip("_") in ACC_COLS else "mag" for c in cols
                 if c.startswith("_") and c.lstrip("_") not in GYRO_COLS}
        if len(kinds) == 1:
            k = kinds.pop()
            gone[k] = gone.get(k, 0) + n
    if len(gone) < 2 or min(gone.values()) <= kept:
        return ""
    return (f"{gone['acc']} rows hold no accelerometer reading and {gone['mag']} no magnetometer reading, "
            f"{kept} both: the two sensors' samples at their own times, one to a row (two streams in one file); "
            f"pair them by time: [magnetometer] file = {json.dumps(os.path.basename(path))} (this log again: its rows "
            f"with a magnetometer reading, paired with the others' nearest in time)")


def _check_poses(desc: SensorDescription, path: str) -> None:
    """Poses with a magnetometer need the azimuth (docs/dataset.md): without
    it no pose tells the magnetometer's reference direction, and the pose
    fits (calibrate, diagnose) would run without poses unasked."""
    p = desc.poses
    if not p or desc.mag is None:
        return
    if "label" in p:
        lacking = sorted(k for k, v in p["labels"].items() if "azi" not in v)
        if lacking:
            raise DataError(f"{desc.path or 'sensor description'}: [poses.labels]: poses incomplete: no azi for "
                            f"{', '.join(lacking[:5])}{' ...' if len(lacking) > 5 else ''}; with a magnetometer every "
                            f"pose needs its azimuth (azi = deg), or leave [poses] out to calibrate without poses")
    elif "azi" not in p:
        raise DataError(f"{desc.path or 'sensor description'}: [poses]: poses incomplete: no azi column; with a "
                        f"magnetometer the poses need the azimuth (azi = COLUMN), or leave [poses] out to calibrate "
                        f"without poses")


def import_log(path: str, desc: SensorDescription, static: bool | None = None,
               drop_bad_rows: bool | None = None) -> tuple[RawDataset, ImportReport]:
    """Read the log at `path` through the description `desc`: the canonical
    dataset (body frame, g and nT) and what the import did.  drop_bad_rows
    (None: the description's [log].bad_rows) drops malformed rows -- cells
    missing, a cell that is not a number: a line garbled on a serial link --
    and counts them, up to MAX_BAD_ROWS_FRACTION of the rows read; otherwise
    the first one is refused with its line number.  A triad logged to a file
    of its own ([magnetometer] file = ...) is read from that file and its
    samples paired with the log's by time (_pair_by_time)."""
    apart = next((t for t in desc.triads if t.file is not None), None)
    if apart is not None:
        _check_poses(desc, path)
        return _import_apart(path, desc, apart, static, drop_bad_rows)
    return _read(path, desc, static, drop_bad_rows)


def _encoding(path: str) -> str:
    """The text encoding of a log: UTF-16 or UTF-32 where its byte-order mark
    says so (a serial log redirected by Windows PowerShell, "> log.csv", is
    UTF-16 with its mark, and was refused as "not UTF-8 text (byte 0xFF
    ...)"), else UTF-8 (a UTF-8 mark taken off)."""
    with open(path, "rb") as raw:
        bom = raw.read(4)
    return ("utf-32" if bom in (b"\xff\xfe\x00\x00", b"\x00\x00\xfe\xff") else
            "utf-16" if bom[:2] in (b"\xff\xfe", b"\xfe\xff") else "utf-8-sig")


def _read(path: str, desc: SensorDescription, static, drop_bad_rows, absolute_time: bool = False,
          time_origin: int | None = None):
    try:
        size = os.path.getsize(path)
        f = open(path, newline="", encoding=_encoding(path))
    except OSError as e:
        raise DataError(f"cannot read {path}: {e.strerror}") from None
    if size > MAX_LOG_BYTES:
        raise DataError(f"{path}: {size} bytes; the import reads at most {MAX_LOG_BYTES} bytes")
    with f:
        lines = dataset._Lines(f, path)
        drop = desc.bad_rows == "drop" if drop_bad_rows is None else bool(drop_bad_rows)
        return _import(lines, path, desc, static, drop, absolute_time, time_origin)


def _import(lines, path: str, desc: SensorDescription, static, drop_bad=False, absolute_time: bool = False,
            time_origin: int | None = None) -> tuple[RawDataset, ImportReport]:
    skipped = []  # the lines skip_rows skipped, with their numbers: one of them may be the header line
    for _ in range(desc.skip_rows):
        line = next(lines, None)
        if line is None:
            break
        skipped.append((lines.lineno, line.rstrip("\r\n")))
    comment = desc.comment or None
    first = None
    log_meta = {}  # a canonical header's '# key=value' lines before the names: the site's field, dip, ...
    for line in lines:
        if not line.strip() or (comment and line.lstrip().startswith(comment)):
            body = line.strip()
            if body.startswith("#") and "=" in body:
                k, v = (t.strip() for t in body.lstrip("#").split("=", 1))
                if k in LOG_META:
                    log_meta[k] = dataset._meta_value(k, v, path, lines.lineno)
            continue
        first = line.rstrip("\r\n")
        break
    if first is None:
        raise DataError(f"{path}: no data")
    unbracket = str.maketrans("", "", desc.strip)
    first = first.translate(unbracket)
    for t in desc.triads:  # unit = "field" with no [header] field_nT: the log's own field_nT line gives it
        if t.unit == FIELD_UNIT and t.scale is None:
            if "field_nT" not in log_meta:
                raise DataError(f"{desc.path or 'sensor description'}: [magnetometer] unit = \"field\" (1.0 = the "
                                f"site's total field) needs that field: [header] field_nT = ... in the description "
                                f"(or a '# field_nT=' line in the log)")
            desc = dataclasses.replace(desc, mag=dataclasses.replace(t, scale=float(log_meta["field_nT"])))
    delim = _line_delimiter(first, desc)
    names = _split(first, delim) if desc.has_header else None
    header_line = lines.lineno
    labelled = _labels(_split(first, delim))
    if labelled is not None:  # every cell "label:value" (Arduino's Serial Plotter): the labels name the columns
        names = labelled
    width = len(names) if names is not None else len(_split(first, delim))
    width_min = width  # a header's trailing empty names (a delimiter after its last name) need no cell
    while names is not None and width_min > 1 and not names[width_min - 1].strip():
        width_min -= 1
    if names is not None:
        _check_split(first, delim, names, desc, path, header_line)
    notes = []
    if len(desc.triads) == 2:
        if names is not None:
            stripped = {n.strip().lower() for n in names}
            absent = [t for t in desc.triads if not any(
                (c.lower() in stripped) if isinstance(c, str) else 1 <= c <= len(names) for c in t.columns)]
        else:  # no header line: a triad whose columns are names (or numbers past the row) is not in the log
            absent = [t for t in desc.triads if not any(isinstance(c, int) and 1 <= c <= width for c in t.columns)]
        preset = len(absent) == 1 and bool(desc.preset or absent[0].kind in desc.from_preset)
        if len(absent) == 1 and (names is not None or preset):
            section = "magnetometer" if absent[0].kind == "mag" else "accelerometer"
            other = "accelerometer" if section == "magnetometer" else "magnetometer"
            cols = ", ".join(str(c) for c in absent[0].columns)
            if not preset:  # the user's own description names the triad: the log does not have it
                raise DataError(f"{path}:{header_line}: none of the [{section}] columns ({cols}) is in the log "
                                f"(its columns: {', '.join(n.strip() for n in names[:20])}): a log of the {other} "
                                f"alone? leave the [{section}] table out of the sensor description")
            desc = dataclasses.replace(desc, **{absent[0].kind: None})
            # (a file with preset = ... and no [section] table of its own: the preset's table, its columns not in
            # this log, is left out as a preset given by name leaves it out)
            notes.append(f"no {section} columns ({cols}) in the log"
                         + (" (it has no header line to name them)" if names is None else "")
                         + f": the {other} alone is imported"
                         + (f" (the [{section}] table is the preset's; give one of your own to import it)"
                            if absent[0].kind in desc.from_preset else ""))
    if names is not None and _header_is_data(names):
        # header = true on a log without a header line, its columns by number: its first data row was read as the
        # names and left out in silence (mikoff/imu-calib's MPU-9150 logs, "-8.42090 0.06710 5.24511 ...")
        shown = [n.strip() for n in names if n.strip()]
        notes.append(f"the line read as the header ({path}:{header_line}: {', '.join(shown[:6])}"
                     f"{' ...' if len(shown) > 6 else ''}) is numbers: a data row, not imported; if the log has no "
                     f"header line, [log] header = false (the columns by number)")
    if names is not None:
        _skipped_header(skipped, names, desc, path, header_line)
    _check_poses(desc, path)
    wanted = {}  # canonical name -> (index, what)
    axis_of = {}  # a log column -> the sensor axis that reads it
    section = {"acc": "accelerometer", "mag": "magnetometer", "gyro": "gyroscope"}
    for t in desc.triads + ((desc.gyro,) if desc.gyro is not None else ()):
        cols = {"acc": ACC_COLS, "mag": MAG_COLS, "gyro": GYRO_COLS}[t.kind]
        for k, c in enumerate(t.columns):
            what = f"[{section[t.kind]}].columns[{k + 1}]"
            j = _index(c, names, what, path, header_line)
            if j in axis_of:
                # one column read as two sensor axes (a triad's columns copied into the other's table, or one
                # typed twice): the magnetometer read as the accelerometer too had imported, its dip -90 deg on
                # every row; a triad with a column twice, its third axis a copy of its second
                col = f"column {j + 1}" + (f" ({names[j].strip()!r})" if names is not None else "")
                raise DataError(f"{desc.path or 'sensor description'}: {what} and {axis_of[j]} both read {col} of "
                                f"{path}: one column is one sensor axis; give each axis its own column")
            axis_of[j] = what
            wanted[f"_{cols[k]}"] = j
    if split_stamp(desc.time):  # whole seconds and nanoseconds: joined exactly below (_join_stamp)
        wanted["t_s"] = _index(desc.time[0], names, "[log].time[1] (whole seconds)", path, header_line)
        wanted["t_ns"] = _index(desc.time[1], names, "[log].time[2] (nanoseconds)", path, header_line)
    elif desc.time is not None:
        wanted["t_s"] = _index(desc.time, names, "[log].time", path, header_line)
    if desc.temperature is not None:
        wanted["temp_c"] = _index(desc.temperature, names, "[log].temperature", path, header_line)
    label_idx = None
    if desc.poses:
        if "label" in desc.poses:
            label_idx = _index(desc.poses["label"], names, "[poses].label", path, header_line)
        else:
            for k, c in (("inc_deg", "inc"), ("azi_deg", "azi"), ("tf_deg", "tf")):
                if c in desc.poses:
                    wanted[k] = _index(desc.poses[c], names, f"[poses].{c}", path, header_line)
    keep_idx = {}
    if desc.keep:
        for c, vals in desc.keep.items():
            keep_idx[_index(c, names, f"[log].keep.{c}", path, header_line)] = (c, set(v.strip() for v in vals))
    keys = list(wanted)
    idx = [wanted[k] for k in keys]
    rows, labels = [], []
    row_no = []  # each kept row's index among the log's rows read (rate_hz: its time)
    line_no = []  # each kept row's line in the log
    missing_rows = {}  # the used columns a dropped row had no value in -> [rows, first line, last line]
    units_lines = [0]  # a second header line read: not a sample
    clock = [False]  # the time column holds date-times (ISO 8601) or times of day, not numbers
    dropped: dict = {}
    read = 0
    pending = [] if names is not None and labelled is None else [first]
    need = max(idx + list(keep_idx) + ([label_idx] if label_idx is not None else []))
    bad_lines = []  # malformed rows dropped (drop_bad)
    cells_seen = []  # the first kept rows' cells, every column (the column that tells interleaved sensors apart)
    first_row = "the header" if names is not None else "the first row"
    drop_hint = "; a garbled or cut line? [log] bad_rows = \"drop\" (or --drop-bad-rows) drops such rows"

    def take(text, lineno):
        nonlocal read
        cells = _split(text.translate(unbracket), delim)
        if not cells or all(not c.strip() for c in cells):
            return
        if names is not None and [c.strip() for c in cells] == [c.strip() for c in names]:
            # the header line again (logs joined into one file): no sample, dropped and counted
            key = "the header line repeated (logs joined into one file?)"
            dropped[key] = dropped.get(key, 0) + 1
            return
        read += 1
        if labelled is not None:
            cells = _unlabel(cells, labelled, path, lineno, drop_bad)
            if cells is None:
                bad_lines.append(lineno)
                return
        # a row of another length than the header is a cut or garbled line (a value cut short, a decimal
        # comma splitting one), even when the columns used are all there: never read by position; cells
        # past the header's that are empty are trailing delimiters (an Arduino's print(",") after each value)
        n = len(cells)
        while n > width and not cells[n - 1].strip():
            n -= 1
        if need >= n or not width_min <= n <= width:
            if drop_bad:
                bad_lines.append(lineno)
                return
            raise DataError(f"{path}:{lineno}: {n} cells, {first_row} has {width}"
                            + (" (a decimal comma? use a point: 1.5)" if delim == "," else "") + drop_hint)
        for j, (c, vals) in keep_idx.items():
            if cells[j].strip() not in vals:
                dropped[f"{c} not in [log].keep"] = dropped.get(f"{c} not in [log].keep", 0) + 1
                return
        lab = None
        if label_idx is not None:
            lab = cells[label_idx].strip()
            if lab not in desc.poses["labels"]:
                key = f"no pose for label ({desc.poses['label']})"
                dropped[key] = dropped.get(key, 0) + 1
                return
        vals = []
        if not rows and names is not None and not any(_numeric(cells[j]) for j in idx):
            # a second header line right after the names (units, descriptions): no cell a number; or a line of
            # control bytes (a serial link's start-up noise: NULs before the logger's header again), not a header
            key = ("a line of control bytes (a serial link's noise)"
                   if any(ord(ch) < 32 and ch not in "\t\r\n" for ch in text) else
                   "a second header line (units or descriptions)")
            if not dropped.get(key):
                dropped[key] = 1
                units_lines[0] += 1
                return
        missing = [k for k, j in zip(keys, idx) if cells[j].strip().lower() in MISSING]
        if missing:  # dropped and counted by the columns that had no value
            _missed(missing_rows, missing, lineno)
            return
        for k, j in zip(keys, idx):
            text_ = cells[j].strip()
            if desc.decimal == ",":
                text_ = text_.replace(",", ".")
            try:
                if "_" in text_:
                    raise ValueError
                v = float(text_)
            except ValueError:
                v = _clock(text_) if k == "t_s" else None
                if v is not None:
                    clock[0] = True
                    vals.append(v)
                    continue
                hint = (" (a decimal comma? set [log] decimal = \",\" and a delimiter other than the comma)"
                        if re.fullmatch(r"[-+]?\d+,\d+([eE][-+]?\d+)?", text_) else
                        " (a date-time, but not as ISO 8601 writes one: YYYY-MM-DD hh:mm:ss, or hh:mm:ss.sss "
                        "alone; rewrite the column, or time it by [log] rate_hz)"
                        if k == "t_s" and re.fullmatch(r"[\d./ -]+[ T]?\d{1,2}:\d{2}(:\d{2}([.,]\d+)?)?", text_)
                        else _bracket_hint(text_, text))
                if drop_bad and not hint:
                    bad_lines.append(lineno)
                    return
                raise DataError(f"{path}:{lineno}: column {k.lstrip('_')} ({names[j].strip() if names else j + 1}): "
                                f"{text_[:40]!r} is not a number{hint or drop_hint}") from None
            if not math.isfinite(v):
                _missed(missing_rows, [k], lineno)
                return
            vals.append(v)
        rows.append(vals)
        if len(cells_seen) < INTERLEAVE_CELLS:
            cells_seen.append([c.strip() for c in cells])
        labels.append(lab)
        row_no.append(read - 1 - units_lines[0])
        line_no.append(lineno)

    for text in pending:
        take(text, header_line)
    for line in lines:
        if comment and line.lstrip().startswith(comment):
            continue
        take(line.rstrip("\r\n"), lines.lineno)
    if bad_lines:
        if len(bad_lines) > MAX_BAD_ROWS_FRACTION * read:
            raise DataError(f"{path}: {len(bad_lines)} of {read} rows malformed (first at line {bad_lines[0]}): more "
                            f"than {MAX_BAD_ROWS_FRACTION:.0%}, so the description does not fit the log (its "
                            "delimiter, header or columns), nothing a dropped line mends")
        shown = ", ".join(str(n) for n in bad_lines[:5]) + (", ..." if len(bad_lines) > 5 else "")
        dropped[f"malformed: cells missing or not a number (line{'s' if len(bad_lines) > 1 else ''} {shown})"] = \
            len(bad_lines)
    for miss, (n, first_line, last_line) in missing_rows.items():
        where = ", ".join(_column_text(k, wanted[k], names) for k in miss)
        lines_ = f"line {first_line}" if n == 1 else f"lines {first_line} ... {last_line}"
        dropped[f"a missing value in {where} ({lines_})"] = n
    turns = _triads_in_turn(missing_rows, desc, len(rows), path)
    if not rows:
        raise DataError(f"{path}: no usable data rows ({read} read; dropped: "
                        + (", ".join(f"{n} for {r}" for r, n in dropped.items()) or "none") + ")"
                        + (f"; {turns}" if turns else ""))
    if turns:
        notes.append(turns)
    data = np.array(rows, float)
    origin = None
    if "t_ns" in keys:  # a stamp in two columns: one time, exact to the nanosecond, before anything reads it
        data, keys, origin = _join_stamp(data, keys, line_no, names, wanted, path, absolute_time, time_origin)
    elif "t_s" in keys and not clock[0]:
        _whole_second_stamp(data[:, keys.index("t_s")], cells_seen, wanted["t_s"], names, path)
    for t in desc.triads:
        _check_counts(t, data, keys, line_no, names, wanted, path)
    keep_rows = _filler(data, keys, line_no, read, path, drop_bad, dropped)
    _interleaved(data if keep_rows is None else data[keep_rows], keys, desc,
                 cells_seen if keep_rows is None else [cells_seen[i] for i in keep_rows if i < len(cells_seen)],
                 set(idx) | set(keep_idx), names, path)
    if keep_rows is not None:
        data = data[keep_rows]
        labels = [labels[i] for i in keep_rows]
        row_no = [row_no[i] for i in keep_rows]
        line_no = [line_no[i] for i in keep_rows]
    col = {k: data[:, i] for i, k in enumerate(keys)}
    out = {}
    # a triad logged out of step ([section].lag = k: its row i + k belongs to row i):
    # the rows without a partner at either end are dropped
    lo, hi = _lag_bounds([t.lag for t in desc.triads], len(data), path, dropped)
    for t in desc.triads:
        cols = ACC_COLS if t.kind == "acc" else MAG_COLS
        raw = np.stack([col[f"_{c}"] for c in cols], -1)[lo + t.lag:hi + t.lag]
        body = t.convert(raw)
        for i, c in enumerate(cols):
            out[c] = np.ascontiguousarray(body[:, i])
    if desc.gyro is not None:  # the log's own rows (no lag of its own): body frame, deg/s
        raw = np.stack([col[f"_{c}"] for c in GYRO_COLS], -1)[lo:hi]
        body = desc.gyro.convert(raw)
        for i, c in enumerate(GYRO_COLS):
            out[c] = np.ascontiguousarray(body[:, i])
    col = {k: v[lo:hi] for k, v in col.items()}
    labels = labels[lo:hi]
    if desc.rate_hz is not None:
        # no time column, a known rate: a row's index among the rows read (dropped ones too, so a dropped
        # row leaves a gap) over the rate
        out["t_s"] = np.asarray(row_no[lo:hi], float) / desc.rate_hz
    if "t_s" in col:
        # date-times are seconds since the first row; numbers in the declared time unit
        # (absolute_time: date-times kept as their own seconds, for pairing two files by time)
        if clock[0]:
            out["t_s"] = col["t_s"] if absolute_time else col["t_s"] - col["t_s"][0]
        else:
            out["t_s"] = col["t_s"] * desc.time_scale
            if absolute_time and time_origin is not None and origin is None:
                out["t_s"] = out["t_s"] - time_origin  # on the clock of the log's stamp in two columns (pairing)
    if "temp_c" in col:
        # degrees C from the declared unit (C, K, F, or counts: T = offset + counts x lsb)
        out["temp_c"] = col["temp_c"] * desc.temperature_scale + desc.temperature_offset
    if label_idx is not None:
        lab = desc.poses["labels"]
        out["inc_deg"] = np.array([float(lab[x]["inc"]) for x in labels]) * desc.pose_scale
        out["tf_deg"] = np.array([float(lab[x].get("tf", 0.0)) for x in labels]) * desc.pose_scale
        if all("azi" in lab[x] for x in labels):
            out["azi_deg"] = np.array([float(lab[x]["azi"]) for x in labels]) * desc.pose_scale
    else:
        for k in ("inc_deg", "azi_deg", "tf_deg"):
            if k in col:
                out[k] = col[k] * desc.pose_scale
    meta = dict(log_meta)  # the description's [header] below overrides the log's own
    for k, v in desc.header.items():
        if k not in dataset.META_KEYS or k in dataset.SENSOR_META:
            raise DataError(f"{desc.path or 'sensor description'}: [header].{k} is not a dataset header key "
                            f"({', '.join(k for k in dataset.META_KEYS if k not in dataset.SENSOR_META)})")
        if k in dataset.NUMERIC_META:
            if isinstance(v, bool) or not isinstance(v, (int, float)):
                raise DataError(f"[header].{k}: a number")
            dataset.check_meta(k, float(v), f"[header].{k}")
            v = float(v)
        meta[k] = v
    meta.update(desc.header_meta())
    if clock[0]:
        meta["time_unit"] = "date-time"  # seconds from the first row's date-time: no unit to declare
    if static is not None:
        meta["static"] = "true" if static else "false"
    meta["source"] = path
    meta["log_sha256"] = _sha256(path)
    if dropped:
        meta["rows_dropped"] = "; ".join(f"{n} ({r})" for r, n in dropped.items())
    ds = RawDataset(out, meta)
    # the values the canonical format's rules refuse (poses, temperature) are refused here too
    _check(ds, path)
    rep = ImportReport(log=path, sensor=desc.name, rows_read=read, rows=len(ds), dropped=dropped, triads=ds.triads,
                       notes=notes, row_index=row_no[lo:hi], time_origin=origin)
    return ds, rep


def _lag_bounds(lags: list, n: int, path: str, dropped: dict) -> tuple:
    """The rows [lo, hi) that keep a partner in every triad when each triad's
    row i + lag belongs to row i (a triad logged out of step): the rows
    without one, at either end, counted in `dropped`."""
    lo, hi = -min(0, min(lags)), n - max(0, max(lags))
    if hi - lo < 1:
        raise DataError(f"{path}: no rows left after the lag of {max(lags, key=abs)} rows")
    if lo or hi < n:
        dropped["a triad's lag (rows without a partner)"] = n - (hi - lo)
    return lo, hi


PAIR_TOLERANCE = 0.75  # a sample paired with the other file's nearest only within this many of its median periods


def _import_apart(path: str, desc: SensorDescription, apart, static, drop_bad_rows):
    """The log with one triad (and its time, temperature, poses), the other
    triad from the file its table names: each read through the description
    on its own (the same [log] rules; its own time column), then paired by
    time (_pair_by_time) or, without one, row by row (_pair_by_row), then
    each triad's lag applied to the rows as paired.  The header records
    both files."""
    other = apart.file if os.path.isabs(apart.file) else os.path.join(os.path.dirname(path), apart.file)
    section = "magnetometer" if apart.kind == "mag" else "accelerometer"
    held = [t for t in desc.triads if t is not apart]
    if not held:
        raise DataError(f"{desc.path or 'sensor description'}: [{section}].file names the file the {section} was "
                        f"logged to, and the log given holds no other triad: import that file itself (leave out "
                        f"file)")
    own = held[0]
    in_log = dataclasses.replace(desc, **{apart.kind: None, own.kind: dataclasses.replace(own, lag=0)})
    # (the gyroscope, if any, is read from the log given, on its rows: as the log's own triad's)
    in_file = dataclasses.replace(desc, **{own.kind: None, apart.kind: dataclasses.replace(apart, lag=0, file=None)},
                                  gyro=None,
                                  time=apart.time, time_unit=apart.time_unit, time_scale=apart.time_scale,
                                  temperature=None, poses=None, keep=None, header={}, static=None)
    if not os.path.isfile(other):
        raise DataError(f"{desc.path or 'sensor description'}: [{section}].file: no file {other} (a relative path is "
                        f"read beside the log)")
    ds_a, rep_a = _read(path, in_log, static, drop_bad_rows, absolute_time=True)
    # a stamp in two columns: both files' times from the log's first whole second (the log's times as they stand
    # otherwise: a second file's stamp in two columns then from 0)
    origin = rep_a.time_origin
    clock_b = 0 if origin is None else origin
    timed_b = None  # paired in order while the log has a time column: the file's own times, if it has that column
    if apart.time is None and desc.time is not None:
        try:
            timed_b = _read(other, dataclasses.replace(in_file, time=desc.time, time_unit=desc.time_unit,
                                                       time_scale=desc.time_scale), None, drop_bad_rows,
                            absolute_time=True, time_origin=clock_b)
        except DataError:
            timed_b = None
    ds_b, rep_b = timed_b if timed_b is not None else _read(other, in_file, None, drop_bad_rows, absolute_time=True,
                                                            time_origin=clock_b)
    if apart.time is not None:
        ia, ib, how, unpaired = _pair_by_time(ds_a, path, "accelerometer" if own.kind == "acc" else "magnetometer",
                                              ds_b, other, section, apart.time_offset)
        if apart.time_offset:
            how += f"; the {section}'s times moved by {apart.time_offset:+.6g} s (time_offset)"
    else:
        ia, ib, how, unpaired = _pair_by_row(rep_a, path, rep_b, other, section)
        if timed_b is not None:
            _rates_in_order(ds_a.columns["t_s"][ia], path, ds_b.columns["t_s"][ib], other, section)
    out = {c: v[ia] for c, v in ds_a.columns.items()}
    for c in ACC_COLS if apart.kind == "acc" else MAG_COLS:
        out[c] = ds_b.columns[c][ib]
    dropped = dict(rep_a.dropped)
    dropped.update({f"{section} file: {r}": n for r, n in rep_b.dropped.items()})
    if unpaired:
        dropped[unpaired[0]] = unpaired[1]
    # each triad's lag, in rows as paired: its row i + lag belongs to row i
    lags = {own.kind: own.lag, apart.kind: apart.lag}
    lo, hi = _lag_bounds(list(lags.values()), len(ia), path, dropped)
    shift = {c: lags["acc"] for c in ACC_COLS} | {c: lags["mag"] for c in MAG_COLS}
    out = {c: v[lo + shift.get(c, 0):hi + shift.get(c, 0)] for c, v in out.items()}
    meta = dict(ds_a.meta)
    meta.update(desc.header_meta())  # both triads' record
    if static is not None:  # the command line's declaration over the description's, as for one file
        meta["static"] = "true" if static else "false"
    if ds_a.meta.get("time_unit") == "date-time":  # seconds from the first row's date-time, as for one file
        meta["time_unit"] = "date-time"
        out["t_s"] = out["t_s"] - out["t_s"][0]
    elif (origin is not None or rep_b.time_origin is not None) and "t_s" in out:
        out["t_s"] = out["t_s"] - out["t_s"][0]  # a stamp in two columns: from the first row, as for one file
    meta["source"] = f"{path} + {other}"
    meta["paired_log_sha256"] = _sha256(other)
    meta["pairing"] = how
    meta.pop("rows_dropped", None)
    if dropped:
        meta["rows_dropped"] = "; ".join(f"{k} ({r})" for r, k in dropped.items())
    ds = RawDataset(out, meta)
    _check(ds, path)
    return ds, ImportReport(log=path, sensor=desc.name, rows_read=rep_a.rows_read, rows=len(ds), dropped=dropped,
                            triads=ds.triads, notes=rep_a.notes + rep_b.notes + [how])


def _pair_by_row(rep_a: ImportReport, path_a: str, rep_b: ImportReport, path_b: str, what_b: str):
    """Two files without time, paired row by row in the order read (row i of
    one with row i of the other; a row dropped from either, for a missing
    value, drops its partner; rows past the shorter file's end are dropped,
    counted): (rows of a, rows of b, the header's pairing line, (reason,
    count) or None)."""
    ra, rb = np.asarray(rep_a.row_index), np.asarray(rep_b.row_index)
    both, ia, ib = np.intersect1d(ra, rb, assume_unique=True, return_indices=True)
    if both.size == 0:
        raise DataError(f"{path_b}: no row pairs with a row of the log")
    how = (f"{what_b} ({path_b}, {rep_b.rows_read} rows read) paired with the log ({path_a}, {rep_a.rows_read} rows "
           f"read) row by row, in order: {both.size} pairs")
    n = max(rep_a.rows_read, rep_b.rows_read) - min(rep_a.rows_read, rep_b.rows_read)
    lost = len(ra) + len(rb) - 2 * both.size
    if rep_a.rows_read != rep_b.rows_read:
        how += (f"; the {'log' if rep_a.rows_read > rep_b.rows_read else what_b + ' file'} has {n} row{'s' if n > 1 else ''} more (its "
                f"last, without a partner: a line lost in one file shifts every row after it, which the checks "
                f"below name)")
    return ia, ib, how, (("rows without a partner in the other file (past its end, or dropped there)", lost)
                         if lost else None)


def _rates_in_order(ta, path_a: str, tb, path_b: str, section: str) -> None:
    """Two files paired row by row whose own time columns say they were
    logged at different rates: row i of one drifts away from row i of the
    other along the log (a phone's accelerometer at 51.08 Hz against its
    magnetometer at 50 Hz: 52 rows apart by the end of 2 400).  Refused from
    a drift of one row, with the fix: pair them by time."""
    if len(ta) < 3 or not (np.all(np.diff(ta) > 0) and np.all(np.diff(tb) > 0)):
        return  # a column that does not rise through the file is not its time: nothing to compare
    span_a, span_b = ta[-1] - ta[0], tb[-1] - tb[0]
    if not (span_a > 0 and span_b > 0):
        return
    ra, rb = (len(ta) - 1) / span_a, (len(tb) - 1) / span_b
    drift = abs(span_a - span_b) * max(ra, rb)  # rows the pairs' time apart changes by, first pair to last
    if drift >= 1.0:
        raise DataError(f"{path_b}: paired with the log row by row, in order ([{section}] time = false), but the two "
                        f"files' own time columns put the log at {ra:.4g} rows/s and this file at {rb:.4g} rows/s: "
                        f"row i of one lies {drift:.0f} rows from row i of the other by the end of the log, so most "
                        f"rows pair two instants apart; pair them by time: leave out [{section}] time = false (a "
                        f"file timed by a clock of its own: [{section}] time_offset)")


def _pair_by_time(a: RawDataset, path_a: str, what_a: str, b: RawDataset, path_b: str, what_b: str,
                  offset: float = 0.0):
    """Two files' samples paired by their time columns (seconds on one
    clock): each sample of the slower (the longer median period; the log's
    on a tie) with the other's nearest in time, kept where they lie within
    PAIR_TOLERANCE of the faster's median period (else a gap, or outside
    the other's span: counted), each sample used once (the nearer pair
    kept).  Every reading stays as measured: no interpolation, no sample
    repeated; `offset` (s) added to b's times first (its clock against a's).
    (rows of a, rows of b, the header's pairing line,
    (reason, count) of the slower's samples left unpaired or None)."""
    ta, tb = a.columns["t_s"], b.columns["t_s"] + offset
    clock_a, clock_b = (d.meta.get("time_unit") == "date-time" for d in (a, b))
    if clock_a != clock_b:
        raise DataError(f"{path_b}: its time column is {'date-times' if clock_b else 'numbers'}, the log's "
                        f"{'date-times' if clock_a else 'numbers'}: the two files must be timed on one clock to be "
                        f"paired")
    for t, p in ((ta, path_a), (tb, path_b)):
        if len(t) < 2:
            raise DataError(f"{p}: {len(t)} row: too few to pair by time")
        back = np.flatnonzero(np.diff(t) < 0)
        if back.size:
            raise DataError(f"{p}: the time column goes back at data row {back[0] + 2} ({t[back[0]]:.6g} s, then "
                            f"{t[back[0] + 1]:.6g} s): two files are paired by time only when each one's times rise")
    lo, hi = max(ta[0], tb[0]), min(ta[-1], tb[-1])
    if hi < lo:
        raise DataError(f"{path_b}: its times ({tb[0]:.6g} ... {tb[-1]:.6g} s) do not overlap the log's "
                        f"({ta[0]:.6g} ... {ta[-1]:.6g} s): not the same clock, or not the same run? (each file's "
                        f"time column and time_unit; a clock of its own: [{what_b}] time_offset = the seconds to add "
                        f"to its times)")
    pa, pb = float(np.median(np.diff(ta))), float(np.median(np.diff(tb)))
    if not (pa > 0 and pb > 0):
        t = ta if pa <= 0 else tb
        steps = np.diff(t)
        whole = ""
        if np.all(t == np.round(t)) and steps.max() > 0 and np.all(np.isin(steps, (0.0, 1.0))):
            # ROS 2's header.stamp as `ros2 topic echo --csv` writes it: sec and nanosec in two columns
            whole = (f" (its times are whole seconds, one step every {len(t) / max(1, np.count_nonzero(steps)):.3g} "
                     f"rows: a stamp whose fraction of a second is in a column of its own, as ROS 2's "
                     f"header.stamp.sec and .nanosec? read the two as one time: [log] time = [the seconds column, "
                     f"the nanoseconds column])")
        raise DataError(f"{path_a if pa <= 0 else path_b}: most rows share their time stamp with the row before: "
                        f"nothing to pair by{whole}")
    slow_is_a = pa >= pb
    ts, tf, pf = (ta, tb, pb) if slow_is_a else (tb, ta, pa)
    j = np.clip(np.searchsorted(tf, ts), 1, len(tf) - 1)
    j -= (ts - tf[j - 1]) <= (tf[j] - ts)           # the nearer of the two around each slow sample
    d = np.abs(tf[j] - ts)
    ok = d <= PAIR_TOLERANCE * pf
    # a faster sample nearest to two slow ones (a gap in the faster): the nearer pair kept
    order = np.lexsort((d, j))
    once = np.zeros(len(ts), bool)
    once[order[np.r_[True, np.diff(j[order]) != 0]]] = True
    keep = np.flatnonzero(ok & once)
    if keep.size == 0:
        raise DataError(f"{path_b}: no sample of the {what_b} within {PAIR_TOLERANCE * pf * 1e3:.3g} ms of a sample "
                        f"of the {what_a}: not the same clock? (each file's time column and time_unit)")
    i_slow, i_fast = keep, j[keep]
    ia, ib = (i_slow, i_fast) if slow_is_a else (i_fast, i_slow)
    slow, fast = (what_a, what_b) if slow_is_a else (what_b, what_a)
    ns, nf = len(ts), len(tf)
    dd = d[keep]
    how = (f"{slow} ({path_a if slow_is_a else path_b}, {ns} rows, {1 / max(pa, pb):.4g} Hz) each paired with the "
           f"{fast}'s nearest in time ({path_b if slow_is_a else path_a}, {nf} rows, {1 / min(pa, pb):.4g} Hz): "
           f"{keep.size} pairs, |dt| median {np.median(dd) * 1e3:.3g} ms, largest {dd.max() * 1e3:.3g} ms")
    lost = ns - keep.size
    unpaired = ((f"{slow} samples with no {fast} sample within {PAIR_TOLERANCE * pf * 1e3:.3g} ms (outside its "
                 f"file's times, or a gap)", lost) if lost else None)
    return ia, ib, how, unpaired


def _check(ds: RawDataset, path: str) -> None:
    for c, v in ds.columns.items():
        bad = ~np.isfinite(v)
        if c in dataset.RULES:
            lo, hi = dataset.RULES[c]
            bad |= (v < lo) | (v > hi)
        if bad.any():
            r = int(np.argmax(bad))
            hint = ("; a temperature logged in K, F or counts: declare it ([log] temperature_unit = \"K\", "
                    "\"F\", or \"counts\" with temperature_lsb and temperature_offset)"
                    if c == "temp_c" and np.isfinite(v[r]) else "")
            raise DataError(f"{path}: row {r + 1} of the data: {c} = {float(v[r]):g} out of range "
                            f"({dataset._rule_text(c) if c in dataset.RULES else 'not finite'}){hint}")
