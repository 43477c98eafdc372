"""Error models as the survey commands propagate them: a standard ISCWSA /
OWSG tool model (by the name welleng ships, or an ISCWSA JSON file), the
calibrated probe's own terms (inclino.survey.errormodel), or the two
together.

* A name: any model welleng lists (`welleng.error.ERROR_MODELS`: "ISCWSA MWD
  Rev5.11", "ISCWSA MWD Rev4", the OWSG models "MWD+SRGM", "MWD+IFR1+AX",
  ...), case-insensitive, or an alias of ALIASES (`iscwsa-mwd-rev5`,
  `iscwsa-mwd-rev4`).  Propagated by welleng under that name, so exactly as
  welleng validated it against the ISCWSA example workbooks.
* A file: an ISCWSA JSON tool model (`metadata`, `terms`), inclino
  toolmodel's output included.  Its `terms` are the model: every term is
  checked (name, value >= 0, unit, propagation, formulas that evaluate) and
  a term that fails is refused with its reason, never dropped.
* With the probe's terms (`--cal`): the base model's sensor terms (AB*, AS*,
  MB*, MS*: accelerometer and magnetometer bias and scale) are replaced by
  the probe's fitted ones and its measured noise; every other term stays
  (depth, sag, axial interference, misalignment, reference field, course
  length).  The probe's terms are written in the base's revision (its
  XYM3/XYM4 as that revision propagates them) and propagated with the
  base's conventions.

Terms are independent, so the position covariance of the whole is the sum
of its parts' (welleng's per-source covariances add to its total to machine
precision): the complete ellipse is never smaller than either part.
"""
from __future__ import annotations

import json
import math
import os
from dataclasses import dataclass, field

import numpy as np

from inclino.errors import DataError

ALIASES = {"iscwsa-mwd-rev5": "ISCWSA MWD Rev5.11", "iscwsa-mwd-rev5.11": "ISCWSA MWD Rev5.11",
           "iscwsa mwd rev5": "ISCWSA MWD Rev5.11", "iscwsa-mwd-rev4": "ISCWSA MWD Rev4"}
DEFAULT_BASE = "ISCWSA MWD Rev5.11"
PROPAGATION = ("Random", "Systematic", "Well", "Global")
FAMILIES = ("sensor", "misalignment", "sag", "axial interference", "depth", "reference field", "other")


def family(name: str) -> str:
    """The kind of an ISCWSA term, from its code."""
    n = name.upper()
    if n[:2] in ("AB", "AS", "MB", "MS"):
        return "sensor"
    if n.startswith("XYM"):
        return "misalignment"
    if n.startswith("SAG"):
        return "sag"
    if n.startswith("AMI"):
        return "axial interference"
    if n.startswith(("DR", "DS", "XCL")):
        return "depth"
    if n.startswith(("DEC", "DBH", "MDI", "MFI", "AZM", "CN")):
        return "reference field"
    return "other"


def standard_name(spec: str) -> str | None:
    """The welleng model name `spec` stands for (an alias, or a name welleng
    lists, any case), else None."""
    import welleng.error as we

    s = spec.strip()
    if s.lower() in ALIASES:
        return ALIASES[s.lower()]
    for n in we.ERROR_MODELS:
        if n.lower() == s.lower():
            return n
    return None


def _revision_of_name(name: str) -> float:
    import welleng.error as we

    for v in we.TOOL_INDEX.values():
        if v.get("Short Name") == name:
            try:
                return float(v.get("Rev.", 5))
            except (TypeError, ValueError):
                return 5.0
    return 5.0


def _json_of_name(name: str) -> dict | None:
    """The ISCWSA JSON of a named model where welleng ships one."""
    from welleng.errors.tool_errors import _resolve_json_model

    p = _resolve_json_model(name)
    if p is None:
        return None
    with open(p, encoding="utf-8") as f:
        return json.load(f)


def _units():
    from welleng.errors.tool_errors import _MAG_UNIT_TO_BASE

    return _MAG_UNIT_TO_BASE


