"""The raw dataset format (CSV) that every tool reads and writes.

    # field_nT=50000
    # dip_deg=60
    t_s,inc_deg,azi_deg,tf_deg,temp_c,ax_g,ay_g,az_g,mx_nT,my_nT,mz_nT
    0,10,30,0,25,...

Optional leading `# key=value` lines (META_KEYS), then a header row with the
columns in any order, extra columns allowed.  Pose columns (turntable
reference) and t_s/temp_c may be absent; the sensor columns hold raw,
uncalibrated readings in nominal units (counts x nominal LSB): both triads,
or one (an accelerometer-only or a magnetometer-only dataset), each triad's
three columns together; optionally a gyroscope's rate (wx_dps, wy_dps,
wz_dps: deg/s, body frame), which only the row-alignment check reads.  The
header may record where the data came from and
the sensor description used (`inclino import`, inclino.formats.sensor).
"""
from __future__ import annotations

import csv
import math
import os
from dataclasses import dataclass, field

import numpy as np

from inclino import progress as _progress
from inclino.errors import DataError

# the sensor description's record (inclino import; docs/dataset.md): resolution,
# noise and range per triad in canonical units, the axis maps and units as
# logged, the declarations (static run, intended reflection), provenance
SENSOR_META = ("sensor", "sensor_sha256", "log_sha256", "acc_axes", "acc_unit", "acc_reads", "mag_axes", "mag_unit",
               "acc_lag_rows", "mag_lag_rows",
               "acc_lsb_g", "acc_noise_g", "acc_range_g", "mag_lsb_nT", "mag_noise_nT", "mag_range_nT",
               "axes_reflection", "reflection", "static", "rows_dropped", "rate_hz", "time_unit",
               "pairing", "paired_log_sha256", "temp_unit", "gyro_axes", "gyro_unit")
META_KEYS = ("field_nT", "dip_deg", "declination_deg", "gravity_g", "lat_deg", "lon_deg",
             "date", "probe_serial", "source", "samples_averaged", "start_utc", "firmware", "calibration_crc",
             "calibration_sequence", "reading_noise_acc_g", "reading_noise_mag_nT", "readings_per_row") + SENSOR_META
NUMERIC_META = {"field_nT", "dip_deg", "declination_deg", "gravity_g", "lat_deg", "lon_deg", "samples_averaged",
                "reading_noise_acc_g", "reading_noise_mag_nT", "readings_per_row",
                "acc_lsb_g", "acc_noise_g", "acc_range_g", "mag_lsb_nT", "mag_noise_nT", "mag_range_nT", "rate_hz"}
ACC_COLS = ("ax_g", "ay_g", "az_g")
MAG_COLS = ("mx_nT", "my_nT", "mz_nT")
SENSOR_COLS = ACC_COLS + MAG_COLS
GYRO_COLS = ("wx_dps", "wy_dps", "wz_dps")  # optional: a gyroscope's angular rate, deg/s, body frame (inclino import)
POSE_COLS = ("inc_deg", "azi_deg", "tf_deg")
ID_COLUMNS = ("pose_id", "segment", "cluster")  # a column naming each row's pose, if present
OPTIONAL_COLS = ("t_s", "temp_c") + POSE_COLS
COLUMN_ORDER = ("t_s",) + POSE_COLS + ("temp_c",) + SENSOR_COLS + GYRO_COLS


@dataclass
class RawDataset:
    columns: dict = field(default_factory=dict)  # name -> float64 array
    meta: dict = field(default_factory=dict)

    def __len__(self) -> int:
        for c in SENSOR_COLS:
            if c in self.columns:
                return len(self.columns[c])
        return len(next(iter(self.columns.values()))) if self.columns else 0

    @property
    def has_acc(self) -> bool:
        return all(c in self.columns for c in ACC_COLS)

    @property
    def has_mag(self) -> bool:
        return all(c in self.columns for c in MAG_COLS)

    @property
    def triads(self) -> str:
        """"both", "acc" or "mag": which triads the dataset holds."""
        return "both" if self.has_acc and self.has_mag else ("acc" if self.has_acc else "mag")

    @property
    def acc(self) -> np.ndarray:
        if not self.has_acc:
            raise DataError("the dataset has no accelerometer columns (ax_g, ay_g, az_g): a magnetometer-only "
                            "dataset")
        return np.stack([self.columns[c] for c in ACC_COLS], axis=-1)

    @property
    def mag(self) -> np.ndarray:
        if not self.has_mag:
            raise DataError("the dataset has no magnetometer columns (mx_nT, my_nT, mz_nT): an accelerometer-only "
                            "dataset")
        return np.stack([self.columns[c] for c in MAG_COLS], axis=-1)

    @property
    def has_gyro(self) -> bool:
        return all(c in self.columns for c in GYRO_COLS)

    @property
    def gyro(self) -> np.ndarray:
        """(n, 3) angular rate, deg/s, body frame (the row-alignment check's only)."""
        if not self.has_gyro:
            raise DataError("the dataset has no gyroscope columns (wx_dps, wy_dps, wz_dps)")
        return np.stack([self.columns[c] for c in GYRO_COLS], axis=-1)

    @property
    def has_pose(self) -> bool:
        return all(c in self.columns for c in POSE_COLS)


