"""A logged survey run as `inclino survey` writes it: its columns, the QC
verdict's text, and the run's files (CSV written row by row, LAS 2.0 at
checkpoints and at any exit).

Every output of a run carries who and when (docs/survey.md, "Logged runs"):

* a header: the start of the run in UTC (ISO 8601), the probe's product,
  serial and firmware, the active calibration's slot, sequence and CRC, and
  which QC checks the probe ran;
* per reading: `utc_s`, seconds since that start by the host's clock when
  the reading arrived; `t_s`, the probe's own time since it started;
  `samples`, the sensor samples the probe averaged for the reading.

A file is never replaced: an existing one is continued with `append`
(one header; a header that does not match this run -- another probe,
calibration or firmware, other columns -- is refused) or refused.
"""
from __future__ import annotations

import csv
import datetime as _dt
import math
import os
import time

from inclino.errors import DataError

SURVEY_COLS = ("t_s", "inc_deg", "azi_deg", "tf_deg", "mtf_deg", "gt_g", "bt_nT", "dip_deg", "flags", "qc")
LOG_COLS = SURVEY_COLS + ("samples", "utc_s")
QC_BITS = {0x01: "G", 0x02: "B", 0x04: "dip", 0x08: "undefined"}
QC_NO_REF = 0x80  # PROBE_QC_NO_REF: no reference stored, only G total checked (against 1 g)
NO_REF_TEXT = "G only: no reference field on the probe (`inclino reffield --port P ...` stores one)"
QC_DESCR = ("QC bits: 1 G total, 2 B total, 4 dip outside the reference window, 8 undefined (zero field or "
            "saturation), 128 no reference on the probe (only G checked); 0 = G, B and dip checked and passed")
# the keys of a run's header that must match for `--append` (the others, start_utc and port, may differ)
MATCH_KEYS = ("product", "probe_serial", "firmware", "calibration_slot", "calibration_sequence",
              "calibration_crc")


def qc_checked(qc: int) -> str:
    return "G only" if int(qc) & QC_NO_REF else "G,B,dip"


def qc_text(qc: int, short: bool = False) -> str:
    """The verdict naming the checks that ran: 'PASS G,B,dip', 'FAIL B
    (checked G,B,dip)', 'PASS G only: no reference field on the probe (...)'."""
    qc = int(qc)
    fails = [n for b, n in QC_BITS.items() if qc & b]
    if qc & QC_NO_REF:
        what = "G only" if short else NO_REF_TEXT
        return f"FAIL {','.join(fails)} ({what})" if fails else f"PASS {what}"
    return f"FAIL {','.join(fails)} (checked G,B,dip)" if fails else "PASS G,B,dip"


def utc_iso(t: float) -> str:
    return _dt.datetime.fromtimestamp(t, _dt.timezone.utc).isoformat(timespec="milliseconds").replace("+00:00", "Z")


def parse_utc(text: str, where: str) -> float:
    try:
        d = _dt.datetime.fromisoformat(str(text).strip())
    except ValueError:
        raise DataError(f"{where}: start time {text!r} is not an ISO 8601 time") from None
    if d.tzinfo is None:
        raise DataError(f"{where}: start time {text!r} has no time zone (UTC is written with Z)")
    return d.timestamp()


def run_header(ident, port: str, start: float) -> dict:
    """The header of a run from the probe's identity (link.identify())."""
    slot = {0: "A", 1: "B", 0xFF: "none"}.get(ident.cal_slot, str(ident.cal_slot))
    return {"start_utc": utc_iso(start), "product": ident.product, "probe_serial": str(ident.serial),
            "firmware": ".".join(map(str, ident.fw_version)), "calibration_slot": slot,
            "calibration_sequence": str(ident.cal_sequence), "calibration_crc": f"{ident.cal_crc:04X}",
            "port": port}


def _fmt(v) -> str:
    if isinstance(v, float):
        return f"{v:.6f}" if math.isfinite(v) else ""
    return str(v)


def csv_row(row: dict, cols) -> list:
    return [_fmt(row[c]) for c in cols]