def check_terms(terms, where: str) -> list:
    """The terms of an ISCWSA JSON model, each checked; DataError naming the
    term and the reason otherwise."""
    if not isinstance(terms, list) or not terms:
        raise DataError(f"{where}: no 'terms' list (an ISCWSA JSON tool model has one)")
    seen = set()
    units = _units()
    out = []
    for i, t in enumerate(terms):
        if not isinstance(t, dict) or not isinstance(t.get("name"), str) or not t["name"].strip():
            raise DataError(f"{where}: term {i + 1} has no name")
        n = t["name"]
        w = f"{where}: term {n}"
        if n in seen:
            raise DataError(f"{w} appears twice (each term is one error source)")
        seen.add(n)
        v = t.get("value")
        if isinstance(v, bool) or not isinstance(v, (int, float)) or not math.isfinite(v) or v < 0:
            raise DataError(f"{w}: value {v!r} must be a number >= 0 (a 1-sigma magnitude)")
        if not isinstance(t.get("units", ""), str) or t.get("units", "") not in units:
            raise DataError(f"{w}: unit {t.get('units')!r} is not one welleng converts ({', '.join(sorted(units))})")
        if not isinstance(t.get("propagation_mode"), str) or t.get("propagation_mode") not in PROPAGATION:
            raise DataError(f"{w}: propagation_mode {t.get('propagation_mode')!r} is not one of "
                            f"{', '.join(PROPAGATION)}")
        for k in ("depth_formula", "inclination_formula", "azimuth_formula"):
            f = t.get(k, 0)
            if f is None or isinstance(f, bool) or not isinstance(f, (str, int, float)):
                raise DataError(f"{w}: {k} {f!r} is not a formula")
        out.append(t)
    return out


@dataclass
class Base:
    """A standard or file model the probe's terms may be set into."""
    label: str
    model: object  # welleng name (str) or ISCWSA JSON dict
    revision: float
    source: str  # "name" or the file's path
    notes: list = field(default_factory=list)
    inclino: object = None  # the ToolModel inclino toolmodel recorded in the file (provenance: fit, noise source)

    def terms(self) -> list | None:
        if isinstance(self.model, dict):
            return self.model["terms"]
        d = _json_of_name(self.model)
        return d["terms"] if d else None

    def term_names(self) -> list:
        t = self.terms()
        if t is not None:
            return [x["name"] for x in t]
        import welleng.error as we

        for k, v in we.TOOL_INDEX.items():
            if v.get("Short Name") == self.model:
                import yaml

                from welleng.errors import tool_errors

                p = os.path.join(os.path.dirname(tool_errors.__file__), "tool_codes", f"{k}.yaml")
                with open(p, encoding="utf-8") as f:
                    return list(yaml.safe_load(f)["codes"])
        return []


