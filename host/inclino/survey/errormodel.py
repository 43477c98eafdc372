"""The calibrated probe's error model in ISCWSA / OWSG form.

A planner's anti-collision software describes a survey tool by a named list
of error terms, each a 1-sigma magnitude, a propagation mode (random per
station, systematic per run, per well, global) and weighting functions
(d inc / d e, d azi / d e) of the station's attitude and the reference
field.  This module writes the probe as such a tool model (the ISCWSA JSON
tool-model format of the ISCWSA error-model revision 5, as welleng reads and
ships it) and evaluates it with welleng.

Terms and where their magnitudes come from:

* sensor terms, systematic over a run -- correlated combination terms
  ABMS-CALnn (toolface-independent) and ABMSXY-CALnn (what a turn of the
  probe changes; see `project`): the calibration's covariance of its 24
  coefficients carried exactly, to first order, correlations included.
  The errors of the corrected readings seen from the toolface frame (21
  SOURCES: the triads' bias, scale and misalignment) each have a weighting
  function of (Inc, AzM, Dip, BField, Gfield); their covariance, averaged
  over the toolface, follows from the coefficients'; each term is one of
  its eigenvectors, its weighting function that combination of the
  sources'.  So the model's toolface-averaged inclination and azimuth
  (co)variance is the covariance's at every attitude, dip and field,
  upward holes included (the covariance's bias-scale correlations make
  the error asymmetric about 90 deg, which independent terms, each
  symmetric, cannot be: the projection onto the standard MWD terms this
  replaced under-stated upward holes by up to 1.6x).  The standard terms
  (ABXY-TI1S .. MSZ, XYM1..XYM4 of the ISCWSA-issued OWSG model MWD+SRGM,
  read from welleng's copy) are still written, with 0, for editing and for
  models written before.  `monte_carlo` checks the result against random
  draws of the coefficients, 5-175 deg.
* sensor noise, random per station -- the same weighting functions with
  propagation "Random" (names ending in R: ABXY-TI1R, ...), magnitudes the
  measured per-axis noise of one survey (the spread of G total and B total
  over repeated surveys at rest, or given values).
* reference-field terms (declination, horizontal-field crustal terms) --
  added for the survey's reference by `reference_terms`: the OWSG values for
  a standard-resolution main-field model (MWD+SRGM) or for in-field
  referencing (MWD+IFR1), or none.

Not in the probe's model: the depth terms (the depth system's), the
tool-axis misalignment and sag terms (XYM, SAG: the tool's centralisation in
the hole), axial interference.  inclino.survey.models sets the probe's terms
into a standard model that has them (`--tool-model iscwsa-mwd-rev5 --cal`).

Revision: the terms are written in ISCWSA revision 5 (default; XYM3E/XYM4E
random with the short-course damping, as Rev 5 and the OWSG models
propagate them) or 4 (XYM3/XYM4 systematic, undamped); the metadata states
it (`revision_number`, `framework`).
"""
from __future__ import annotations

import json
import math
from dataclasses import asdict, dataclass, field

import numpy as np

from inclino.errors import DataError
from inclino.formats.jsonout import dumps

G0 = 9.80665
SENSOR_TERMS = ("ABXY-TI1S", "ABXY-TI2S", "ABZ", "ASXY-TI1S", "ASXY-TI2S", "ASXY-TI3S", "ASZ",
                "MBXY-TI1S", "MBXY-TI2S", "MBZ", "MSXY-TI1S", "MSXY-TI2S", "MSXY-TI3S", "MSZ",
                "XYM1", "XYM2", "XYM3E", "XYM4E")
# magnitude groups: one value per group (the TI1/TI2/TI3 parts of an XY term share it)
GROUPS = {"ABXY": ("ABXY-TI1S", "ABXY-TI2S"), "ABZ": ("ABZ",),
          "ASXY": ("ASXY-TI1S", "ASXY-TI2S", "ASXY-TI3S"), "ASZ": ("ASZ",),
          "MBXY": ("MBXY-TI1S", "MBXY-TI2S"), "MBZ": ("MBZ",),
          "MSXY": ("MSXY-TI1S", "MSXY-TI2S", "MSXY-TI3S"), "MSZ": ("MSZ",),
          "XYM1": ("XYM1",), "XYM2": ("XYM2",), "XYM34": ("XYM3", "XYM4")}
NOISE_GROUPS = {"ABXY-R": ("ABXY-TI1S", "ABXY-TI2S"), "ABZ-R": ("ABZ",),
                "MBXY-R": ("MBXY-TI1S", "MBXY-TI2S"), "MBZ-R": ("MBZ",)}
REF_TERMS = {"srgm": ("MWD+SRGM", ("DEC-U", "DEC-OS", "DEC-OH", "DEC-OI", "DECR", "DBH-U", "DBH-OS", "DBH-OH",
                                   "DBH-OI", "DBHR")),
             "ifr1": ("MWD+IFR1+AX", ("DEC-U", "DEC-CI", "DEC-OI", "DECR", "DBH-U", "DBH-CI", "DBH-OI", "DBHR")),
             "none": (None, ())}


def _owsg(short_name: str) -> dict:
    import welleng

    path = f"{welleng.__path__[0]}/errors/iscwsa_json/owsg_a/{short_name}.json"
    with open(path, encoding="utf-8") as f:
        return json.load(f)


def _template_terms(revision: int = 4) -> dict:
    """The OWSG MWD+SRGM terms this model uses, keyed by GROUPS' names.
    XYM3/XYM4 (the calibration's misalignment in the toolface-independent
    form): ISCWSA Rev 4's XYM3/XYM4, systematic, no damping (Rev 5's
    XYM3E/XYM4E weighting without the damping factor; checked against
    welleng's Rev 4 model in the tests).  In revision 5 ISCWSA's XYM3E/XYM4E
    are random (the tool's misalignment in the hole changes from station to
    station): the calibration's misalignment does not, so a revision 5 file
    names these terms XYM3-CAL/XYM4-CAL, systematic, and leaves XYM3E/XYM4E
    to the standard model they may be set into (models.ErrorModel)."""
    out = {}
    for t in _owsg("MWD+SRGM")["terms"]:
        if t["name"] not in SENSOR_TERMS:
            continue
        t = dict(t)
        if t["name"] in ("XYM3E", "XYM4E"):
            t["name"] = t["name"][:-1] + ("-CAL" if revision >= 5 else "")
            t["propagation_mode"] = "Systematic"
            t["description"] = ("the calibration's triad misalignment in the XYM3/XYM4 weighting (systematic over "
                                "the run)")
            for k in ("inclination_formula", "azimuth_formula", "north_singularity", "east_singularity"):
                if isinstance(t.get(k), str):
                    t[k] = t[k].replace("* Max(1, sqrt(10/(MD-MDPrev)))", "").replace("Max(1, sqrt(10/(MD-MDPrev)))", "1")
        out[t["name"][:4] if t["name"].startswith(("XYM3", "XYM4")) else t["name"]] = t
    return out


