"""Repeatability QC: two surveys of the same hole (in-run and out-run, or two
probes) station by station, against the spread the error model expects.

Stations are paired by measured depth (nearest, within md_tol metres): an
in-run (depth increasing) and an out-run (decreasing) pair as well as two
in-runs.  At each pair the inclination and azimuth differences are set
against the expected 1-sigma of a difference, from the error model's terms
at the pair's attitude (welleng's per-term station covariance):

* the same probe (default): the random terms (noise, random declination
  and misalignment) of both surveys, and the toolface-dependent systematic
  terms (the XY sensor terms and the tool-axis misalignment), which a
  different toolface at the same depth changes; the Z-axis terms and the
  reference field's systematic terms cancel;
* two probes (two_probes): every sensor term of both.

A station passes when both |d inc| and |d azi| are within k (default 3)
times their expected sigma.  Where the noise is an estimate from the
calibration's residuals with few degrees of freedom (noise_dof), the limit
is Student's t quantile of the same two-sided probability: the expected
sigma carries the estimate's own error.
"""
from __future__ import annotations

import gc
import math
from dataclasses import asdict, dataclass, field

import numpy as np

from inclino.errors import DataError
from inclino.formats.jsonout import dump, dumps

@dataclass
class CompareResult:
    stations: list = field(default_factory=list)
    unmatched_in: list = field(default_factory=list)
    unmatched_out: list = field(default_factory=list)
    k: float = 3.0
    # the limit the pairs are judged against: k, or with a noise estimated on noise_dof degrees of freedom Student's
    # t quantile of k's two-sided probability (k 3: 3.35 at 24, 4.28 at 8)
    k_limit: float = 3.0
    noise_dof: float | None = None
    mode: str = "same probe"
    # the probe's calibration terms: at each station's own toolface in both surveys, or toolface-averaged
    toolface: str = "averaged"
    runs: list = field(default_factory=list)  # "in-run"/"out-run" of the two listings
    passed: bool = True
    summary: dict = field(default_factory=dict)

    def to_json(self) -> str:
        return dumps(asdict(self))

    def write_json(self, f) -> None:
        """to_json()'s text written to f as it is encoded (a 10^5-pair result
        is never held as one string, nor copied by asdict: the fields are
        plain lists and dicts)."""
        dump({k: getattr(self, k) for k in self.__dataclass_fields__}, f)


def counts(code: str, propagation: str, two_probes: bool) -> bool:
    """Whether a term differs between the two surveys of a station: a random
    term always; the same probe's toolface-dependent systematic terms (the
    X/Y sensor terms, misalignment), which another toolface at the same depth
    changes; with two probes every sensor term.  Depth (course length) and
    the reference field's systematic terms are common to both."""
    from inclino.survey.models import family

    f = family(code)
    if f == "depth":
        return False
    if propagation == "random":
        return True
    if f == "misalignment":
        return True
    if f == "sensor":
        return two_probes or "XY" in code.upper()
    return False


# Stations per call of the error model: a station's survey covariance is its
# own (the position covariance, which adds up along the hole, is not used
# here), so a long survey goes through in stretches of bounded memory
# (welleng holds some 13 kB per station and term set: 10^5 pairs at once took 1.3 GB)
CHUNK = 5000
NEAR_VERTICAL_DEG = 0.5  # azimuth undefined within this of vertical, down or up (ATT_F_NEAR_VERTICAL)
MIN_STATIONS = 4  # per call of the error model: welleng on 3 stations gives the first a zero and the last a
# negative variance; a shorter survey is called with stations added below its last


def expected(model, md, inc, azi, rf, two_probes=False, fallback=(60.0, 50000.0), chunk: int = CHUNK,
             skip_calibration: bool = False):
    """1-sigma (deg) of the inclination and azimuth difference between two
    surveys at each station (md increasing), from the model's terms
    (skip_calibration: without the probe's combination terms, which
    `at_toolfaces` gives instead)."""
    n = len(md)
    if 1 < n < MIN_STATIONS:  # fewer than the error model needs: stations below the last, their results unused
        k = MIN_STATIONS - n
        si, sa = expected(model, np.r_[md, md[-1] + 10.0 * np.arange(1, k + 1)], np.r_[inc, np.full(k, inc[-1])],
                          np.r_[azi, np.full(k, azi[-1])], rf, two_probes, fallback, chunk, skip_calibration)
        return si[:n], sa[:n]
    from inclino.survey.errormodel import is_correlated_name

    vi = np.zeros(n)
    va = np.zeros(n)
    for lo in range(0, n, chunk):
        hi = min(n, lo + chunk)
        # each stretch starts at the last station of the one before, and the call holds at least MIN_STATIONS
        # (more of the survey's own on either side): the error model called on 3 stations gives the first and
        # last a covariance of their own (NaN or off), not what the same stations get within the survey
        a = max(0, min(lo - 1, hi - MIN_STATIONS))
        b = min(n, max(hi, a + MIN_STATIONS))
        prop = model.propagate(md[a:b], inc[a:b], azi[a:b], rf, fallback)
        for (part, code), (propagation, dia) in prop.sources.items():
            if counts(code, propagation, two_probes) and not (skip_calibration and part == "probe"
                                                               and is_correlated_name(code)):
                vi[lo:hi] += dia[lo - a:hi - a, 1, 1]
                va[lo:hi] += dia[lo - a:hi - a, 2, 2]
        del prop
        gc.collect()  # welleng's survey objects hold reference cycles: a stretch's arrays go before the next
    return np.degrees(np.sqrt(2.0 * vi)), np.degrees(np.sqrt(2.0 * va))


