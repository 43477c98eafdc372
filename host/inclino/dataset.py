"""The raw dataset format (CSV) that every tool reads and writes.

    # field_nT=50000
    # dip_deg=60
    t_s,inc_deg,azi_deg,tf_deg,temp_c,ax_g,ay_g,az_g,mx_nT,my_nT,mz_nT
    0,10,30,0,25,...

Optional leading `# key=value` lines (META_KEYS), then a header row with the
columns in any order, extra columns allowed.  Pose columns (turntable
reference) and t_s/temp_c may be absent; the six sensor columns are required
and hold raw, uncalibrated readings in nominal units (counts x nominal LSB).
"""
from __future__ import annotations

import csv
import math
from dataclasses import dataclass, field

import numpy as np

from inclino.errors import DataError

META_KEYS = ("field_nT", "dip_deg", "declination_deg", "gravity_g", "lat_deg", "lon_deg",
             "date", "probe_serial", "source", "samples_averaged")
NUMERIC_META = {"field_nT", "dip_deg", "declination_deg", "gravity_g", "lat_deg", "lon_deg", "samples_averaged"}
SENSOR_COLS = ("ax_g", "ay_g", "az_g", "mx_nT", "my_nT", "mz_nT")
POSE_COLS = ("inc_deg", "azi_deg", "tf_deg")
OPTIONAL_COLS = ("t_s", "temp_c") + POSE_COLS
COLUMN_ORDER = ("t_s",) + POSE_COLS + ("temp_c",) + SENSOR_COLS


@dataclass
class RawDataset:
    columns: dict = field(default_factory=dict)  # name -> float64 array
    meta: dict = field(default_factory=dict)

    def __len__(self) -> int:
        return len(self.columns[SENSOR_COLS[0]]) if self.columns else 0

    @property
    def acc(self) -> np.ndarray:
        return np.stack([self.columns[c] for c in SENSOR_COLS[:3]], axis=-1)

    @property
    def mag(self) -> np.ndarray:
        return np.stack([self.columns[c] for c in SENSOR_COLS[3:]], axis=-1)

    @property
    def has_pose(self) -> bool:
        return all(c in self.columns for c in POSE_COLS)


def _meta_value(key, text, path, lineno):
    if key in NUMERIC_META:
        try:
            v = float(text)
        except ValueError:
            raise DataError(f"{path}:{lineno}: header {key}={text!r} is not a number")
        if not math.isfinite(v):
            raise DataError(f"{path}:{lineno}: header {key} is not finite")
        return v
    return text


def read_raw(path: str) -> RawDataset:
    """Read a raw dataset; raise DataError (one line, naming the row and
    column) on any defect."""
    try:
        f = open(path, newline="", encoding="utf-8")
    except OSError as e:
        raise DataError(f"cannot read {path}: {e.strerror}")
    meta: dict = {}
    with f:
        try:
            lines = f.read().splitlines()
        except UnicodeDecodeError:
            raise DataError(f"{path}: not a text (UTF-8) file")
    i = 0
    while i < len(lines) and (lines[i].startswith("#") or not lines[i].strip()):
        body = lines[i].lstrip("#").strip()
        if "=" in body:
            k, v = (s.strip() for s in body.split("=", 1))
            if k in META_KEYS:
                meta[k] = _meta_value(k, v, path, i + 1)
        i += 1
    if i >= len(lines):
        raise DataError(f"{path}: no header row")
    header_line = i + 1
    reader = csv.reader(lines[i:])
    header = [h.strip() for h in next(reader)]
    missing = [c for c in SENSOR_COLS if c not in header]
    if missing:
        raise DataError(f"{path}:{header_line}: missing column(s) {', '.join(missing)}")
    if len(set(header)) != len(header):
        raise DataError(f"{path}:{header_line}: a column name appears twice")
    wanted = [c for c in COLUMN_ORDER if c in header]
    idx = {c: header.index(c) for c in wanted}
    data = {c: [] for c in wanted}
    for rownum, row in enumerate(reader, start=header_line + 1):
        if not row or all(not cell.strip() for cell in row):
            continue
        for c in wanted:
            j = idx[c]
            if j >= len(row):
                raise DataError(f"{path}:{rownum}: column {c} is missing in this row")
            cell = row[j].strip()
            try:
                v = float(cell)
            except ValueError:
                raise DataError(f"{path}:{rownum}: column {c}: {cell!r} is not a number")
            if not math.isfinite(v):
                raise DataError(f"{path}:{rownum}: column {c}: {cell!r} is not a finite number")
            data[c].append(v)
    if not data[SENSOR_COLS[0]]:
        raise DataError(f"{path}: no data rows")
    return RawDataset({c: np.array(v, dtype=float) for c, v in data.items()}, meta)


def write_raw(path: str, ds: RawDataset) -> None:
    cols = [c for c in COLUMN_ORDER if c in ds.columns]
    with open(path, "w", newline="", encoding="utf-8") as f:
        for k in META_KEYS:
            if k in ds.meta:
                f.write(f"# {k}={ds.meta[k]}\n")
        w = csv.writer(f)
        w.writerow(cols)
        for r in range(len(ds)):
            w.writerow([repr(float(ds.columns[c][r])) for c in cols])