def header_lines(header: dict, checked: str) -> list[str]:
    lines = [f"# {k}={v}" for k, v in header.items()]
    lines.append(f"# qc_checked={checked}")
    lines.append("# utc_s=seconds since start_utc (host clock at reception); t_s=probe time since its start; "
                 "samples=sensor samples averaged per reading")
    return lines


def _norm(key: str, v) -> str:
    """A header value as compared for --append (LAS readers turn numbers into numbers)."""
    s = str(v).strip() if v is not None else ""
    try:
        if key == "calibration_crc":
            return f"{int(s[2:] if s.lower().startswith('0x') else s, 16):04X}"
        if key in ("probe_serial", "calibration_sequence"):
            return str(int(float(s)))
    except ValueError:
        pass
    return s


def _mismatch(path: str, have: dict, want: dict) -> None:
    diff = [f"{k} {_norm(k, have.get(k))} in the file, {_norm(k, want[k])} now" for k in MATCH_KEYS
            if _norm(k, have.get(k)) != _norm(k, want[k])]
    if diff:
        raise DataError(f"{path}: its header does not match this run ({'; '.join(diff)}): not appended; "
                        "start a new file")


# ------------------------------------------------------------------ CSV
class CsvLog:
    """The run's CSV file, written and flushed row by row."""

    def __init__(self, path: str, header: dict, columns: tuple, append: bool):
        self.path, self.columns, self.rows = path, columns, 0
        self.start = parse_utc(header["start_utc"], path)
        exists = os.path.exists(path)
        if os.path.isdir(path):
            raise DataError(f"refusing to write {path}: it is a directory")
        if exists and not append:
            raise DataError(f"{path} exists: --append continues it (one header), or choose a new file")
        self.new = not exists or os.path.getsize(path) == 0
        self.header = header
        self.notes: list[str] = []
        if not self.new:
            meta, cols = _csv_header(path)
            _mismatch(path, meta, header)
            if tuple(cols) != tuple(columns):
                raise DataError(f"{path}: its columns ({','.join(cols)}) are not this run's "
                                f"({','.join(columns)}): not appended; start a new file")
            self.start = parse_utc(meta.get("start_utc", ""), path)
            self._drop_cut_row()
        from inclino.formats import safeio

        self.f = safeio.open_log(path, "a")  # the output rules: never an input, never another output
        self.w = csv.writer(self.f, lineterminator="\n")

    def _drop_cut_row(self) -> None:
        """A run stopped while writing a row (killed, the power lost) leaves
        it without its newline: the next row would be glued onto it.  Cut
        the file back to its last whole row and say so."""
        with open(self.path, "rb") as f:
            data = f.read()
        if data.endswith(b"\n"):
            return
        keep = data.rfind(b"\n") + 1
        os.truncate(self.path, keep)
        self.notes.append(f"{self.path}: its last row was cut short (the run stopped while writing it): "
                          f"dropped ({len(data) - keep} bytes), the new readings follow the last whole row")

    def write(self, row: dict, checked: str) -> None:
        try:
            if self.new:
                h = dict(self.header)
                for line in header_lines(h, checked):
                    self.f.write(line + "\n")
                self.w.writerow(self.columns)
                self.new = False
            self.w.writerow(csv_row({**row, "utc_s": row["utc"] - self.start}, self.columns))
            self.f.flush()
        except OSError as e:
            raise DataError(f"cannot write {self.path}: {e.strerror}") from None
        self.rows += 1

    def close(self) -> None:
        try:
            self.f.flush()
            os.fsync(self.f.fileno())
        except OSError:
            pass
        self.f.close()


def _csv_header(path: str):
    meta, cols = {}, None
    try:
        with open(path, encoding="utf-8") as f:
            for line in f:
                s = line.strip()
                if s.startswith("#"):
                    if "=" in s:
                        k, v = s[1:].split("=", 1)
                        meta[k.strip()] = v.strip()
                    continue
                if s:
                    cols = [c.strip() for c in next(csv.reader([s]))]
                    break
    except OSError as e:
        raise DataError(f"cannot read {path}: {e.strerror}") from None
    except UnicodeDecodeError:
        raise DataError(f"{path}: not a text file") from None
    if cols is None or "start_utc" not in meta:
        raise DataError(f"{path}: not a survey log written by inclino survey (no header): not appended")
    return meta, cols


