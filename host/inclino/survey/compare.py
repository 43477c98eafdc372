"""Repeatability QC: two surveys of the same hole (in-run and out-run, or two
probes) station by station, against the spread the error model expects.

Stations are paired by measured depth (nearest, within md_tol metres).  At
each pair the inclination and azimuth differences are set against the
expected 1-sigma of a difference, from the tool model's terms at the pair's
attitude (toolface-independent ISCWSA weighting functions):

* the same probe (default): the random terms (noise) of both surveys, and
  the toolface-dependent systematic terms (the XY sensor terms and the
  tool-axis misalignment), which a different toolface at the same depth
  changes; the Z-axis terms and the reference field cancel;
* two probes (two_probes): every sensor term of both.

A station passes when both |d inc| and |d azi| are within k (default 3)
times their expected sigma.
"""
from __future__ import annotations

import math
from dataclasses import asdict, dataclass, field

import numpy as np

from inclino.survey import errormodel as em
from inclino.errors import DataError
from inclino.formats.jsonout import dumps

XY_GROUPS = ("ABXY", "ASXY", "MBXY", "MSXY", "XYM34")


@dataclass
class CompareResult:
    stations: list = field(default_factory=list)
    unmatched_in: list = field(default_factory=list)
    unmatched_out: list = field(default_factory=list)
    k: float = 3.0
    mode: str = "same probe"
    passed: bool = True
    summary: dict = field(default_factory=dict)

    def to_json(self) -> str:
        return dumps(asdict(self))


def _expected(tm: em.ToolModel, inc, azi, dip, field_nT, two_probes):
    if two_probes:
        sub = tm
    else:
        sub = em.ToolModel(systematic={g: v for g, v in tm.systematic.items() if g in XY_GROUPS}, noise=tm.noise)
    si, sa = em.station_sigma(sub, inc, azi, dip, field_nT)
    return math.sqrt(2.0) * si, math.sqrt(2.0) * sa


def compare(a, b, tm: em.ToolModel, dip_deg: float, field_nT: float, k: float = 3.0, md_tol: float = 0.5,
            two_probes: bool = False) -> CompareResult:
    """a, b: wellpath.Survey (in-run, out-run)."""
    if not (k > 0 and math.isfinite(k)):
        raise DataError("--k must be > 0")
    if not (md_tol >= 0 and math.isfinite(md_tol)):
        raise DataError("--md-tol must be >= 0")
    res = CompareResult(k=k, mode="two probes" if two_probes else "same probe")
    used_b = set()
    for i, md in enumerate(a.md_m):
        j = int(np.argmin(np.abs(b.md_m - md)))
        if abs(b.md_m[j] - md) > md_tol or j in used_b:
            res.unmatched_in.append(float(md))
            continue
        used_b.add(j)
        inc = 0.5 * (a.inc_deg[i] + b.inc_deg[j])
        d_azi = ((b.azi_mag_deg[j] - a.azi_mag_deg[i] + 180.0) % 360.0) - 180.0
        azi = (a.azi_mag_deg[i] + 0.5 * d_azi) % 360.0
        si, sa = _expected(tm, np.array([inc]), np.array([azi]), dip_deg, field_nT, two_probes)
        d_inc = float(b.inc_deg[j] - a.inc_deg[i])
        si, sa = float(si[0]), float(sa[0])
        azi_defined = math.isfinite(sa) and min(a.inc_deg[i], b.inc_deg[j]) >= 0.5
        ok_i = abs(d_inc) <= k * si
        ok_a = (abs(d_azi) <= k * sa) if azi_defined else True
        res.stations.append({"md_m": float(md), "md_out_m": float(b.md_m[j]), "inc_deg": float(a.inc_deg[i]),
                             "d_inc_deg": d_inc, "sigma_d_inc_deg": si,
                             "d_azi_deg": float(d_azi) if azi_defined else None,
                             "sigma_d_azi_deg": sa if azi_defined else None,
                             "verdict": "PASS" if ok_i and ok_a else
                             "FAIL " + ",".join(n for n, ok in (("inc", ok_i), ("azi", ok_a)) if not ok)})
    res.unmatched_out = [float(m) for j, m in enumerate(b.md_m) if j not in used_b]
    if not res.stations:
        raise DataError(f"no station of the two surveys is within {md_tol:g} m of measured depth of the other")
    nf = sum(s["verdict"] != "PASS" for s in res.stations)
    res.passed = nf == 0
    res.summary = {"pairs": len(res.stations), "failed": nf, "unmatched_in": len(res.unmatched_in),
                   "unmatched_out": len(res.unmatched_out),
                   "d_inc_rms_deg": float(np.sqrt(np.mean([s["d_inc_deg"] ** 2 for s in res.stations]))),
                   "d_azi_rms_deg": _rms([s["d_azi_deg"] for s in res.stations])}
    return res


def _rms(v):
    v = [x for x in v if x is not None]
    return float(np.sqrt(np.mean(np.square(v)))) if v else None