def _in_units(v_si: float, unit: str) -> float:
    """A magnitude held in SI (rad for angles) in the term's declared unit."""
    return math.degrees(v_si) if unit == "deg" else v_si


def _noise_name(name: str) -> str:
    return name[:-1] + "R" if name.endswith("S") else name + "R"


@dataclass
class ToolModel:
    """The probe's error terms: magnitudes per group (SI: m/s^2, nT,
    dimensionless scale), the noise per survey, and where they came from."""
    name: str = "INCLINO"
    systematic: dict = field(default_factory=dict)  # GROUPS key -> 1 sigma
    noise: dict = field(default_factory=dict)  # NOISE_GROUPS key -> 1 sigma per survey
    fit: dict = field(default_factory=dict)  # how the projection matched (relative RMS, attitudes)
    source: dict = field(default_factory=dict)
    revision: int = 5  # the ISCWSA revision its terms are written in (XYM3/XYM4 as that revision propagates them)
    # correlated combination terms: name -> {SOURCES name: coefficient (SI per unit)}; magnitude in systematic
    correlated: dict = field(default_factory=dict)

    def __post_init__(self):
        # a magnitude of 0 is no term: never written (welleng evaluates a term written with 0 as 0 x its weight,
        # and an azimuth weight is infinite at the vertical: NaN), never evaluated; a file written before with
        # the standard terms at 0 reads as the same model without them
        self.systematic = {k: v for k, v in self.systematic.items() if v != 0.0}
        self.noise = {k: v for k, v in self.noise.items() if v != 0.0}

    def to_json(self) -> str:
        return dumps(asdict(self))

    def terms(self, revision: int | None = None) -> list:
        """The ISCWSA JSON terms (the weighting functions of the OWSG
        MWD+SRGM model, this probe's magnitudes) in `revision` (default its own)."""
        tpl = _template_terms(self.revision if revision is None else revision)
        out = []
        for g, names in GROUPS.items():  # the standard terms a model has (none where the combination terms
            if g not in self.systematic:  # carry the calibration)
                continue
            for n in names:
                t = dict(tpl[n])
                t["value"] = _in_units(float(self.systematic[g]), t["units"])
                t["hash_value"] = "0" * 32
                out.append(t)
        for n, w in self.correlated.items():
            if n not in self.systematic:
                continue
            t = correlated_term(n, float(self.systematic[n]), w)
            t["hash_value"] = "0" * 32
            out.append(t)
        for g, names in NOISE_GROUPS.items():
            if g not in self.noise:
                continue
            for n in names:
                t = dict(tpl[n])
                t["name"] = _noise_name(n)
                t["value"] = float(self.noise[g])
                t["propagation_mode"] = "Random"
                t["hash_value"] = "0" * 32
                out.append(t)
        return out

    def iscwsa(self, reference: str = "none", revision: int | None = None) -> dict:
        """The tool model as an ISCWSA JSON dict (welleng ErrorModel loads it
        as is), with the reference-field terms of `reference` appended."""
        rev = self.revision if revision is None else revision
        return {"metadata": {"model_id": self.name, "short_name": self.name,
                             "long_name": f"{self.name}: calibrated magnetic probe (inclino)",
                             "revision_number": rev, "tool_type": "Magnetic", "framework": f"ISCWSA Rev{rev}",
                             "source": "inclino toolmodel: " + json.dumps(self.source, sort_keys=True),
                             "author": "inclino", "application": "magnetic survey probe, calibrated",
                             "reference_terms": reference},
                "parameters": {"inc_min": 0, "inc_max": 180},
                "terms": self.terms(rev) + reference_terms(reference)}

    def save(self, path: str, reference: str = "none") -> None:
        d = self.iscwsa(reference)
        d["inclino"] = asdict(self)
        try:  # every number finite: never NaN in the file (a degenerate model is refused before this)
            text = json.dumps(d, indent=2, allow_nan=False)
        except ValueError:
            raise DataError("the tool model has a value that is not a finite number; nothing written") from None
        _write(path, text + "\n")

    @staticmethod
    def from_dict(d, where: str = "tool model") -> "ToolModel":
        """The "inclino" block of a tool model file, every field by its rule
        (type and range: one DataError line naming the file and the field)."""
        from inclino.formats.fields import Fields

        f = Fields(d, f"{where}: inclino")
        name = f.string("name", required=False, default="INCLINO", max_len=64)
        out = {}
        corr = {}
        c = f.obj("correlated", required=False)
        if c is not None:
            for k in c.d:
                if not is_correlated_name(k):
                    raise DataError(f"{c.where}: {str(k)[:20]!r} is not a correlated term's name "
                                    f"({CORRELATED_PREFIX}NN or {CORRELATED_PREFIX_XY}NN)")
                w = c.obj(k)
                for b in w.d:
                    if b not in SOURCES:
                        raise DataError(f"{w.where}: unknown source {str(b)[:20]!r} (known: "
                                        f"{', '.join(SOURCES)})")
                corr[k] = {b: w.number(b, -1e6, 1e6) for b in w.d}
        for key, groups in (("systematic", {**GROUPS, **corr}), ("noise", NOISE_GROUPS)):
            g = f.obj(key, required=False)
            out[key] = {}
            if g is None:
                continue
            for k in g.d:
                if k not in groups:
                    raise DataError(f"{g.where}: unknown term group {str(k)[:20]!r} (known: {', '.join(groups)})")
            # magnitudes in SI (m/s^2, nT, scale, rad): finite, >= 0, within what a probe could have
            out[key] = {k: g.number(k, 0.0, 1e6) for k in g.d}
        fit = f.obj("fit", required=False)
        fd = {}
        if fit is not None:
            fd = dict(fit.d)
            if fit.has("dip_deg"):
                fd["dip_deg"] = fit.number("dip_deg", -90.0, 90.0, lo_open=True, hi_open=True)
            if fit.has("field_nT"):
                fd["field_nT"] = fit.number("field_nT", 0.0, 2e5, lo_open=True)
        src = f.obj("source", required=False)
        rev = f.integer("revision", 4, 5, required=False, default=5)
        return ToolModel(name=name, systematic=out["systematic"], noise=out["noise"], fit=fd,
                         source=dict(src.d) if src is not None else {}, revision=rev, correlated=corr)


