"""A logged survey run as `inclino survey` writes it: its columns, the QC
verdict's text, and the LAS 2.0 file (lasio) of the run."""
from __future__ import annotations

SURVEY_COLS = ("t_s", "inc_deg", "azi_deg", "tf_deg", "mtf_deg", "gt_g", "bt_nT", "dip_deg", "flags", "qc")
QC_BITS = {0x01: "G", 0x02: "B", 0x04: "dip", 0x08: "undefined", 0x80: "no-ref"}


def qc_text(qc: int) -> str:
    fails = [n for b, n in QC_BITS.items() if qc & b and b != 0x80]
    return ("FAIL " + ",".join(fails)) if fails else "PASS"


def las_text(recs: list[dict], probe: str = "", md: float | None = None) -> str:
    """A logged survey run as LAS 2.0 text (lasio), indexed by time."""
    import io

    import lasio
    import numpy as np

    las = lasio.LASFile()
    las.well["COMP"] = lasio.HeaderItem("COMP", value="")
    las.well["WELL"] = lasio.HeaderItem("WELL", value="")
    las.other = f"Recorded by inclino from {probe}. Index is time since probe start (s)."
    t = np.array([r["t_s"] for r in recs], dtype=float)
    las.append_curve("TIME", t, unit="s", descr="time since probe start")
    if md is not None:
        las.append_curve("MD", np.full(len(t), float(md)), unit="m", descr="measured depth of the station")
    for key, mnem, unit, descr in (("inc_deg", "INC", "deg", "inclination"), ("azi_deg", "AZI", "deg", "azimuth"),
                                   ("tf_deg", "GTF", "deg", "gravity toolface"),
                                   ("mtf_deg", "MTF", "deg", "magnetic toolface"),
                                   ("gt_g", "GTOT", "g", "G total"), ("bt_nT", "BTOT", "nT", "B total"),
                                   ("dip_deg", "DIP", "deg", "magnetic dip"), ("flags", "FLAGS", "", "status flags"),
                                   ("qc", "QC", "", "QC bits, 0 = pass")):
        las.append_curve(mnem, np.array([r[key] for r in recs], dtype=float), unit=unit, descr=descr)
    buf = io.StringIO()
    las.write(buf, version=2.0)
    return buf.getvalue()


def write_las(path: str, recs: list[dict], probe: str = "", md: float | None = None) -> None:
    """A logged survey run as LAS 2.0 (lasio), through inclino.formats.safeio."""
    from inclino.formats import safeio

    safeio.write_output(path, las_text(recs, probe, md))