def load(spec: str) -> Base:
    """The model of `--tool-model SPEC`: a standard name, or an ISCWSA JSON
    file whose terms (as they stand in the file) are the model."""
    name = standard_name(spec)
    if name is not None:
        return Base(name, name, _revision_of_name(name), "name")
    if not os.path.exists(spec):
        import welleng.error as we

        raise DataError(f"--tool-model {spec}: neither a file nor a model welleng ships (for example "
                        f"{', '.join(sorted(ALIASES)[:2])}, 'ISCWSA MWD Rev5.11', 'MWD+IFR1+AX'; "
                        f"{len(we.ERROR_MODELS)} names in welleng.error.ERROR_MODELS)")
    from inclino.formats.safeio import load_json

    d = load_json(spec, "tool model")
    if not isinstance(d, dict):
        raise DataError(f"{spec}: not an ISCWSA JSON tool model (an object with 'metadata' and 'terms')")
    terms = check_terms(d.get("terms"), spec)
    # a term of 0 contributes nothing, and welleng evaluates it as 0 x its weight, NaN at a vertical station (an
    # azimuth weight is infinite there): left out.  inclino toolmodel wrote the standard sensor terms with 0 beside
    # its combination terms before 2026-11-29; such a file is the same model without them
    terms = [t for t in terms if t["value"] != 0]
    if not terms:
        raise DataError(f"{spec}: every term is 0: the model describes no error (an ISCWSA tool model needs a term "
                        "above 0)")
    meta = d.get("metadata") if isinstance(d.get("metadata"), dict) else {}
    rev = meta.get("revision_number", 5)
    try:
        rev = float(rev)
    except (TypeError, ValueError):
        raise DataError(f"{spec}: metadata.revision_number {rev!r} is not a number")
    label = str(meta.get("short_name") or meta.get("model_id") or os.path.basename(spec))
    model = {"metadata": {**meta, "short_name": label}, "parameters": d.get("parameters") or
             {"inc_min": 0, "inc_max": 180}, "terms": terms}
    base = Base(label, model, rev, spec)
    ib = d.get("inclino")
    if isinstance(ib, dict):
        from inclino.survey.errormodel import ToolModel

        tm = ToolModel.from_dict(ib, f"tool model {spec}")  # every field by its rule
        written = {t["name"]: t["value"] for t in tm.iscwsa(meta.get("reference_terms", "none"))["terms"]} \
            if tm.revision == rev else {}
        now = {t["name"]: t["value"] for t in terms}
        same = written.keys() == now.keys() and all(
            math.isclose(float(written[k]), float(now[k]), rel_tol=1e-9, abs_tol=1e-300) for k in now)
        if not same:
            base.notes.append("its terms differ from those inclino toolmodel wrote (edited): the file's terms are "
                              "the model")
        base.inclino = tm
    return base


def load_toolmodel(path: str):
    """The errormodel.ToolModel inclino toolmodel recorded in a file (its fit
    and sources; the file's terms, as `load` reads them, are the model)."""
    b = load(path)
    if b.inclino is None:
        raise DataError(f"{path}: not a tool model written by inclino toolmodel")
    return b.inclino


# a listing whose toolfaces' circular spread is within this is read as surveyed at one toolface
ONE_TOOLFACE_DEG = 30.0