def reference_terms(which: str) -> list:
    if which not in REF_TERMS:
        raise DataError(f"unknown reference-field terms {which!r} (srgm, ifr1 or none)")
    model, names = REF_TERMS[which]
    if model is None:
        return []
    return [t for t in _owsg(model)["terms"] if t["name"] in names]


def _write(path: str, text: str) -> None:
    """Through inclino.formats.safeio: atomic, never over a device or a symlink's
    place, the target's mode kept."""
    from inclino.formats import safeio

    safeio.write_output(path, text)


# ---------------------------------------------------------------- weights

def weights(names, inc_deg, azm_deg, dip_deg, field_nT, gravity=G0):
    """(d inc / d e, d azi / d e) of each named template term at the
    attitudes, rad per unit of the term (welleng's formula interpreter)."""
    from welleng.errors.interpreter import evaluate_formula

    tpl = _template_terms()
    inc = np.radians(np.asarray(inc_deg, float))
    azm = np.radians(np.asarray(azm_deg, float))
    b = {"Inc": inc, "AzM": azm, "AzT": azm, "Az": azm, "Dip": math.radians(dip_deg), "BField": field_nT,
         "Bfield": field_nT, "Gfield": gravity, "GField": gravity, "RAD": math.pi / 180.0}
    wi, wa = [], []
    for n in names:
        t = tpl[n]
        wi.append(np.broadcast_to(np.asarray(evaluate_formula(t["inclination_formula"], b), float), inc.shape))
        wa.append(np.broadcast_to(np.asarray(evaluate_formula(t["azimuth_formula"], b), float), inc.shape))
    return np.array(wi), np.array(wa)


def station_sigma(tm: ToolModel, inc_deg, azm_deg, dip_deg, field_nT, systematic=True, noise=True):
    """Inclination and azimuth 1 sigma (deg) of single stations from the
    tool model's sensor terms (root sum of squares of magnitude x weight)."""
    vi = np.zeros(np.shape(inc_deg))
    va = np.zeros(np.shape(inc_deg))
    parts = []
    if systematic:  # the terms the model has (ToolModel holds no magnitude of 0)
        parts += [(GROUPS[g], tm.systematic[g]) for g in GROUPS if g in tm.systematic]
    if noise:
        parts += [(NOISE_GROUPS[g], tm.noise[g]) for g in NOISE_GROUPS if g in tm.noise]
    for names, mag in parts:
        wi, wa = weights(names, inc_deg, azm_deg, dip_deg, field_nT)
        vi += mag ** 2 * np.sum(wi ** 2, axis=0)
        va += mag ** 2 * np.sum(wa ** 2, axis=0)
    if systematic:
        for n, w in tm.correlated.items():
            if n not in tm.systematic:
                continue
            wi, wa = correlated_weights(w, inc_deg, azm_deg, dip_deg, field_nT)
            mag = tm.systematic[n]
            vi += mag ** 2 * wi ** 2
            va += mag ** 2 * wa ** 2
    return np.degrees(np.sqrt(vi)), np.degrees(np.sqrt(va))


# ------------------------------------------------- from the calibration

def _attitude(acc, mag):
    from inclino.engines import reference as ref

    a = ref.attitude(acc, mag)
    return a["inc"], a["azi"]


def _truth(cal, inc, azi, tf, dip, field_nT, gravity=1.0):
    """The raw readings a probe with calibration `cal` (taken as exact)
    gives at these poses: corrected = M (raw - b)  =>  raw = M^-1 u + b."""
    from inclino.engines import reference as ref

    g, b = ref.body_vectors(inc, azi, tf, field_nT, dip)
    g = g * gravity
    Ma, Mm = np.asarray(cal.acc_m, float), np.asarray(cal.mag_m, float)
    ra = np.linalg.solve(Ma, g.T).T + np.asarray(cal.acc_b, float)
    rm = np.linalg.solve(Mm, b.T).T + np.asarray(cal.mag_b, float)
    return ra, rm


def _apply(vec, ra, rm):
    """Corrected readings with the 24-vector of coefficients `vec` (PARAM_NAMES order)."""
    Ma, ba = vec[0:9].reshape(3, 3), vec[9:12]
    Mm, bm = vec[12:21].reshape(3, 3), vec[21:24]
    return (ra - ba) @ Ma.T, (rm - bm) @ Mm.T


def calibration_covariance(cal):
    """(24x24 covariance, what it is) from a calibration file's fit report:
    the full covariance when the report carries it, else the coefficients'
    1-sigma as a diagonal."""
    from inclino.calib.common import PARAM_NAMES
    from inclino.errors import CalibrationError
    from inclino.formats.fields import check_array, check_number

    unc = (cal.report or {}).get("uncertainty") or {}
    if not isinstance(unc, dict):
        raise CalibrationError("the calibration file's report: uncertainty must be a JSON object")
    where = "the calibration file's report: uncertainty"
    cov = unc.get("covariance")
    if cov is not None:  # the rules: 24 x 24 finite numbers, symmetric, positive semi-definite, not all zero
        c = check_array(cov, f"{where}: covariance", (24, 24), error=CalibrationError)
        c = 0.5 * (c + c.T)
        w = np.linalg.eigvalsh(c)
        if not w.max() > 0 or w.min() < -1e-9 * w.max() or np.any(np.diag(c) < 0):
            raise CalibrationError(f"{where}: covariance is not a covariance (eigenvalues {w.min():.3g} to "
                                   f"{w.max():.3g}: it must be positive semi-definite and not zero)")
        return c, "the fit's covariance of the 24 coefficients"
    sig = unc.get("sigma")
    if sig is not None:
        if not isinstance(sig, dict) or not all(k in sig for k in PARAM_NAMES):
            raise CalibrationError(f"{where}: sigma must give the 1-sigma of each of the 24 coefficients "
                                   f"({PARAM_NAMES[0]} ... {PARAM_NAMES[-1]})")
        s = np.array([check_number(sig[k], f"{where}: sigma: {k}", 0.0, 1e6, error=CalibrationError)
                      for k in PARAM_NAMES])
        if not s.max() > 0:
            raise CalibrationError(f"{where}: sigma is zero for every coefficient")
        return np.diag(s ** 2), "the coefficients' 1-sigma (diagonal: the report has no covariance)"
    raise DataError("the calibration file has no uncertainty (fit report) to build an error model from; "
                    "calibrate with a method that reports one")