def at_toolfaces(model, a, b, ia, ib, rf, fallback=(60.0, 50000.0)):
    """The variance (deg^2) of the inclination and azimuth difference that
    the probe's calibration error makes between two surveys of the same
    probe, each station at the attitude and toolface each survey read it
    in: (J_b - J_a) C (J_b - J_a)^T, one error for both runs.  A station
    surveyed twice at one toolface has none (the same error both times); at
    opposite toolfaces its X/Y part twice over.  None where the surveys do
    not give every paired station's toolface or the model has no
    calibration (then the toolface-averaged terms, counted as independent)."""
    from inclino.survey import errormodel as em

    ta, tb = (s.extra.get("tf_deg") for s in (a, b))
    if ta is None or tb is None or not (model.at_toolface(ta[ia], len(ia)) and model.at_toolface(tb[ib], len(ib))):
        return None
    from inclino.survey.models import field_of

    cal, cov = model.calibration
    f = field_of(rf, fallback)
    Ja, _ = em.station_jacobian(cal, cov, a.inc_deg[ia], a.azi_mag_deg[ia], ta[ia], *f)
    Jb, _ = em.station_jacobian(cal, cov, b.inc_deg[ib], b.azi_mag_deg[ib], tb[ib], *f)
    D = Jb - Ja
    v = np.degrees(np.degrees(np.einsum("snk,kl,snl->sn", D, cov, D)))
    return v[0], v[1]


def k_limit(k: float, noise_dof: float | None) -> float:
    """The pass limit in expected sigmas: k where the noise is known
    (noise_dof None), else Student's t quantile with noise_dof degrees of
    freedom of the two-sided probability k leaves under a normal law (a
    difference over a sigma whose noise is estimated from a few rows is
    t-distributed, and a fixed k fails correct pairs more often than it
    says)."""
    if noise_dof is None:
        return k
    from scipy import stats

    return float(stats.t.isf(stats.norm.sf(k), noise_dof))


def compare(a, b, model, rf, k: float = 3.0, md_tol: float = 0.5, two_probes: bool = False,
            fallback=(60.0, 50000.0), noise_dof: float | None = None) -> CompareResult:
    """a, b: wellpath.Survey (in-run and out-run, in either order; each sorted
    by depth when read); model: models.ErrorModel; rf: the reference field
    (its dip and total field enter the weights); noise_dof: the degrees of
    freedom of the model's noise where it is an estimate (k_limit)."""
    if not (k > 0 and math.isfinite(k)):
        raise DataError("--k must be > 0")
    if not (md_tol >= 0 and math.isfinite(md_tol)):
        raise DataError("--md-tol must be >= 0")
    res = CompareResult(k=k, mode="two probes" if two_probes else "same probe", noise_dof=noise_dof)
    res.k_limit = kl = k_limit(k, noise_dof)
    res.runs = [a.meta.get("run", ""), b.meta.get("run", "")]
    ia, ib = pair_stations(a.md_m, b.md_m, md_tol)
    used = np.zeros(len(b.md_m), bool)
    used[ib] = True
    unpaired = np.ones(len(a.md_m), bool)
    unpaired[ia] = False
    res.unmatched_in = a.md_m[unpaired].astype(float).tolist()
    res.unmatched_out = b.md_m[~used].astype(float).tolist()
    if not len(ia):
        raise DataError(f"no station of the two surveys is within {md_tol:g} m of measured depth of the other")
    pairs = list(zip(ia.tolist(), ib.tolist()))
    inc = 0.5 * (a.inc_deg[ia] + b.inc_deg[ib])
    d_azi = ((b.azi_mag_deg[ib] - a.azi_mag_deg[ia] + 180.0) % 360.0) - 180.0
    azi = (a.azi_mag_deg[ia] + 0.5 * d_azi) % 360.0
    md = a.md_m[ia]
    pad = len(md) == 1  # welleng needs two stations: one more above, its result unused
    exact = None if two_probes else at_toolfaces(model, a, b, ia, ib, rf, fallback)
    si, sa = expected(model, np.r_[md[0] - 10.0, md] if pad else md, np.r_[inc[0], inc] if pad else inc,
                      np.r_[azi[0], azi] if pad else azi, rf, two_probes, fallback, skip_calibration=exact is not None)
    si, sa = (si[1:], sa[1:]) if pad else (si, sa)
    if exact is not None:
        si, sa = np.sqrt(si ** 2 + exact[0]), np.sqrt(sa ** 2 + exact[1])
    res.toolface = "each station's own (the calibration's covariance)" if exact is not None else "averaged"
    si = tilt_length_sigma(si, a.inc_deg[ia], b.inc_deg[ib])
    for n, (i, j) in enumerate(pairs):
        d_inc = float(b.inc_deg[j] - a.inc_deg[i])
        azi_defined = (math.isfinite(sa[n]) and min(a.inc_deg[i], b.inc_deg[j]) >= NEAR_VERTICAL_DEG
                       and max(a.inc_deg[i], b.inc_deg[j]) <= 180.0 - NEAR_VERTICAL_DEG)
        ok_i = abs(d_inc) <= kl * si[n]
        ok_a = (abs(d_azi[n]) <= kl * sa[n]) if azi_defined else True
        res.stations.append({"md_m": float(md[n]), "md_out_m": float(b.md_m[j]), "inc_deg": float(a.inc_deg[i]),
                             "d_inc_deg": d_inc, "sigma_d_inc_deg": float(si[n]),
                             "d_azi_deg": float(d_azi[n]) if azi_defined else None,
                             "sigma_d_azi_deg": float(sa[n]) if azi_defined else None,
                             "verdict": "PASS" if ok_i and ok_a else
                             "FAIL " + ",".join(nm for nm, ok in (("inc", ok_i), ("azi", ok_a)) if not ok)})
    nf = sum(s["verdict"] != "PASS" for s in res.stations)
    res.passed = nf == 0
    res.summary = {"pairs": len(res.stations), "failed": nf, "passed_fraction": 1.0 - nf / len(res.stations),
                   "unmatched_in": len(res.unmatched_in), "unmatched_out": len(res.unmatched_out),
                   "d_inc_rms_deg": float(np.sqrt(np.mean([s["d_inc_deg"] ** 2 for s in res.stations]))),
                   "d_azi_rms_deg": _rms([s["d_azi_deg"] for s in res.stations]),
                   "error_model": model.describe()}
    return res