# One rule per field: (low, high) inclusive, for the numeric header keys and
# the columns; every value must also be finite.  Pose angles follow
# docs/conventions.md (I in [0, 180], with 5 deg of slack for a turntable
# that reads a little past vertical; A and T are wrapped, any turn within one
# revolution either way is accepted).
RULES = {
    "field_nT": (1e-3, 200_000.0),   # > 0; beyond what the +-100 000 nT fluxgate axes can measure
    "dip_deg": (-90.0, 90.0),
    "declination_deg": (-360.0, 360.0),
    "gravity_g": (1e-3, 2.0),        # > 0, within the accelerometer's +-1.7 g
    "lat_deg": (-90.0, 90.0),
    "lon_deg": (-360.0, 360.0),
    "inc_deg": (-5.0, 185.0),
    "azi_deg": (-360.0, 360.0),
    "tf_deg": (-360.0, 360.0),
    "temp_c": (-100.0, 300.0),
    "samples_averaged": (1.0, 1_000_000.0),  # sensor samples per reading (the probe's, recorded by acquire)
    "reading_noise_acc_g": (0.0, 1.0),  # 1 sigma of one reading per axis, measured by acquire at each pose
    "reading_noise_mag_nT": (0.0, 100_000.0),
    "readings_per_row": (1.0, 1000.0),  # readings averaged into one row (acquire's stability window)
    # the sensor description's figures (> 0; generous bounds: any part a log could come from)
    "acc_lsb_g": (1e-3, 1.0), "acc_noise_g": (1e-3, 1.0), "acc_range_g": (1e-3, 1000.0),
    "mag_lsb_nT": (1e-3, 1e6), "mag_noise_nT": (1e-3, 1e6), "mag_range_nT": (1e-3, 1e9),
    "rate_hz": (1e-3, 1e9),  # the sample rate a log's rows were read at, when it has no time column
}
POSITIVE = {"field_nT", "gravity_g", "acc_lsb_g", "acc_noise_g", "acc_range_g", "mag_lsb_nT", "mag_noise_nT",
            "mag_range_nT", "rate_hz"}  # > 0: the lower bound in RULES is only a placeholder
MAX_LINE_CHARS = 1 << 20  # a longer line is refused (bounded reading of a hostile file)
CHUNK_ROWS = 1 << 16


def _rule_text(key: str) -> str:
    lo, hi = RULES[key]
    if key in POSITIVE:
        return f"must be > 0 and <= {hi:g}"
    return f"must be within [{lo:g}, {hi:g}]"


def _in_rule(key: str, v: float) -> bool:
    lo, hi = RULES[key]
    return (v > 0 if key in POSITIVE else v >= lo) and v <= hi


def check_meta(key: str, value, what: str) -> None:
    """A header value given some other way (a command-line option) obeys the
    header's rule: DataError naming `what`."""
    if value is None or key not in RULES:
        return
    if not (math.isfinite(value) and _in_rule(key, value)):
        raise DataError(f"{what} {value:g} out of range: {key} {_rule_text(key)}")


def _meta_value(key, text, path, lineno):
    if key in NUMERIC_META:
        try:
            v = float(text)
        except ValueError:
            raise DataError(f"{path}:{lineno}: header {key}={text!r} is not a number") from None
        if not math.isfinite(v):
            raise DataError(f"{path}:{lineno}: header {key} is not finite")
        if "_" in text or not text.isascii():
            raise DataError(f"{path}:{lineno}: header {key}={text!r} is not a plain number")
        if not _in_rule(key, v):
            raise DataError(f"{path}:{lineno}: header {key}={text} out of range: {key} {_rule_text(key)}")
        return v
    return text