def _grid(n_tf=12):
    inc = np.array([5.0, 15, 30, 45, 60, 75, 90, 105, 120, 135, 150, 165, 175])
    azi = np.arange(0.0, 360.0, 15.0)
    I, A = np.meshgrid(inc, azi, indexing="ij")
    return I.ravel(), A.ravel(), np.arange(n_tf) * 360.0 / n_tf


def station_jacobian(cal, cov, inc, azi, tf, dip, field_nT, gravity=1.0, declination=0.0, h=None):
    """At each attitude (inclination, magnetic azimuth, gravity toolface,
    deg; arrays of one length n), how the survey moves with the
    calibration's 24 coefficients (PARAM_NAMES order), linearised by central
    differences (steps of each coefficient's 1 sigma in `cov`, or h):
    (d(inc, azi)/dc, rad per unit, (2, n, 24); d(tool axis)/dc, (n, 3, 24)).
    The tool axis is the unit vector (sin I cos A, sin I sin A, cos I) in
    north, east, vertical (down), A the azimuth from true north
    (magnetic + declination): smooth at the vertical, where the azimuth's
    derivative is not."""
    from inclino.calib.common import cal_vector

    x0 = cal_vector(cal)
    inc, azi, tf = (np.asarray(v, float).ravel() for v in (inc, azi, tf))
    ra, rm = _truth(cal, inc, azi, tf, dip, field_nT, gravity)
    sd = np.sqrt(np.clip(np.diag(cov), 0, None))

    def axis(i, a):
        i, a = np.radians(i), np.radians(a + declination)
        return np.stack([np.sin(i) * np.cos(a), np.sin(i) * np.sin(a), np.cos(i)], axis=-1)

    J = np.zeros((2, len(inc), 24))
    T = np.zeros((len(inc), 3, 24))
    for k in range(24):
        step = h if h is not None else max(sd[k], 1e-9 * max(1.0, abs(x0[k])))
        xp, xm = x0.copy(), x0.copy()
        xp[k] += step
        xm[k] -= step
        ip, ap = _attitude(*_apply(xp, ra, rm))
        im, am = _attitude(*_apply(xm, ra, rm))
        J[0, :, k] = np.radians(ip - im) / (2 * step)
        J[1, :, k] = np.radians(((ap - am + 180.0) % 360.0) - 180.0) / (2 * step)
        T[:, :, k] = (axis(ip, ap) - axis(im, am)) / (2 * step)
    return J, T


def linear_variance(cal, cov, inc, azi, tfs, dip, field_nT, gravity=1.0, h=None):
    """Toolface-averaged inclination/azimuth variance (rad^2) the coefficient
    covariance gives at each (inc, azi), linearised (central differences)."""
    n, m = len(inc), len(tfs)
    J, _ = station_jacobian(cal, cov, np.repeat(inc, m), np.repeat(azi, m), np.tile(tfs, n), dip, field_nT,
                            gravity, h=h)
    v = np.einsum("snk,kl,snl->sn", J, cov, J)
    return v[0].reshape(n, m).mean(axis=1), v[1].reshape(n, m).mean(axis=1)


def run_covariance(cal, cov, md, inc, azi, tf, dip, field_nT, gravity=1.0, declination=0.0):
    """The position (north, east, vertical; m^2, (n, 3, 3)) and survey
    (depth, inclination, azimuth; (n, 3, 3)) covariance per station of a
    run surveyed with this calibration, its coefficients' error one draw
    for the whole run (systematic), each station at its own toolface.

    The toolface-averaged combination terms (`project`) describe a probe
    that turns at random between stations; a run at one toolface adds the
    X/Y errors up along the hole instead, beyond those terms' ellipse (the
    survey benchmark's one-toolface runs, `inclino bench survey`).  Here
    each station's error is the calibration's at the attitude it was
    surveyed in.  Position: the balanced-tangential first
    order of minimum curvature (as ISCWSA propagates), course j moving
    station K (K >= j) by dMD_j (e_{j-1} + e_j) / 2, e the tool axis's
    error; the first station (the tie-in) is taken as exact, its attitude's
    error moving the course below it."""
    md = np.asarray(md, float)
    J, T = station_jacobian(cal, cov, inc, azi, tf, dip, field_nT, gravity, declination)
    dmd = np.diff(md)
    course = 0.5 * dmd[:, None, None] * (T[:-1] + T[1:])  # (n-1, 3, 24)
    M = np.concatenate([np.zeros((1, 3, 24)), np.cumsum(course, axis=0)])
    nev = np.einsum("nik,kl,njl->nij", M, cov, M)
    dia = np.zeros((len(md), 3, 3))
    dia[:, 1:, 1:] = np.einsum("snk,kl,tnl->nst", J, cov, J)
    return nev, dia


