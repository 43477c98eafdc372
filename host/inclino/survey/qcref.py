"""The probe's QC reference (QCREF_WRITE): G total, B total and dip with
their tolerances, from a survey's reference field (inclino.survey.geomag), so that
the probe's own QC verdict (the `qc` column of `inclino survey`) checks each
survey against the field where it is run."""
from __future__ import annotations

import math

from inclino.errors import DataError


def fixed(rf) -> tuple:
    """(gt_ref, gt_tol Q27 g, bt_ref, bt_tol Q8 nT, dip_ref, dip_tol Q16 deg): qc_ref_t."""
    if not (math.isfinite(rf.field_nT) and math.isfinite(rf.dip_deg)):
        raise DataError("the probe's QC reference needs the dip and the total field (a position and date, "
                        "or --dip and --field)")
    t = rf.tol
    g = rf.gravity_g if math.isfinite(rf.gravity_g) else 1.0  # the firmware's default reference (qc_default)
    vals = (g * 2**27, t["gt_g"] * 2**27, rf.field_nT * 256.0, t["bt_nT"] * 256.0,
            rf.dip_deg * 65536.0, t["dip_deg"] * 65536.0)
    out = tuple(int(round(v)) for v in vals)
    if any(not -2**31 <= v < 2**31 for v in out) or min(out[1], out[3], out[5]) < 0:
        raise DataError("the QC reference is outside the probe's range")
    return out


def write_probe(link, rf) -> tuple:
    """Write the reference to the probe and read it back; returns the record."""
    from inclino.errors import InclinoError

    want = fixed(rf)
    link.qcref_write(want)
    got = tuple(link.qcref_read())
    if got != want:
        raise InclinoError(f"the probe's QC reference reads back {got}, not {want}")
    return got


def readable(rec) -> dict:
    """A QC reference record (qc_ref_t, fixed point) in units."""
    gt, gtt, bt, btt, dip, dipt = rec
    return {"gt_g": gt / 2**27, "gt_tol_g": gtt / 2**27, "bt_nT": bt / 256.0, "bt_tol_nT": btt / 256.0,
            "dip_deg": dip / 65536.0, "dip_tol_deg": dipt / 65536.0}


def text(rec) -> str:
    r = readable(rec)
    return (f"G total {r['gt_g']:.6f} +- {r['gt_tol_g']:.4f} g, B total {r['bt_nT']:.1f} +- {r['bt_tol_nT']:.0f} nT, "
            f"dip {r['dip_deg']:.4f} +- {r['dip_tol_deg']:.2f} deg")