class _Lines:
    """The file's lines, each bounded, with the current line number."""

    def __init__(self, f, path):
        self.f, self.path, self.lineno, self.chars = f, path, 0, 0
        self.cut = False   # the last line read has no line end: the file stops inside it

    def __iter__(self):
        return self

    def __next__(self) -> str:
        try:
            line = self.f.readline(MAX_LINE_CHARS + 1)
        except UnicodeDecodeError:  # the text layer decodes ahead: find the byte's own line in the file
            from inclino.formats.safeio import utf8_error

            enc = str(getattr(self.f, "encoding", "utf-8")).lower()
            if enc.startswith(("utf-16", "utf-32")):  # a log its byte-order mark says is UTF-16 or UTF-32
                raise DataError(f"{self.path}:{self.lineno + 1}: not {enc.upper()} text from about this line, "
                                f"as its byte-order mark says it is (a byte cut off or garbled)") from None

            where = None
            try:
                where = utf8_error(self.path)
            except OSError:
                pass
            if where is None:
                raise DataError(f"{self.path}:{self.lineno + 1}: not UTF-8 text") from None
            raise DataError(f"{self.path}:{where[0]}: not UTF-8 text (byte 0x{where[2]:02X} at column "
                            f"{where[1]})") from None
        if not line:
            raise StopIteration
        self.lineno += 1
        self.chars += len(line)
        self.cut = not line.endswith(("\n", "\r"))
        if len(line) > MAX_LINE_CHARS:
            raise DataError(f"{self.path}:{self.lineno}: line longer than {MAX_LINE_CHARS} characters")
        return line


def read_raw(path: str, progress: bool = False) -> RawDataset:
    """Read a raw dataset; raise DataError (one line, naming the row and
    column) on any defect.  Streams the file (memory: 8 bytes per value
    kept, plus one chunk), every line bounded.  A data row must have exactly
    as many cells as the header (never read by position: a decimal comma
    or a stray cell is an error naming the row).  progress: show reading
    progress on stderr (inclino.progress)."""
    try:
        f = open(path, newline="", encoding="utf-8-sig")  # -sig: a UTF-8 byte-order mark is dropped
        size = os.fstat(f.fileno()).st_size
    except OSError as e:
        raise DataError(f"cannot read {path}: {e.strerror}") from None
    with f:
        lines = _Lines(f, path)
        bar = _progress.bar(size or None, f"reading {path}", unit="B", quiet=not progress)
        try:
            return _read(lines, path, bar)
        except csv.Error as e:
            raise DataError(f"{path}:{lines.lineno}: {e}") from None
        finally:
            bar.close()


def _read(lines: _Lines, path: str, bar) -> RawDataset:
    meta: dict = {}
    line = None
    for line in lines:
        if line.startswith("#") or not line.strip():
            body = line.lstrip("#").strip()
            if "=" in body:
                k, v = (t.strip() for t in body.split("=", 1))
                if k in META_KEYS:
                    if k in meta:  # never one copy read and the other dropped: which one the file meant is unknown
                        raise DataError(f"{path}:{lines.lineno}: header key {k} given twice ({meta[k]!s} and {v}): "
                                        f"keep the one that is right")
                    meta[k] = _meta_value(k, v, path, lines.lineno)
            line = None
            continue
        break
    if line is None:
        raise DataError(f"{path}: no header row")
    header_line = lines.lineno
    header = [h.strip() for h in next(csv.reader([line]))]
    for cols in (ACC_COLS, MAG_COLS, GYRO_COLS):  # a triad is all three columns or none
        have = [c for c in cols if c in header]
        if have and len(have) < 3:
            raise DataError(f"{path}:{header_line}: missing column(s) {', '.join(c for c in cols if c not in have)} "
                            f"(a triad is three columns)")
    if not any(c in header for c in SENSOR_COLS):
        sep = next((name for ch, name in ((";", "semicolons"), ("\t", "tabs")) if len(header) == 1 and ch in line),
                   None)
        if sep is not None:  # the canonical format is comma-separated: one "column" holding every name
            raise DataError(f"{path}:{header_line}: the header is one column separated by {sep}: a dataset's "
                            f"columns are separated by commas (docs/dataset.md); a log separated otherwise: "
                            f"inclino import LOG --sensor S.toml (its [log] delimiter)")
        raise DataError(f"{path}:{header_line}: missing column(s) {', '.join(SENSOR_COLS)}: no sensor triad (the "
                        f"accelerometer's ax_g, ay_g, az_g and/or the magnetometer's mx_nT, my_nT, mz_nT; a log in "
                        f"other columns or units: inclino import LOG --sensor S.toml)")
    twice = sorted({h for h in header if header.count(h) > 1})
    if twice:  # never read one copy and drop the other: which one the file meant is unknown
        raise DataError(f"{path}:{header_line}: column name repeated in the header: {', '.join(twice)}")
    ncells = len(header)
    wanted = [c for c in COLUMN_ORDER if c in header]
    idx = [header.index(c) for c in wanted]
    chunks = []
    buf = np.empty((CHUNK_ROWS, len(wanted)))
    nos = np.empty(CHUNK_ROWS, dtype=np.int64)
    k = 0
    done = 0

    def flush(k):
        block = buf[:k].copy()
        _check_block(block, nos[:k], wanted, path)
        chunks.append(block)

    for row in csv.reader(lines):
        if not row or all(not cell.strip() for cell in row):
            continue
        rownum = lines.lineno
        if len(row) != ncells:
            hint = (" (a decimal comma? use a point: 1.5)" if len(row) > ncells else
                    " (the file ends inside this row: cut short while it was written or copied; delete the "
                    "row, or copy the file again)" if lines.cut else "")
            raise DataError(f"{path}:{rownum}: {len(row)} cells, the header has {ncells}{hint}")
        try:
            buf[k] = [float(row[j]) for j in idx]
        except ValueError:
            for c, j in zip(wanted, idx):
                _cell_value(row[j], c, path, rownum)
            raise  # pragma: no cover (one of the cells above raised)
        joined = "".join(row[j] for j in idx)
        if "_" in joined or not joined.isascii():  # float() takes "1_5" as 15, and fullwidth or Arabic-Indic digits
            for c, j in zip(wanted, idx):
                _cell_value(row[j], c, path, rownum)
        nos[k] = rownum
        k += 1
        if k == CHUNK_ROWS:
            flush(k)
            k = 0
            bar.update(lines.chars - done)
            done = lines.chars
    if k:
        flush(k)
    if not chunks:
        raise DataError(f"{path}: no data rows")
    data = np.concatenate(chunks) if len(chunks) > 1 else chunks[0]
    chunks.clear()
    return RawDataset({c: np.ascontiguousarray(data[:, i]) for i, c in enumerate(wanted)}, meta)