# The correlated part of the model.  A joint calibration's covariance correlates each axis's bias with its scale,
# the accelerometer's errors with the fluxgate's, and so on: the error it gives is not symmetric about
# inclination 90 deg (an ABZ x ASZ cross term goes as sin^2(I) cos(I)), and independent ISCWSA terms, each
# symmetric, under-stated upward holes by up to 1.6x.  So the probe's systematic terms are the calibration
# covariance itself, carried exactly (to first order) in ISCWSA form:
#
# * the error of a corrected reading is du = A u + beta (A = dM M^-1, beta = -M db: 24 coefficients' errors);
# * seen from the toolface frame (the body frame at toolface 0) it is A~ u0 + beta~, A~ = Rz^T A Rz,
#   beta~ = Rz^T beta; the inclination and azimuth depend on A~ and beta~ through weighting functions of
#   (Inc, AzM, Dip, BField, Gfield) alone: w_i u0_j and w_i (SOURCES, w the gradient of inclination or
#   azimuth with respect to the reading, u0 the true reading at toolface 0);
# * the covariance of (A~, beta~), averaged over a toolface the probe takes at random, follows from the
#   calibration covariance (exactly: the average of trigonometric polynomials of degree <= 4 over 16
#   toolfaces);
# * its eigenvectors are the terms ("correlated combination terms", ABMS-CALnn and ABMSXY-CALnn: the
#   toolface-independent part and the rest, each decomposed on its own): each an independent
#   systematic error whose weighting function is its eigenvector's combination of the sources' weighting
#   functions.  Their sum of squares is the covariance's toolface-averaged inclination and azimuth
#   covariance at every attitude, dip and field: no projection, nothing fitted.
# "AB...": the sensor family (models.family); CAL: the calibration's.  The toolface-independent part (the
# mean over the toolface: Z bias and scale, the X/Y scales' mean, ...) is ABMS-CALnn; what a turn of the probe
# changes (the X/Y biases, the scales' difference, the cross-axis terms: harmonics 1 and 2 of the toolface) is
# ABMSXY-CALnn, an X/Y term as `compare` counts them for the same probe at another toolface.  The two parts are
# uncorrelated once averaged over the toolface, so the model is their sum.
CORRELATED_PREFIX = "ABMS-CAL"
CORRELATED_PREFIX_XY = "ABMSXY-CAL"
_GRAD = {  # inclination, azimuth, lateral (sin(Inc) x azimuth: finite at the vertical) per unit reading error
    "ACC": (("-Cos(Inc) / Gfield", "0", "-Sin(Inc) / Gfield"),
            ("Tan(Dip) * Cos(Inc) * Sin(AzM) / Gfield", "(Tan(Dip) * Cos(AzM) - Tan((pi / 2) - Inc)) / Gfield",
             "Tan(Dip) * Sin(Inc) * Sin(AzM) / Gfield"),
            ("Tan(Dip) * Sin(Inc) * Cos(Inc) * Sin(AzM) / Gfield",
             "(Tan(Dip) * Cos(AzM) * Sin(Inc) - Cos(Inc)) / Gfield",
             "Tan(Dip) * Sin(Inc) * Sin(Inc) * Sin(AzM) / Gfield")),
    "MAG": (("0", "0", "0"),
            ("-Cos(Inc) * Sin(AzM) / (BField * Cos(Dip))", "-Cos(AzM) / (BField * Cos(Dip))",
             "-Sin(Inc) * Sin(AzM) / (BField * Cos(Dip))"),
            ("-Sin(Inc) * Cos(Inc) * Sin(AzM) / (BField * Cos(Dip))", "-Sin(Inc) * Cos(AzM) / (BField * Cos(Dip))",
             "-Sin(Inc) * Sin(Inc) * Sin(AzM) / (BField * Cos(Dip))"))}
_U0 = {"ACC": ("-Gfield * Sin(Inc)", None, "Gfield * Cos(Inc)"),  # the true reading at toolface 0
       "MAG": ("BField * (Cos(Inc) * Cos(AzM) * Cos(Dip) - Sin(Inc) * Sin(Dip))", "-BField * Sin(AzM) * Cos(Dip)",
               "BField * (Sin(Inc) * Cos(AzM) * Cos(Dip) + Cos(Inc) * Sin(Dip))")}


_DEN = {"ACC": (" / Gfield", "Gfield"), "MAG": (" / (BField * Cos(Dip))", "(BField * Cos(Dip))")}
_UNIT = {"ACC": ("Gfield * ", "-Gfield * "), "MAG": ("BField * ", "-BField * ")}


def _strip(f: str, suffix: str) -> str:
    assert f == "0" or f.endswith(suffix), (f, suffix)
    return f if f == "0" else f[:-len(suffix)]


def _unit(f: str, s: str) -> str:
    """The true reading's component without its field factor (Gfield, BField), sign kept."""
    plus, minus = _UNIT[s]
    if f.startswith(minus):
        return "-" + f[len(minus):]
    assert f.startswith(plus), f
    return f[len(plus):]


def _source_parts():
    """name -> (denominator or None, (inclination, azimuth, lateral numerator)):
    each toolface-frame error's weights with the field factors cancelled
    (an ACC M term's weight, gradient / Gfield times the reading Gfield x
    unit, is gradient x unit; a MAG M term's has 1 / Cos(Dip) left)."""
    out = {}
    for s in ("ACC", "MAG"):
        suffix, den = _DEN[s]
        g = [[_strip(w, suffix) for w in row] for row in _GRAD[s]]
        for i in range(3):
            for j in range(3):
                if _U0[s][j] is None:
                    continue  # the reading has no such component: no weight
                u = _unit(_U0[s][j], s)
                out[f"{s}-M{i}{j}"] = (None if s == "ACC" else "Cos(Dip)",
                                       tuple("0" if w[i] == "0" else f"({w[i]}) * ({u})" for w in g))
        for i in range(3):
            out[f"{s}-B{i}"] = (den, tuple(w[i] for w in g))
    return out


_SOURCE_PARTS = _source_parts()
_DEN_ORDER = (None, "Gfield", "Cos(Dip)", "(BField * Cos(Dip))")


def _sources():
    """name -> (inclination, azimuth, lateral formula): the toolface-frame errors
    (ACC/MAG M{ij}: dimensionless, ACC B{i}: m/s^2, MAG B{i}: nT)."""
    return {n: tuple("0" if f == "0" else f if den is None else f"({f}) / {den}" for f in nums)
            for n, (den, nums) in _SOURCE_PARTS.items()}


SOURCES = _sources()


def correlated_name(k: int, xy: bool = False) -> str:
    return f"{CORRELATED_PREFIX_XY if xy else CORRELATED_PREFIX}{k + 1:02d}"


def is_correlated_name(name) -> bool:
    import re

    return isinstance(name, str) and re.fullmatch(f"({CORRELATED_PREFIX}|{CORRELATED_PREFIX_XY})[0-9]{{2,3}}", name) \
        is not None


def _combine(weights: dict, part: int) -> str:
    """The combination's weight formula: the sources' numerators over each common denominator."""
    groups = {}
    for n, c in weights.items():
        den, nums = _SOURCE_PARTS[n]
        if nums[part] != "0":
            groups.setdefault(den, []).append(f"{float(c)!r} * ({nums[part]})")
    parts = []
    for den in _DEN_ORDER:
        if den in groups:
            sum_ = " + ".join(groups[den])
            parts.append(sum_ if den is None else f"({sum_}) / {den}")
    return " + ".join(parts) if parts else "0"