def tilt_length_sigma(sigma_d, inc_a, inc_b):
    """1-sigma of the inclination difference with the inclination taken as
    what it is, the length of the tilt vector from the vertical (down or
    up): Rice-distributed, its spread sqrt((4 - pi) / 2) = 0.66 of the
    linearised one at the vertical, the linearised one a few sigma off it.
    sigma_d: the linearised 1-sigma of the difference (sqrt 2 x each
    survey's spread per tilt axis); the true tilt's square estimated from
    the two surveys' (their mean square less the noise's 2 s^2)."""
    from scipy.special import i0e, i1e

    sigma_d = np.asarray(sigma_d, float)
    s = sigma_d / math.sqrt(2.0)
    off_a = np.minimum(inc_a, 180.0 - np.asarray(inc_a, float))  # from the vertical, down or up
    off_b = np.minimum(inc_b, 180.0 - np.asarray(inc_b, float))
    tilt2 = np.maximum(0.5 * (off_a ** 2 + off_b ** 2) - 2.0 * s * s, 0.0)
    with np.errstate(divide="ignore", invalid="ignore", over="ignore"):
        y = tilt2 / (4.0 * s * s)  # the Rice mean: s sqrt(pi/2) L_1/2(-2y), L_1/2(-2y) = (1 + 2y) i0e(y) + 2y i1e(y)
        mean = s * math.sqrt(math.pi / 2.0) * ((1.0 + 2.0 * y) * i0e(y) + 2.0 * y * i1e(y))
        out = np.sqrt(2.0 * np.maximum(2.0 * s * s + tilt2 - mean * mean, 0.0))
    # beyond ~100 sigma off the vertical the linearised spread is exact to 1e-3 (and the formula cancels digits)
    return np.where(np.isfinite(out) & (s > 0) & (y < 1e4), np.minimum(out, sigma_d), sigma_d)


def pair_stations(md_a, md_b, md_tol):
    """(ia, ib): each station of a (in order) with the nearest station of b
    by measured depth (the shallower of two equally near), when within
    md_tol and not taken by an earlier station of a.  Sorted search: time
    n log n (a search of every b station for each a station took 6 ms a pair
    at 10^5 pairs)."""
    md_a, md_b = np.asarray(md_a, float), np.asarray(md_b, float)
    if not len(md_a) or not len(md_b):
        return np.zeros(0, int), np.zeros(0, int)
    order = np.argsort(md_b, kind="stable")
    sb = md_b[order]
    k = np.clip(np.searchsorted(sb, md_a), 1, len(sb) - 1) if len(sb) > 1 else np.zeros(len(md_a), int)
    lo = np.maximum(k - 1, 0)
    near = np.where(np.abs(sb[k] - md_a) < np.abs(sb[lo] - md_a), k, lo)
    # the lowest index among equal depths and equal distances, as a scan of b in order finds it
    j = order[near]
    ok = np.abs(md_b[j] - md_a) <= md_tol
    ia = np.flatnonzero(ok)
    _, first = np.unique(j[ia], return_index=True)  # a station of b goes to the first station of a that wants it
    ia = np.sort(ia[first])
    return ia, j[ia]


def _rms(v):
    v = [x for x in v if x is not None]
    return float(np.sqrt(np.mean(np.square(v)))) if v else None