@dataclass
class ErrorModel:
    """What `trajectory --uncertainty` and `compare` propagate."""
    base: Base | None = None
    probe: object = None  # errormodel.ToolModel: the calibration's terms (replace the base's sensor terms)
    reference: str | None = None  # None: the model's own reference-field terms; else none/srgm/ifr1 replace them
    notes: list = field(default_factory=list)
    # (Calibration, 24x24 covariance) the probe's terms came from (--cal): with each station's toolface, its
    # sensor error is propagated at the attitude surveyed (errormodel.run_covariance), not toolface-averaged
    calibration: tuple | None = None

    @property
    def revision(self) -> float:
        return self.base.revision if self.base is not None else float(getattr(self.probe, "revision", 5))

    # ------------------------------------------------------------ the parts
    def parts(self) -> list:
        """[(part name, welleng model, drop set)]: each run of welleng and the
        base terms it leaves out."""
        from inclino.survey import errormodel as em

        out = []
        base_names = self.base.term_names() if self.base is not None else []
        drop = set()
        if self.base is not None:
            if self.probe is not None:
                drop |= {n for n in base_names if family(n) == "sensor"}
            if self.reference is not None:
                drop |= {n for n in base_names if family(n) == "reference field"}
            out.append(("base", self.base.model, drop))
        rev = int(self.revision) if self.revision < 5 else 5
        extra = em.reference_terms(self.reference) if self.reference is not None else []
        if self.probe is not None:
            d = self.probe.iscwsa("none", revision=rev)
            d["terms"] = d["terms"] + extra
            out.append(("probe", d, set()))
        elif extra:
            out.append(("reference", {"metadata": {"short_name": f"reference-{self.reference}", "revision_number": rev,
                                                   "framework": f"ISCWSA Rev{rev}", "tool_type": "Magnetic"},
                                      "parameters": {"inc_min": 0, "inc_max": 180}, "terms": extra}, set()))
        return out

    def families(self) -> dict:
        """family -> number of terms in what propagates."""
        c = {}
        for _, m, drop in self.parts():
            names = [t["name"] for t in m["terms"]] if isinstance(m, dict) else self.base.term_names()
            for n in names:
                if n not in drop:
                    f = family(n)
                    c[f] = c.get(f, 0) + 1
        return c

    def part_label(self, part: str) -> str:
        """How the summary names a part."""
        if part == "base":
            replaced = self.probe is not None or (self.reference is not None and self.has_reference_terms())
            return f"{self.base.label}'s other terms" if replaced else self.base.label
        if part == "probe":
            return "the probe's terms" + (f" and reference terms {self.reference}" if self.reference and
                                          self.base is None else "")
        return f"reference terms {self.reference}"

    def has_reference_terms(self) -> bool:
        names = self.base.term_names() if self.base is not None else []
        return any(family(n) == "reference field" for n in names)

    def describe(self) -> str:
        """One sentence: what is propagated, what is missing."""
        fam = self.families()
        have = [f for f in FAMILIES if fam.get(f)]
        if self.base is not None:
            what = f"{self.base.label} (revision {self.base.revision:g}" + \
                   (f", {self.base.source}" if self.base.source != "name" else "") + ")"
            if self.probe is not None:
                what += f" with the probe's sensor terms ({self.probe.source.get('calibration', 'calibration')} " \
                        f"calibration of probe {self.probe.source.get('probe_serial') or '(no serial)'}) in place of its own"
        else:
            what = f"the probe's terms ({self.probe.name}, revision {self.revision:g})"
        if self.reference is not None:
            what += f"; reference-field terms {self.reference}"
        missing = [f for f in ("depth", "sag", "axial interference", "misalignment", "reference field")
                   if not fam.get(f)]
        s = f"error model: {what}; terms: {', '.join(have)}"
        if missing:
            s += f"; no {', '.join(missing)} terms ({self._missing_hint(missing)})"
        return s

    def _missing_hint(self, missing) -> str:
        """What puts the missing terms in: a standard model for the probe's
        terms alone; --ref-terms for reference terms it took out."""
        if self.base is None:
            return "add --tool-model iscwsa-mwd-rev5 for a complete ellipse"
        if missing == ["reference field"] and self.reference == "none":
            return "--ref-terms none took them out; srgm or ifr1 puts them in"
        return f"{self.base.label} has none"

    # ------------------------------------------------------------ propagation
    def at_toolface(self, tf, n: int) -> bool:
        """Whether the probe's sensor terms are propagated at each station's
        own toolface: a calibration, and a toolface for each of the n stations."""
        return self.calibration is not None and self.probe is not None and tf is not None and len(tf) == n and \
            bool(np.all(np.isfinite(tf)))

    def toolface_note(self, tf, n: int) -> str | None:
        """What the listing's toolfaces made of the probe's sensor terms (a
        model from a calibration), or, for a model without the calibration
        whose listing keeps one toolface, what its toolface-averaged terms
        assume and what would do better."""
        if self.calibration is None or self.probe is None:
            t = np.radians(np.asarray(tf, float)) if tf is not None and len(tf) == n and n > 1 else None
            if t is None or not np.all(np.isfinite(t)):
                return None
            spread = math.degrees(math.sqrt(-2.0 * math.log(max(min(float(np.hypot(np.cos(t).mean(), np.sin(
                t).mean())), 1.0), 1e-300))))
            if spread > ONE_TOOLFACE_DEG:
                return None
            return (f"the listing's toolfaces stay within about {spread:.0f} deg (circular spread) of one another: the "
                    "model's sensor terms are averaged over the toolface, which holds for a probe turning between "
                    "stations; at one toolface the X/Y errors add up along the hole and the ellipse can be too "
                    "small (--cal CAL.json propagates the calibration at each station's own toolface)")
        if self.at_toolface(tf, n):
            return ("the probe's sensor terms: its calibration's covariance at each station's own attitude and "
                    "toolface (the listing's tf_deg), one error for the whole run")
        have = 0 if tf is None else int(np.isfinite(tf).sum())
        return (f"the probe's sensor terms averaged over the toolface ({n - have} of {n} stations have no tf_deg, or "
                "repeats at a depth in different toolfaces): they hold for a probe turning between stations; at "
                "one toolface the X/Y errors add up along the hole and the ellipse can be too small")

    def propagate(self, md, inc, azi_mag, rf, fallback=(60.0, 50000.0), tf=None) -> "Propagation":
        """Position (NEV) and survey (depth, inc, azi) covariance per station,
        total and per part, and each source's survey covariance.  With the
        calibration (`calibration`) and every station's gravity toolface
        (`tf`, deg), the probe's systematic sensor terms are its coefficients'
        covariance at each station's own attitude (source ("probe",
        "CAL-TOOLFACE")), in place of the toolface-averaged combination terms."""
        import warnings

        from inclino.survey import errormodel as em

        exact = self.at_toolface(tf, len(md))

        n = len(md)
        total = np.zeros((n, 3, 3))
        dia = np.zeros((n, 3, 3))
        parts, sources = {}, {}
        for part, model, drop in self.parts():
            with warnings.catch_warnings():
                warnings.simplefilter("ignore")
                try:
                    ws = welleng_survey(md, error_model_inc(inc), azi_mag, rf, model, fallback)
                except (ValueError, AssertionError, ArithmeticError, KeyError, IndexError, TypeError,
                        np.linalg.LinAlgError) as e:
                    raise DataError(f"the survey cannot be computed with {part} model: {e}")
            errs = ws.err.errors
            dropped = [d for d in getattr(errs, "dropped_terms", []) if d.code not in drop]
            if dropped:
                raise DataError(f"the error model's term {dropped[0].code} cannot be evaluated "
                                f"({dropped[0].missing and 'missing variable ' + repr(dropped[0].missing) or dropped[0].reason}): "
                                "refused (a term that contributes nothing would make the ellipse too small)")
            c = np.zeros((n, 3, 3))
            for code, e in errs.errors.items():
                if code in drop or (exact and part == "probe" and em.is_correlated_name(code)):
                    continue
                cov = np.asarray(e.cov_NEV, float)
                if cov.shape[0] == 3 and cov.shape[-1] == n:  # welleng's (3, 3, n) layout in some versions
                    cov = np.moveaxis(cov, -1, 0)
                c += cov
                d = np.asarray(e.cov_DIA, float)
                if d.shape[0] == 3 and d.shape[-1] == n:
                    d = np.moveaxis(d, -1, 0)
                dia += d
                sources[(part, code)] = (e.propagation, d)
            if exact and part == "probe":
                cal, cov = self.calibration
                nev, d = em.run_covariance(cal, cov, md, error_model_inc(inc), azi_mag, tf, *field_of(rf, fallback),
                                           rf.declination_deg)
                c += nev
                dia += d
                sources[(part, "CAL-TOOLFACE")] = ("systematic", d)
            parts[part] = c
            total += c
        return Propagation(total, dia, parts, sources)

    # ------------------------------------------------------------ export
    def to_iscwsa(self, name: str) -> dict:
        """The whole model as one ISCWSA JSON dict (welleng loads it as is)."""
        if self.base is None:
            d = self.probe.iscwsa(self.reference or "none", revision=int(self.revision) if self.revision < 5 else 5)
            d["metadata"]["short_name"] = name
            return d
        terms = self.base.terms()
        if terms is None:
            raise DataError(f"{self.base.label}: welleng ships it as hand-coded weight functions, not as ISCWSA JSON "
                            "terms, so it cannot be written out as one file; use a revision 5 model (iscwsa-mwd-rev5, "
                            "an OWSG model) or propagate it with trajectory --tool-model")
        keep = []
        for _, m, drop in self.parts():
            if isinstance(m, dict):
                keep += [t for t in m["terms"] if t["name"] not in drop]
            else:
                keep += [t for t in terms if t["name"] not in drop]
        names = [t["name"] for t in keep]
        for i, t in enumerate(keep):  # the probe's misalignment terms beside the base's own
            if names.count(t["name"]) > 1 and i >= names.index(t["name"]) + 1:
                keep[i] = {**t, "name": t["name"] + "-CAL"}
        meta = dict(self.base.model["metadata"]) if isinstance(self.base.model, dict) else \
            dict((_json_of_name(self.base.model) or {}).get("metadata", {}))
        rev = self.revision
        meta.update(short_name=name, model_id=name, revision_number=int(rev) if rev < 5 else 5,
                    framework=f"ISCWSA Rev{int(rev) if rev < 5 else 5}",
                    long_name=f"{name}: {self.base.label} with the calibrated probe's sensor terms",
                    source=f"inclino toolmodel: {self.base.label} (revision {rev:g}); sensor terms from the "
                           f"calibration ({json.dumps(self.probe.source, sort_keys=True) if self.probe else ''})",
                    author="inclino")
        params = dict(self.base.model.get("parameters", {})) if isinstance(self.base.model, dict) else \
            dict((_json_of_name(self.base.model) or {}).get("parameters", {"inc_min": 0, "inc_max": 180}))
        return {"metadata": meta, "parameters": params, "terms": keep}