def correlated_term(name: str, value: float, weights: dict) -> dict:
    """An ISCWSA JSON term: systematic, magnitude `value` (dimensionless), its
    weighting functions the combination `weights` (source -> coefficient) of
    the sources'; at a vertical station, the position weights of ISCWSA's
    singular vectors (inclination along Az, lateral across it)."""
    inc, lat = _combine(weights, 0), _combine(weights, 2)
    return {"name": name, "x_owsg_weight_function": "inclino: correlated combination", "value": float(value),
            "units": "-", "depth_factor": 1, "inclination_factor": 0, "azimuth_factor": 0,
            "propagation_mode": "Systematic", "depth_formula": "0", "inclination_formula": inc,
            "azimuth_formula": _combine(weights, 1),
            "north_singularity": f"({inc}) * Cos(Az) - ({lat}) * Sin(Az)",
            "east_singularity": f"({inc}) * Sin(Az) + ({lat}) * Cos(Az)", "vertical_singularity": "0",
            "description": "the calibration's correlated sensor errors (bias, scale, misalignment of both triads): "
                           "one eigenvector of their toolface-averaged covariance (inclino toolmodel)"}


def _bindings(inc_deg, azm_deg, dip_deg, field_nT, gravity_si=G0):
    inc = np.radians(np.asarray(inc_deg, float))
    azm = np.radians(np.asarray(azm_deg, float))
    return {"Inc": inc, "AzM": azm, "AzT": azm, "Az": azm, "Dip": math.radians(dip_deg), "BField": field_nT,
            "Bfield": field_nT, "Gfield": gravity_si, "GField": gravity_si, "RAD": math.pi / 180.0}


def correlated_weights(weights: dict, inc_deg, azm_deg, dip_deg, field_nT, gravity_si=G0):
    """(d inc, d azi) per unit of a combination term at the attitudes, rad
    (the formulas it is written with, by welleng's interpreter)."""
    from welleng.errors.interpreter import evaluate_formula

    b = _bindings(inc_deg, azm_deg, dip_deg, field_nT, gravity_si)
    shape = np.shape(b["Inc"])
    return tuple(np.broadcast_to(np.asarray(evaluate_formula(_combine(weights, p), b), float), shape)
                 for p in (0, 1))


def source_covariance(cal, cov, n_tf=16):
    """(names, covariance, covariance of the toolface mean) of the
    toolface-frame errors SOURCES from the coefficient covariance: averaged
    over the toolface (uniform), and that of their toolface-independent
    part (the sources' mean over the toolface; the rest, their total less
    this, is what a turn of the probe changes)."""
    from inclino.engines import reference as ref

    names = list(SOURCES)
    idx = {n: k for k, n in enumerate(names)}
    Ma, Mm = np.asarray(cal.acc_m, float), np.asarray(cal.mag_m, float)
    iMa, iMm = np.linalg.inv(Ma), np.linalg.inv(Mm)
    S = np.zeros((len(names), len(names)))
    Pm = np.zeros((len(names), 24))
    for T in np.arange(n_tf) * 360.0 / n_tf:
        Rz = np.asarray(ref.pose_matrix(0.0, 0.0, T), float)
        P = np.zeros((len(names), 24))
        for k in range(24):
            d = np.zeros(24)
            d[k] = 1.0
            for s, dM, db, M, iM, unit in (("ACC", d[0:9], d[9:12], Ma, iMa, G0), ("MAG", d[12:21], d[21:24], Mm, iMm, 1.0)):
                A = Rz.T @ (dM.reshape(3, 3) @ iM) @ Rz
                beta = Rz.T @ (-(M @ db)) * unit
                for i in range(3):
                    for j in range(3):
                        if f"{s}-M{i}{j}" in idx:
                            P[idx[f"{s}-M{i}{j}"], k] = A[i, j]
                    P[idx[f"{s}-B{i}"], k] = beta[i]
        S += P @ cov @ P.T
        Pm += P / n_tf
    S0 = Pm @ cov @ Pm.T
    return names, 0.5 * (S + S.T) / n_tf, 0.5 * (S0 + S0.T)


# How the combination terms' coefficients are written: 7 significant digits (a coefficient moves by at most
# 5e-8 of itself), and a source whose share of a term is below PRUNE_REL of the term's largest possible weight
# (each source's weight at its largest over the attitude grid, dips -80..80 deg and total fields 25000-65000 nT)
# left out.  The eigenvectors carry the rounding of the eigensolver (shares of 1e-16 .. 1e-30 of a term): the
# file held every one of them with 17 digits, 196 kB for one probe.
COEF_DIGITS = 7
PRUNE_REL = 1e-7
_SCALE_DIPS = (-80.0, -60.0, -30.0, 0.0, 30.0, 60.0, 80.0)
_SCALE_FIELDS = (25000.0, 65000.0)


def source_scale(dip, field_nT, gravity_si=G0) -> dict:
    """source -> the largest |weight| (inclination, and lateral: sin(Inc) x
    azimuth, finite at the vertical) over the attitude grid, at `dip` and
    `field_nT` and at dips -80..80 deg and total fields 25000-65000 nT."""
    from welleng.errors.interpreter import evaluate_formula

    inc, azi, _ = _grid()
    inc = np.r_[0.0, inc, 180.0]
    azi = np.r_[0.0, azi, 0.0]
    out = dict.fromkeys(SOURCES, 0.0)
    for d in set(_SCALE_DIPS) | {float(dip)}:
        for f in set(_SCALE_FIELDS) | {float(field_nT)}:
            b = _bindings(inc, azi, d, f, gravity_si)
            for n, (fi, _, fl) in SOURCES.items():
                for form in (fi, fl):
                    w = np.abs(np.asarray(evaluate_formula(form, b), float))
                    out[n] = max(out[n], float(np.max(w)))
    return out


def _eigen_terms(S, names, xy, mags, combos, scale=None):
    """The eigenvectors of the source covariance S as combination terms
    (magnitude sqrt(eigenvalue) of the correlation matrix, the weights its
    eigenvector times the sources' 1-sigma) into mags and combos; with
    `scale` (source_scale), each coefficient to COEF_DIGITS and the
    sources whose share is below PRUNE_REL left out."""
    sd = np.sqrt(np.clip(np.diag(S), 0, None))
    if not sd.max() > 0:
        return
    live = sd > 1e-12 * sd.max()
    R = S[np.ix_(live, live)] / np.outer(sd[live], sd[live])
    lam, U = np.linalg.eigh(0.5 * (R + R.T))
    names_live = [n for n, l in zip(names, live) if l]
    for k, j in enumerate(o for o in np.argsort(lam)[::-1] if lam[o] > 1e-10 * max(lam.max(), 1e-300)):
        u = U[:, j]
        if u[np.argmax(np.abs(u))] < 0:  # a sign convention: the largest share positive
            u = -u
        nm = correlated_name(k, xy)
        mags[nm] = float(math.sqrt(lam[j]))
        c = {n: float(c) for n, c in zip(names_live, u * sd[live]) if c != 0.0}
        if scale is not None:
            top = sum(abs(v) * scale[n] for n, v in c.items())
            c = {n: float(f"{v:.{COEF_DIGITS}g}") for n, v in c.items() if abs(v) * scale[n] >= PRUNE_REL * top}
        combos[nm] = c