def _cell_value(cell: str, col: str, path, rownum) -> float:
    text = cell.strip()
    try:
        if "_" in text or not text.isascii():  # a plain decimal number (docs/dataset.md), ASCII digits only
            raise ValueError
        return float(text)
    except ValueError:
        raise DataError(f"{path}:{rownum}: column {col}: {text[:40]!r} is not a number") from None


def _check_block(block, nos, cols, path) -> None:
    """Finite values, and each column within its rule (RULES)."""
    for i, c in enumerate(cols):
        v = block[:, i]
        bad = ~np.isfinite(v)
        if c in RULES:
            lo, hi = RULES[c]
            bad |= ~((v >= lo) & (v <= hi))
        if bad.any():
            r = int(np.argmax(bad))
            if not math.isfinite(v[r]):
                raise DataError(f"{path}:{nos[r]}: column {c}: {str(float(v[r]))!r} is not a finite number")
            raise DataError(f"{path}:{nos[r]}: column {c}: {float(v[r]):g} out of range: {c} {_rule_text(c)}")


THIN_NOTE = "the run has"
THIN_SEED = 20_160_210  # the stratified draw's seed: the same file always gives the same rows


def thin_rows(n: int, max_rows: int) -> "np.ndarray":
    """The rows a long run keeps (increasing): the run cut into max_rows
    stretches of equal length (to a row) and one row drawn at random in each,
    seeded (THIN_SEED).  Every stretch of the run keeps its share, and no
    pattern repeating along the run can line up with the rows kept (a fixed
    stride of k kept only the even rows of a run whose rows alternate, and
    40 002 rows of a repeated run failed where 39 999 passed)."""
    edges = (np.arange(max_rows + 1, dtype=np.int64) * n) // max_rows
    rng = np.random.default_rng(THIN_SEED)
    return edges[:-1] + (rng.random(max_rows) * np.diff(edges)).astype(np.int64)


def thin(ds: RawDataset, max_rows: int | None) -> tuple[RawDataset, str | None]:
    """The subsampling rule for methods that do not need every row of a long
    run: with n > max_rows rows, max_rows rows, one drawn at random from each
    of max_rows equal stretches of the run (thin_rows: stratified, seeded).
    Returns the dataset (the same object when nothing is dropped) and a
    one-line note, or None."""
    n = len(ds)
    if max_rows is None or n <= max_rows:
        return ds, None
    m = int(max_rows)
    keep = thin_rows(n, m)
    sub = RawDataset({c: np.ascontiguousarray(v[keep]) for c, v in ds.columns.items()}, dict(ds.meta))
    return sub, (f"{THIN_NOTE} {n} rows; {m} of them were used, one drawn at random from each of {m} equal "
                 f"stretches of the run (stratified, seed {THIN_SEED}: the same file gives the same rows; "
                 "docs/dataset.md)")


def write_raw(path: str, ds: RawDataset, inputs=()) -> None:
    """Write a raw dataset through inclino.formats.safeio (atomic, never over one of
    `inputs`, a device or a symlink's place)."""
    from inclino.formats import safeio

    cols = [c for c in COLUMN_ORDER if c in ds.columns]
    with safeio.output_file(path, inputs) as f:
        for k in META_KEYS:
            if k in ds.meta:
                f.write(f"# {k}={ds.meta[k]}\n")
        w = csv.writer(f)
        w.writerow(cols)
        for r in range(len(ds)):
            w.writerow([repr(float(ds.columns[c][r])) for c in cols])