# ------------------------------------------------------------------ LAS
LAS_CURVES = (("utc_s", "TIME", "s", "time since the start of the run (DATE, UTC)"),
              ("t_s", "PTIME", "s", "probe time since the probe started"),
              ("inc_deg", "INC", "deg", "inclination"), ("azi_deg", "AZI", "deg", "azimuth, magnetic north"),
              ("tf_deg", "GTF", "deg", "gravity toolface"), ("mtf_deg", "MTF", "deg", "magnetic toolface"),
              ("gt_g", "GTOT", "g", "G total"), ("bt_nT", "BTOT", "nT", "B total"),
              ("dip_deg", "DIP", "deg", "magnetic dip"),
              ("flags", "FLAGS", "", "attitude flags: 1 near vertical (azimuth undefined), 2 zero gravity, "
                                     "4 zero field, 8 arithmetic saturation"),
              ("qc", "QC", "", QC_DESCR), ("samples", "NSAMP", "", "sensor samples averaged per reading"))
LAS_PARAMS = (("product", "PRODUCT", "probe product"), ("probe_serial", "PSERIAL", "probe serial"),
              ("firmware", "FWVER", "probe firmware version"),
              ("calibration_slot", "CALSLOT", "active calibration slot"),
              ("calibration_sequence", "CALSEQ", "active calibration sequence"),
              ("calibration_crc", "CALCRC", "active calibration image CRC (hex)"),
              ("start_utc", "TSTART", "start of the run, UTC (ISO 8601)"),
              ("port", "PORT", "port the run was read from"))


class LasLog:
    """The run's LAS 2.0 file: written whole (atomically) at checkpoints and
    when the run ends; with `append`, an existing file's readings first."""

    def __init__(self, path: str, header: dict, with_md: bool, append: bool):
        self.path, self.header, self.with_md = path, dict(header), with_md
        self.rows: list[dict] = []
        self.old: dict | None = None
        self.start = parse_utc(header["start_utc"], path)
        if os.path.isdir(path):
            raise DataError(f"refusing to write {path}: it is a directory")
        if os.path.exists(path):
            if not append:
                raise DataError(f"{path} exists: --append continues it, or choose a new file")
            self._load_old()
        self.last_write, self.write_cost = time.monotonic(), 0.0

    def _load_old(self) -> None:
        from inclino.formats import las as lasfmt
        from inclino.formats.safeio import read_text

        las = lasfmt.read(read_text(self.path, "LAS file", max_bytes=1 << 30), self.path)
        params = {p.mnemonic.upper(): str(p.value).strip() for p in las.params}
        meta = {key: params.get(m) for key, m, _ in LAS_PARAMS}
        if meta.get("start_utc") is None:
            raise DataError(f"{self.path}: not a survey log written by inclino survey (no TSTART): not appended")
        _mismatch(self.path, meta, self.header)
        index = las.curves[0].mnemonic.upper() if las.curves else ""
        want = "DEPT" if self.with_md else "TIME"
        if index != want:
            raise DataError(f"{self.path}: indexed by {index or 'nothing'}, this run by {want} "
                            f"({'with' if self.with_md else 'without'} --md): not appended; start a new file")
        mnems = [c.mnemonic.upper() for c in las.curves]
        ours = self._mnemonics()
        if mnems != ours:
            raise DataError(f"{self.path}: its curves ({','.join(mnems)}) are not this run's ({','.join(ours)}): "
                            "not appended; start a new file")
        self.start = parse_utc(meta["start_utc"], self.path)
        self.header["start_utc"] = meta["start_utc"]
        self.header["port"] = meta.get("port") or self.header["port"]
        self.old = {c.mnemonic.upper(): list(map(float, c.data)) for c in las.curves}
        self.old_checked = params.get("QCCHK", "")

    def _mnemonics(self) -> list:
        return (["DEPT"] if self.with_md else []) + [m for _, m, _, _ in LAS_CURVES]

    def add(self, row: dict) -> None:
        self.rows.append(row)
        now = time.monotonic()
        if now - self.last_write > max(5.0, 20.0 * self.write_cost):
            self.write()

    def count(self) -> int:
        return len(self.rows) + (len(next(iter(self.old.values()))) if self.old else 0)

    def write(self) -> None:
        import numpy as np

        from inclino.formats import las as lasfmt
        from inclino.formats.safeio import write_output

        t0 = time.monotonic()
        cols = {}
        for key, mnem, _, _ in LAS_CURVES:
            v = [(r["utc"] - self.start) if key == "utc_s" else float(r[key]) for r in self.rows]
            cols[mnem] = np.array((self.old or {}).get(mnem, []) + v, float)
        if self.with_md:
            depth = np.array((self.old or {}).get("DEPT", []) + [float(r["md_m"]) for r in self.rows], float)
        checked = sorted({qc_checked(r["qc"]) for r in self.rows} | ({self.old_checked} if self.old else set()))
        checked = [c for c in checked if c]
        params = [(m, "", ("0x" if k == "calibration_crc" else "") + str(self.header.get(k, "")), d)
                  for k, m, d in LAS_PARAMS]
        params.append(("QCCHK", "", " / ".join(checked) if checked else "", "QC checks the probe ran: G,B,dip, or "
                       "G only (no reference field on the probe)"))
        curves = [(m, u, d, cols[m]) for _, m, u, d in LAS_CURVES]
        other = ("Survey run logged by inclino survey. TIME: seconds since DATE (UTC) by the host clock at "
                 "reception; PTIME: the probe's own time.")
        if self.with_md:
            text = lasfmt.render("DEPT", "M", "measured depth of the station", depth, curves, params,
                                 date=self.header["start_utc"], other=other)
        else:
            text = lasfmt.render("TIME", "s", curves[0][2], cols["TIME"], curves[1:], params,
                                 date=self.header["start_utc"], other=other)
        write_output(self.path, text)
        self.last_write = time.monotonic()
        self.write_cost = self.last_write - t0