def project(cal, cov, dip, field_nT, gravity=1.0):
    """The probe's systematic terms from the calibration covariance:
    (magnitudes, fit).  The magnitudes are those of the combination terms
    (correlated_name: ABMS-CALnn toolface-independent, ABMSXY-CALnn what a
    turn changes; no standard GROUPS: the combinations carry every
    sensor error); fit["correlated"] has each
    combination's weights, and the sigma ratios how the model's
    toolface-averaged 1-sigma matches the covariance's linearised one over
    the attitude grid (5-175 deg; 1 up to the linearisation)."""
    names, S, S0 = source_covariance(cal, cov)
    mags = {}
    combos = {}
    scale = source_scale(dip, field_nT, gravity * G0)
    _eigen_terms(S0, names, False, mags, combos, scale)
    _eigen_terms(S - S0, names, True, mags, combos, scale)
    inc, azi, tfs = _grid()
    vi, va = linear_variance(cal, cov, inc, azi, tfs, dip, field_nT, gravity)
    pi = np.zeros_like(vi)
    pa = np.zeros_like(va)
    for nm, w in combos.items():
        wi, wa = correlated_weights(w, inc, azi, dip, field_nT, gravity * G0)
        pi += mags[nm] ** 2 * wi ** 2
        pa += mags[nm] ** 2 * wa ** 2
    y, p = np.concatenate([vi, va]), np.concatenate([pi, pa])
    keep = y > 0
    rel = np.sqrt(p[keep] / y[keep]) - 1.0
    fit = {"attitudes": int(len(inc)), "toolfaces": int(len(tfs)), "dip_deg": float(dip),
           "field_nT": float(field_nT), "sigma_ratio_rms": float(np.sqrt(np.mean(rel ** 2))),
           "sigma_ratio_min": float(1 + rel.min()), "sigma_ratio_max": float(1 + rel.max()),
           "form": "correlated combination terms: the eigenvectors of the toolface-averaged covariance of the "
                   "calibration's sensor errors", "correlated": combos}
    return mags, fit


def from_calibration(cal, dip_deg, field_nT, gravity_g=1.0, acc_noise_g=0.0, mag_noise_nT=0.0,
                     name="INCLINO", noise_source: str = "given", revision: int = 5) -> ToolModel:
    """The probe's tool model from a calibration (its covariance) and the
    probe's measured noise per survey (per axis, g and nT)."""
    if not (math.isfinite(dip_deg) and abs(dip_deg) < 90.0):
        raise DataError(f"dip {dip_deg} deg must be within +-90")
    if not (math.isfinite(field_nT) and field_nT > 0):
        raise DataError(f"total field {field_nT} nT must be > 0")
    cov, what = calibration_covariance(cal)
    mags, fit = project(cal, cov, dip_deg, field_nT, gravity_g)
    fit = dict(fit)
    correlated = fit.pop("correlated", {})
    tm = ToolModel(name=name, systematic=mags, correlated=correlated,
                   noise={"ABXY-R": acc_noise_g * G0, "ABZ-R": acc_noise_g * G0,
                          "MBXY-R": float(mag_noise_nT), "MBZ-R": float(mag_noise_nT)},
                   fit=fit,
                   source={"calibration": cal.method, "probe_serial": cal.probe_serial,
                           "covariance": what, "data": (cal.data or {}).get("sha256", ""),
                           "acc_noise_g": acc_noise_g, "mag_noise_nT": mag_noise_nT, "noise_source": noise_source},
                   revision=revision)
    for v in list(tm.systematic.values()) + [c for w in correlated.values() for c in w.values()]:
        if not math.isfinite(v):
            raise DataError("the projection of the calibration covariance gave a value that is not a finite number")
    for g, v in tm.noise.items():
        if not (math.isfinite(v) and v >= 0):
            raise DataError("noise must be a finite value >= 0")
    tm.fit["monte_carlo"] = mc_check(tm, cal, cov, dip_deg, field_nT, gravity_g)
    return tm


# upward holes too (105-175 deg): the correlated terms make the model hold there (it was 5-90 deg while the
# terms were independent and symmetric about 90 deg, and under-stated upward holes by up to 1.6x)
MC_INC = (5.0, 10.0, 20.0, 30.0, 45.0, 60.0, 75.0, 90.0, 105.0, 120.0, 135.0, 150.0, 165.0, 175.0)
MC_AZI = (17.0, 300.0, 130.0, 75.0, 210.0, 345.0, 160.0, 250.0, 40.0, 280.0, 100.0, 190.0, 325.0, 60.0)


MC_DRAWS = 20000
MC_LIMIT = 0.2  # the model's 1 sigma within +-20 % of the Monte Carlo's


def mc_check(tm, cal, cov, dip_deg, field_nT, gravity_g=1.0, n=MC_DRAWS, seed=1):
    """The model's systematic inclination/azimuth 1 sigma against a Monte
    Carlo over the coefficient covariance at fourteen attitudes (inclination
    5-175 deg: upward holes included): the ratios model / Monte Carlo, each with the standard error
    of the Monte Carlo's own estimate (`mc_ratio_se`).  `within_20pct`: every
    ratio within +-20 % of 1, up to two of its standard errors (a ratio that
    is 1.2 in truth reads above 1.2 in half of the Monte Carlo seeds: the
    verdict then follows the seed, not the model)."""
    inc, azi = np.array(MC_INC), np.array(MC_AZI)
    mi, ma, ki, ka = monte_carlo(cal, cov, inc, azi, dip_deg, field_nT, n=n, seed=seed, gravity=gravity_g,
                                 kurtosis=True)
    pi, pa = station_sigma(tm, inc, azi, dip_deg, field_nT, noise=False)
    ri, ra = pi / mi, pa / ma
    si, sa = mc_ratio_se(ri, ki, n), mc_ratio_se(ra, ka, n)
    ok = bool(np.all(np.abs(ri - 1) <= MC_LIMIT + 2 * si) and np.all(np.abs(ra - 1) <= MC_LIMIT + 2 * sa))
    return {"draws": n, "inc_deg": list(MC_INC), "azi_deg": list(MC_AZI), "inc_ratio": ri.tolist(),
            "azi_ratio": ra.tolist(), "inc_ratio_se": si.tolist(), "azi_ratio_se": sa.tolist(),
            "within_20pct": ok}