# welleng refuses a model at its own inclination limit (it asks max inc < the model's 180): a station straight up,
# inclination 180 (docs/conventions.md: I in [0, 180]), is propagated as this close to it (1.7e-8 rad: the error
# terms' weights are continuous there; the positions are welleng's of the station itself)
INC_MAX_PROPAGATED = 180.0 - 1e-6


def error_model_inc(inc):
    """The inclinations (deg) the error model is evaluated at: the station's, 180 as INC_MAX_PROPAGATED."""
    return np.minimum(np.asarray(inc, float), INC_MAX_PROPAGATED)


@dataclass
class Propagation:
    cov_nev: np.ndarray  # (n, 3, 3) north, east, vertical, m^2
    cov_dia: np.ndarray  # (n, 3, 3) depth m, inclination rad, azimuth rad: the stations' own
    parts: dict  # part name -> (n, 3, 3)
    sources: dict  # (part, code) -> (propagation, (n, 3, 3) DIA covariance)


def field_of(rf, fallback=(60.0, 50000.0)) -> tuple:
    """(dip deg, total field nT, gravity g) of a reference: `fallback` (the
    tool model's own dip and field) where it has none (declination-only
    referencing), 1 g without a gravity."""
    return (rf.dip_deg if math.isfinite(rf.dip_deg) else fallback[0],
            rf.field_nT if math.isfinite(rf.field_nT) else fallback[1],
            rf.gravity_g if math.isfinite(rf.gravity_g) else 1.0)


def welleng_survey(md, inc, azi_mag, rf, error_model=None, fallback=(60.0, 50000.0)):
    """welleng's Survey of magnetic azimuths.  Dip and field only enter the
    error model's weights; when the reference lacks them (declination-only
    referencing) `fallback` (the tool model's own) stands in."""
    from welleng.survey import Survey as WSurvey, SurveyHeader

    dip, bt, grav = field_of(rf, fallback)
    h = SurveyHeader(latitude=rf.lat_deg if rf.lat_deg is not None else 0.0,
                     longitude=rf.lon_deg if rf.lon_deg is not None else 0.0, altitude=rf.alt_m,
                     survey_date=rf.date, b_total=bt, dip=dip, declination=rf.declination_deg,
                     convergence=0.0, azi_reference="magnetic", G=grav * 9.80665, vertical_inc_limit=0.0001)
    return WSurvey(md=np.asarray(md, float), inc=np.asarray(inc, float), azi=np.asarray(azi_mag, float),
                   header=h, error_model=error_model)