# ------------------------------------------------------------------ the run
class SurveyLog:
    """A run being logged: the CSV file (row by row) and the LAS file
    (checkpoints and the end).  `add` each reading as it arrives; `close`
    (in a finally: Ctrl-C, a link failure) writes what is held and says
    what was kept."""

    def __init__(self, ident, port: str, md: float | None = None, csv_path: str | None = None,
                 las_path: str | None = None, append: bool = False, clock=time.time):
        self.clock = clock
        self.md = md
        self.header = run_header(ident, port, clock())
        self.columns = (("md_m",) if md is not None else ()) + LOG_COLS + ("qc_verdict",)
        self.csv = CsvLog(csv_path, self.header, self.columns, append) if csv_path else None
        if self.csv is not None:
            self.header["start_utc"] = utc_iso(self.csv.start)
        self.las = LasLog(las_path, self.header, md is not None, append) if las_path else None
        self.notes = self.csv.notes if self.csv is not None else []
        self.rows = 0
        self.closed = False

    def add(self, units: dict, samples: int) -> dict:
        row = {**units, "samples": int(samples), "utc": self.clock()}
        if self.md is not None:
            row["md_m"] = float(self.md)
        row["qc_verdict"] = qc_text(units["qc"])
        if self.csv is not None:
            self.csv.write(row, qc_checked(units["qc"]))
        if self.las is not None:
            self.las.add(row)
        self.rows += 1
        return row

    def close(self) -> str:
        """Write the LAS, close the CSV; the sentence saying what was kept."""
        if self.closed:
            return ""
        self.closed = True
        kept = []
        if self.csv is not None:
            self.csv.close()
            kept.append(f"{self.csv.path} ({self.csv.rows} new rows)")
        if self.las is not None and (self.las.rows or self.las.old is None):
            if self.las.rows:
                self.las.write()
            kept.append(f"{self.las.path} ({self.las.count()} readings)" if self.las.rows else
                        f"{self.las.path} not written (no reading)")
        elif self.las is not None:
            kept.append(f"{self.las.path} unchanged (no new reading)")
        return f"{self.rows} reading{'s' if self.rows != 1 else ''} logged" + (": " + ", ".join(kept) if kept else "")