def mc_ratio_se(ratio, kurtosis, n):
    """Standard error of model / Monte Carlo 1 sigma from the Monte Carlo's
    n draws: the sample standard deviation s of n draws of kurtosis k
    (m4 / sigma^4) has var(s) / sigma^2 = (k - 1) / (4 n) to first order
    (delta method on the sample variance, var(s^2) = sigma^4 (k - 1) / n)."""
    return np.asarray(ratio, float) * np.sqrt(np.clip(np.asarray(kurtosis, float) - 1.0, 0, None) / (4.0 * n))


def mc_worst(mc) -> tuple[str, float, float, float, float]:
    """(quantity, ratio, standard error, inclination, azimuth) of the ratio
    furthest from 1 in a `mc_check` result (in its standard errors beyond
    the +-20 % band)."""
    best = None
    for q in ("inc", "azi"):
        se = mc.get(f"{q}_ratio_se") or [0.0] * len(mc[f"{q}_ratio"])
        for r, e, i, a in zip(mc[f"{q}_ratio"], se, mc["inc_deg"], mc["azi_deg"]):
            beyond = abs(r - 1) - MC_LIMIT - 2 * e
            if best is None or beyond > best[0]:
                best = (beyond, q, r, e, i, a)
    _, q, r, e, i, a = best
    return ("inclination" if q == "inc" else "azimuth"), r, e, i, a


def calibration_noise(cal) -> tuple[float, float, str]:
    """(accelerometer g, fluxgate nT, where from): the noise of one probe
    reading per axis that the calibration's fit report records
    (report.uncertainty.reading_noise: measured by acquire at the poses, or
    the fit's residuals of G total and B total); an older report's
    residuals of G total and B total.  DataError when the report has neither: the noise is
    never taken as zero."""
    rep = cal.report or {}
    rn = (rep.get("uncertainty") or {}).get("reading_noise")
    if isinstance(rn, dict) and all(isinstance(rn.get(k), (int, float)) for k in ("acc_g", "mag_nT")):
        a, m = float(rn["acc_g"]), float(rn["mag_nT"])
        if math.isfinite(a) and math.isfinite(m) and a >= 0 and m >= 0:
            return a, m, f"the calibration's fit report ({rn.get('source', 'reading noise')})"
    res = rep.get("residuals") or {}
    ga, bm = res.get("acc_norm_rms_mg"), res.get("mag_norm_rms_nT")
    if all(isinstance(v, (int, float)) and math.isfinite(v) and v >= 0 for v in (ga, bm)):
        return (ga * 1e-3, float(bm), "the calibration's fit report (its RMS residual of G total and B total: the "
                                      "noise along the field and what the calibration leaves)")
    raise DataError("the calibration's fit report records no reading noise: give --acc-noise G and --mag-noise NT "
                    "(or toolmodel --noise NOISE.csv, repeated surveys at rest); the noise is never taken as zero")


def calibration_noise_dof(cal) -> float | None:
    """The degrees of freedom of the noise calibration_noise takes from the
    calibration's fit report (report.uncertainty.reading_noise.dof: the
    rows its residuals come from less the coefficients they spent); None
    when the report records none (acquire's measured noise, an older
    report): the noise is then taken as known."""
    rn = ((cal.report or {}).get("uncertainty") or {}).get("reading_noise")
    dof = rn.get("dof") if isinstance(rn, dict) else None
    return float(dof) if isinstance(dof, (int, float)) and math.isfinite(dof) and dof >= 1 else None


def noise_from_survey(rows) -> tuple[float, float]:
    """(accelerometer g, fluxgate nT) per-axis noise of one survey from
    repeated surveys at rest: the spread of G total and B total (each the
    projection of the axes' noise on the measured vector).  At least 3
    surveys with both (docs/survey.md), else DataError."""
    gt = np.array([r["gt_g"] for r in rows if isinstance(r.get("gt_g"), (int, float))], float)
    bt = np.array([r["bt_nT"] for r in rows if isinstance(r.get("bt_nT"), (int, float))], float)
    if len(gt) < 3 or len(bt) < 3:
        raise DataError("the noise run needs at least 3 surveys with gt_g and bt_nT")
    return float(np.std(gt, ddof=1)), float(np.std(bt, ddof=1))


def monte_carlo(cal, cov, inc, azi, dip, field_nT, n=2000, seed=1, gravity=1.0, kurtosis=False):
    """Inclination and azimuth 1 sigma (deg) at each attitude from random
    draws of the 24 coefficients (the covariance), each draw at a random
    toolface: the error of the survey computed with the drawn coefficients
    from the readings of the probe the calibration describes.  With
    `kurtosis`, also the errors' kurtosis (m4 / m2^2) at each attitude, for
    the standard error of the 1 sigma (mc_ratio_se)."""
    from inclino.calib.common import cal_vector

    rng = np.random.default_rng(seed)
    x0 = cal_vector(cal)
    w, V = np.linalg.eigh(0.5 * (cov + cov.T))
    L = V * np.sqrt(np.clip(w, 0, None))
    si, sa, ki, ka = [], [], [], []
    for I, A in zip(np.atleast_1d(inc), np.atleast_1d(azi)):
        tf = rng.uniform(0, 360, n)
        ra, rm = _truth(cal, np.full(n, I), np.full(n, A), tf, dip, field_nT, gravity)
        d = rng.standard_normal((n, 24)) @ L.T
        ai, aa = _attitude(*_apply_many(x0 + d, ra, rm))
        ei, ea = ai - I, ((aa - A + 180.0) % 360.0) - 180.0
        si.append(np.std(ei))
        sa.append(np.std(ea))
        ki.append(_kurtosis(ei))
        ka.append(_kurtosis(ea))
    if kurtosis:
        return np.array(si), np.array(sa), np.array(ki), np.array(ka)
    return np.array(si), np.array(sa)


def _kurtosis(e):
    c = e - np.mean(e)
    m2 = np.mean(c ** 2)
    return float(np.mean(c ** 4) / m2 ** 2) if m2 > 0 else 3.0


def _apply_many(X, ra, rm):
    Ma, ba = X[:, 0:9].reshape(-1, 3, 3), X[:, 9:12]
    Mm, bm = X[:, 12:21].reshape(-1, 3, 3), X[:, 21:24]
    return np.einsum("nij,nj->ni", Ma, ra - ba), np.einsum("nij,nj->ni", Mm, rm - bm)
