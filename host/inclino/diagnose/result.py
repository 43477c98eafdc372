"""The diagnosis as data: `Diagnosis.to_json()` prints exactly

    {"baseline": {...},
     "effects": [{"name", "sensor", "axis", "estimate", "stderr", "units",
                  "gain": {"rms_before", "rms_after", "cv_rms_before", "cv_rms_after",
                           "azi_rms_before_deg", "azi_rms_after_deg",
                           "inc_rms_before_deg", "inc_rms_after_deg"},
                  "detail": {...}}],
     "contradicted": [...], "confounded": [...],
     "unexplained": true|false, "checks": {...}|null, "calibrate": {"level", "message"}|null, "motion": {...}|null,
     "pairing": {"level", "triad", "message", "fix", "explains"}|null,
     "conclusion": "PASS: ..."|"FAIL: ..."}

(docs/diagnose.md describes the baseline object's keys)."""
from __future__ import annotations

from dataclasses import dataclass, field

from inclino.formats.jsonout import dumps, json_safe


@dataclass
class Gain:
    rms_before: float
    rms_after: float
    cv_rms_before: float
    cv_rms_after: float
    azi_rms_before_deg: float | None
    azi_rms_after_deg: float | None
    inc_rms_before_deg: float
    inc_rms_after_deg: float

    def to_dict(self):
        return json_safe({k: getattr(self, k) for k in ("rms_before", "rms_after", "cv_rms_before", "cv_rms_after",
                                                    "azi_rms_before_deg", "azi_rms_after_deg",
                                                    "inc_rms_before_deg", "inc_rms_after_deg")})


@dataclass
class Effect:
    name: str
    sensor: str
    axis: str
    estimate: float
    stderr: float
    units: str
    gain: Gain
    # not in the JSON: what the text report and the plots use
    rms_units: str = ""
    p_value: float = 1.0
    detail: dict = field(default_factory=dict)  # in the JSON: the checks it passed, a rig field's harmonics

    def to_dict(self):
        return json_safe({"name": self.name, "sensor": self.sensor, "axis": self.axis, "estimate": self.estimate,
                          "stderr": self.stderr, "units": self.units, "gain": self.gain.to_dict(),
                          "detail": self.detail})


@dataclass
class Diagnosis:
    baseline: dict
    effects: list = field(default_factory=list)
    unexplained: bool = False
    # kept for the report and the plots, not in the JSON
    structure: dict = field(default_factory=dict)
    plot_data: dict = field(default_factory=dict, repr=False)
    elapsed_s: float = 0.0
    # effects the selection kept that failed the checks: not causes ("fits the poses but contradicts the invariants")
    contradicted: list = field(default_factory=list)
    # named (or contradicted) effects and the candidates the run cannot tell them from
    confounded: list = field(default_factory=list)
    # the checks before any fit (checks.CheckReport.to_dict()) when the caller ran them (inclino diagnose)
    checks: dict | None = None
    # what `calibrate` says of the data without poses (posefree.calibrate_says): {"level": "error" (it refuses),
    # "message", "why"} | {"level": "warning", "message"}
    calibrate: dict | None = None
    # without poses, a log read mostly while moving (calib.motion.figures): the hand's acceleration is in |g|
    motion: dict | None = None
    # the checks before the fit warned (or erred) that the rows are paired out of step (pairing_of): the
    # likely cause of structure the library's effects leave in the channels it touches
    pairing: dict | None = None

    def to_dict(self) -> dict:
        return {"baseline": json_safe(self.baseline), "effects": [e.to_dict() for e in self.effects],
                "contradicted": json_safe(self.contradicted), "confounded": json_safe(self.confounded),
                "unexplained": bool(self.unexplained), "checks": json_safe(self.checks),
                "calibrate": json_safe(self.calibrate), "motion": json_safe(self.motion),
                "pairing": json_safe({**self.pairing, "explains": self._mispaired()}) if self.pairing else None,
                "conclusion": self.conclusion().removeprefix("conclusion: ") if self.baseline else None}

    def to_json(self, indent=2) -> str:
        return dumps(self.to_dict(), indent=indent)

    def names(self) -> list:
        return [(e.name, e.sensor, e.axis) for e in self.effects]

    def summary(self) -> str:
        b = self.baseline
        if b.get("mode") == "invariants":
            u = {"|g|": "g", "|b|": "nT", "dip": "deg"}
            lines = [f"baseline: {b['model']}; {b['rows']} readings in {b['clusters']} poses (clusters of rows at one "
                     f"pose count once), invariants " + ", ".join(b["invariants"])
                     # a failed fit's dip is no fitted model's (x-io Fusion's log: 52.176 deg, the data +69.2)
                     + ("" if b.get("dip_deg") is None else ", dip not fitted" if b.get("fit_failed")
                        else f", dip {b['dip_deg']:.3f} deg"),
                     "  residual RMS: " + ", ".join(f"{k} {v:.4g} {u[k]}" for k, v in b["rms"].items())]
            if b.get("fit_failed"):
                lines.append(f"  the fit failed: {b['fit_failed']}: these readings do not determine the model, "
                             f"and its figures here are those of no fitted model")
            pr = b.get("prediction", {}).get("by_invariant")
            if pr and b.get("fit_failed"):
                lines.append("  held-out poses: not predicted (no fitted model to predict them from)")
            elif pr:
                lines.append("  held-out poses, predicted -> achieved RMS: " + ", ".join(
                    f"{k} {v['predicted_heldout_rms']:.4g} -> {v['achieved_heldout_rms']:.4g} {u[k]} "
                    f"(ratio {v['ratio']:.2f})" for k, v in pr.items()))
        else:
            nz = b["noise"]
            lines = [f"baseline: {b['model']}; {b['rows']} readings ({b['kind']}), {b['orientations']} orientations, "
                     f"dip {b['dip_deg']:.3f} deg",
                     "  noise from the data: acc " + ", ".join(f"{s * 1e6:.0f}" for s in nz["acc_g"]) + " ug; mag "
                     + ", ".join(f"{s:.2f}" for s in nz["mag_nT"]) + " nT; turntable "
                     + ", ".join(f"{k} {v:.3f}" for k, v in nz["pose_deg"].items()) + " deg",
                     "  residual RMS: acc " + ", ".join(f"{s * 1e6:.0f}" for s in b["rms"]["acc_g"]) + " ug; mag "
                     + ", ".join(f"{s:.2f}" for s in b["rms"]["mag_nT"]) + " nT; "
                     + (f"azimuth {b['azi_rms_deg']:.4f} deg, " if b.get("azi_rms_deg") is not None else "")
                     + f"inclination {b['inc_rms_deg']:.4f} deg"]
            sc = b.get("serial_correlation") or {}
            if sc.get("correlated"):
                lines.append("  rows serially correlated in time (lag-1 "
                             + ", ".join(f"{c} {v:+.2f}" for c, v in zip(sc["channels"], sc["lag1"]))
                             + f"; Ljung-Box p = {sc['ljung_box_p']:.2g}): each F-test and standard error is widened "
                             "by its effect's Bartlett factor" + (" (" + ", ".join(
                                 f"{k.split(':')[0]} {k.split(':')[2]} {v:.2f}"
                                 for k, v in sc["inflation_by_effect"].items()) + ")"
                                 if sc["inflation_by_effect"] else ""))
        sel = b["selection"]
        lines.append(f"effects tested: {len(sel['tested'])} (F-test at alpha = {sel['alpha']:g}, Bonferroni over the "
                     f"candidates, and "
                     + ("leave-one-pose-out cross-validation)" if b.get("clusters") == sel["folds"]
                        else f"{sel['folds']}-fold cross-validation)"))
        groups = {}
        for nt in sel["not_testable"]:
            parts = nt["effect"].split(":")
            where = groups.setdefault((parts[0], nt["reason"]), [])
            if len(parts) == 3:
                where.append(f"{parts[1]} {parts[2]}")
        for (name, reason), where in groups.items():
            needs = sel.get("needs_label", "needs the poses") if b.get("mode") == "invariants" \
                and name in sel.get("needs_poses", ()) else \
                "not testable"
            lines.append(f"  {needs}: {name}" + (f" ({', '.join(where)})" if where else "") + f": {reason}")
        if not self.effects:
            lines.append("effects found: none")
        for e in self.effects:
            g = e.gain
            lines.append(f"effect: {e.name} ({e.sensor} {e.axis}) = {e.estimate:.4g} +- {e.stderr:.2g} {e.units}"
                         f"  (p = {e.p_value:.2g})")
            hv = e.detail.get("holds_view")
            if hv:
                lines.append(f"  confirmed on the {hv['holds']} static holds alone (the rows read while moving left "
                             f"out, the baseline fitted to the holds again): p = {hv['p']:.2g}")
            ce = e.detail.get("calibration_error_if_ignored")
            if ce:
                lines.append(f"  the rig's field, not the probe's: keep it out of the probe's calibration -- ignored, "
                             f"it leaves {ce['azi_rms_deg']:.3f} deg azimuth and {ce['inc_rms_deg']:.4f} deg "
                             f"inclination RMS over the Li grid")
            lines.append(f"  residual RMS {g.rms_before:.4g} -> {g.rms_after:.4g} {e.rms_units} (cross-validated "
                         f"{g.cv_rms_before:.4g} -> {g.cv_rms_after:.4g})"
                         + (f"; inclination {g.inc_rms_before_deg:.4f} -> {g.inc_rms_after_deg:.4f} deg"
                            if g.inc_rms_before_deg == g.inc_rms_before_deg else "")
                         + (f", azimuth {g.azi_rms_before_deg:.4f} -> {g.azi_rms_after_deg:.4f} deg"
                            if g.azi_rms_before_deg is not None else ""))
            for rc in e.detail.get("run_confounds", []):
                rival = rc["rival"].split(":")
                lines.append(f"  confound: its driver goes with {_the(rc['variable'])} here (correlation "
                             f"{rc['correlation']:.2f}); set beside {rival[0]} ({' '.join(rival[1:])}) in its place: "
                             + (f"told apart (cross-validated residual {rc['cv_without_either']:.3g} without either, "
                                f"{rc['cv_with_effect']:.3g} with it, "
                                f"{rc['cv_with_rival_instead']:.3g} with the rival; p = {rc['p_effect_beside_rival']:.2g}"
                                f" beside it)" if rc["told_apart"] else
                                f"NOT told apart (cross-validated residual {rc['cv_without_either']:.3g} without either, "
                                f"{rc['cv_with_effect']:.3g} with it, "
                                f"{rc['cv_with_rival_instead']:.3g} with the rival); to separate them, "
                                f"{rc['separate_by']}"))
        for c in self.contradicted:
            name, sensor, axis = c["effect"].split(":")
            lines.append(f"not a cause: {name} ({sensor} {axis}) {c['verdict']} -- " + "; ".join(c["reasons"])
                         + " (a sign of pose error or of a rig effect the model lacks)")
        for cf in self.confounded:
            e1, e2 = (x.split(":")[0] + " (" + " ".join(x.split(":")[1:]) + ")" if ":" in x else x
                      for x in (cf["effect"], cf["with"]))
            if cf.get("undetermined"):  # the orientations leave the baseline's ellipsoid free
                lines.append(f"not named: {e1} = {cf['estimate']:.4g} {cf['units']}: the calibration refuses these "
                             f"data ({cf['with']}); an effect found on them rests on that freedom; to tell, "
                             f"{cf['separate_by']}")
                continue
            if "share" in cf:  # an effect found on the rows read while moving only
                lines.append(f"not named: {e1} = {cf['estimate']:.4g} {cf['units']}: it rests on {e2} "
                             f"({100 * cf['share']:.0f} % of the rows, read while moving), which the holds alone "
                             + (f"do not confirm (p = {cf['p_on_holds']:.2g} on them)"
                                if cf.get("p_on_holds") is not None else "cannot confirm")
                             + f"; to tell, {cf['separate_by']}")
                continue
            if "beside_cubic" in cf:  # a temperature term an unmodelled cubic of its axis takes as well
                bc = cf["beside_cubic"]
                ps = (f"p = {bc['p_beside']:.2g} for the temperature term beside the cubic, "
                      f"{bc['p_cubic_beside']:.2g} for the cubic beside it")
                lines.append(f"not named: {e1}: confounded with {e2} (a term the library's model does not have), "
                             + (f"which takes its place ({ps})" if bc["cubic_takes_it"] else
                                f"and neither is significant beside the other ({ps}): the data cannot tell them "
                                f"apart") + f"; to separate them, {cf['separate_by']}")
                continue
            how = (f"correlation {cf['correlation']:.3f}" if cf.get("gain_share", 0.0) < cf["correlation"] ** 2
                   else f"{e2} in its place keeps {100 * cf['gain_share']:.0f} % of its gain")
            lines.append(f"confounded: {e1} {'(named)' if cf['named'] else '(not a cause)'} and {e2}, {how} in this "
                         f"run: the data cannot tell them apart; to separate them, {cf['separate_by']}")
        for rv in b.get("run_variables", []):
            lines.append(f"run: {rv['a']} and {rv['b']} go together (correlation {rv['correlation']:.2f}): an effect "
                         f"of one is also a function of the other here")
        bs = sel.get("best_subset")
        if bs:
            named = {f"{e.name}:{e.sensor}:{e.axis}" for e in self.effects}
            extra = [c for c in bs["chosen"] if c not in named]
            lines.append("best-subset check (nested K-fold): chosen " + (" + ".join(bs["chosen"]) or "none")
                         + ("" if bs["agrees_with_the_stepwise_choice"] else " (differs from the stepwise choice)")
                         + (f"; {', '.join(extra)} not named: the stepwise selection or its checks did not keep "
                            f"{'it' if len(extra) == 1 else 'them'}" if extra else ""))
            for t in bs["drop_tests"]:
                lines.append(f"  {t['term']}: " + ("asked for by the data (removing it from the pool worsens the "
                                                    "nested CV by more than 1 SE)" if t["asked_for_by_the_data"] else
                                                    "not asked for: without it the data are explained as well by "
                                                    + (" + ".join(t["model_without_it"]) or "no effect")))
            for r in bs["rivals"]:
                lines.append("  rival within 1 SE: " + (" + ".join(r) or "no effect"))
        outl = b.get("outliers", {}).get("rows", [])
        if outl:
            lines.append(f"outlier rows set aside: {len(outl)} (row: channel, size in sigma)")
            for o in outl[:20]:
                lines.append(f"  row {o['row']}: {o['channel']} {o['sigma']:+.1f}"
                             + "".join(f", {k} {v:+.1f}" for k, v in o["channels"].items() if k != o["channel"]))
            if len(outl) > 20:
                lines.append(f"  ... and {len(outl) - 20} more (--json lists them all)")
        for note in sel.get("notes", []):
            lines.append(f"  note: {note}")
        s = self.structure
        if self._unjudged():
            lines.append("unexplained: not judged (the residuals are a failed fit's: structure in them is the "
                         "model's, undetermined by these readings)")
        elif self.unexplained:
            sig = ", ".join(_structure_text(x) for x in s["significant"][:4])
            lines.append(f"unexplained: YES -- structure no library effect explains: {sig}")
            if self._moved():
                from inclino.calib.motion import cause

                lines.append(f"  in |g| likely: {cause(self.motion)}")
            if self._mispaired():
                lines.append(f"  in {self._mispaired_words()} likely: {self._pairing_text()}")
        else:
            lines.append(f"unexplained: no (smallest of {s['tests']} structure-test p-values {s['min_p']:.2g}, "
                         f"threshold {s['threshold']:.2g})")
        c = self.calibrate
        if c:
            lines.append(("calibrate refuses these data: " if c["level"] == "error" else "calibrate: warning: ")
                         + c["message"])
        lines.append(self.conclusion())
        return "\n".join(lines)

    def _unjudged(self) -> bool:
        """A pose-free baseline whose fit failed: its residuals are no fitted
        model's, so their structure is not judged (a log turned only about
        the vertical was told "structure no library effect explains, p =
        1e-211" beside "the fit failed")."""
        return self.baseline.get("mode") == "invariants" and bool(self.baseline.get("fit_failed"))

    def _moved(self) -> bool:
        """A log read mostly while moving whose |g| residual is among the
        structure no effect explains (the hand's acceleration is in it)."""
        return bool(self.motion) and any(x.get("channel") == "|g|" for x in self.structure.get("significant", []))

    def _mispaired(self) -> list:
        """The channels whose unexplained structure the rows' pairing out of
        step (the checks' warning) explains: without poses the triads'
        pairing moves the dip alone (|g| and |b| are each one triad's); with
        poses, or the accelerometer's rows against the poses, every channel.
        [] when the checks warned of none, or nothing unexplained is in
        those channels."""
        if not self.pairing or not self.unexplained:
            return []
        chans = list(dict.fromkeys(x.get("channel") for x in self.structure.get("significant", [])))
        if self.baseline.get("mode") == "invariants" and self.pairing.get("triad") != "acc":
            return ["dip"] if "dip" in chans else []
        return chans

    def _mispaired_words(self) -> str:
        ch = self._mispaired()
        return "the dip" if ch == ["dip"] else "the residuals"

    def _pairing_text(self, short: bool = False) -> str:
        """The likely cause in words: the pairing the checks named, and
        their fix (short: the conclusion's, without the why)."""
        p = self.pairing
        who = ("the accelerometer's rows and the poses paired out of step" if p.get("triad") == "acc" else
               "the triads paired out of step")
        fix = f": {p['fix']}" if p.get("fix") else ""
        if short:
            return f"{who} (the checks' row-alignment {p['level']}){fix}"
        return (f"{who}, as the checks before the fit {'found' if p['level'] == 'error' else 'warned'} (the "
                f"row-alignment {p['level']} above), which no library effect models{fix}, and diagnose again")

    def conclusion(self) -> str:
        """The report's last line: PASS when the baseline model leaves nothing
        to name (no effect, no unexplained structure), else FAIL, with the
        figures that decided it.  A finding, not a check: `inclino diagnose`
        exits 0 either way."""
        b = self.baseline
        pose_free = b.get("mode") == "invariants"
        if pose_free:
            u = {"|g|": "g", "|b|": "nT", "dip": "deg"}
            base = ", ".join(f"{k} {v:.4g} {u[k]}" for k, v in b["rms"].items())
            model = "the pose-free model (invariants only)"
        else:
            base = (f"azimuth {b['azi_rms_deg']:.4f} deg, " if b.get("azi_rms_deg") is not None else "") + \
                f"inclination {b['inc_rms_deg']:.4f} deg"
            model = "the 12-parameter model"
        alpha = b["selection"]["alpha"]
        refused = bool(self.calibrate) and self.calibrate["level"] == "error"
        if not self.effects and not self.unexplained and not refused and not (pose_free and b.get("fit_failed")):
            return (f"conclusion: PASS: {model} leaves nothing to name: no effect at alpha = {alpha:g}, "
                    f"no unexplained structure (residual RMS {base})")
        parts = []
        for e in self.effects:
            g = e.gain
            if pose_free or g.inc_rms_before_deg != g.inc_rms_before_deg:
                fig = f"residual RMS {g.rms_before:.4g} -> {g.rms_after:.4g} {e.rms_units}"
            elif g.azi_rms_before_deg is not None:
                fig = f"azimuth RMS {g.azi_rms_before_deg:.4f} -> {g.azi_rms_after_deg:.4f} deg"
            else:
                fig = f"inclination RMS {g.inc_rms_before_deg:.4f} -> {g.inc_rms_after_deg:.4f} deg"
            parts.append(f"{e.name} ({e.sensor} {e.axis}, p = {e.p_value:.2g}; {fig})")
        if self.unexplained and not self._unjudged():
            parts.append("structure no library effect explains (p = "
                         f"{self.structure['min_p']:.2g} < {self.structure['threshold']:.2g})"
                         + ("; in |g| likely the hand's acceleration: the sensor moved while it was read"
                            if self._moved() else "")
                         + (f"; in {self._mispaired_words()} likely {self._pairing_text(short=True)}"
                            if self._mispaired() else ""))
        head = (f"calibrate refuses these data ({self.calibrate.get('why') or 'see above'})" if refused else "")
        failed = "the pose-free baseline fit failed (its residuals are no fitted model's)" if pose_free and \
            b.get("fit_failed") else ""
        # calibrate's refusal first: the cause the fit's failure follows from
        return "conclusion: FAIL: " + "; ".join(x for x in (head, failed, f"{model} misses " + "; ".join(parts)
                                                           if parts else "") if x)


def _structure_text(x: dict) -> str:
    """One significant structure test in words a reader new to the tests
    follows (the JSON keeps its `channel` and `test`): a failed whiteness
    (Ljung-Box) test is a residual that is not white noise."""
    p = f"p = {x['p']:.2g}" + (f"; {x['follows']}" if x.get("follows") else "")
    if x["test"] == "whiteness" and x.get("ar_order"):
        # a channel whose rows' noise is itself correlated: the test is of what an AR(p) noise model leaves
        return (f"{x['channel']} residual more than serially correlated noise (what an AR({x['ar_order']}) noise "
                f"model leaves is not white; Ljung-Box {p})")
    if x["test"] == "whiteness":
        return (f"{x['channel']} residual not white noise (serially correlated: neighbouring rows' residuals alike; "
                f"Ljung-Box {p})")
    return f"{x['channel']} residual vs {x['test']} ({p})"


def _the(variable: str) -> str:
    """A run variable as a sentence names it: time, temperature, the
    inclination axis angle."""
    return "the " + variable if variable.endswith("angle") else variable


def pairing_of(found) -> dict | None:
    """The checks' (a checks.CheckReport) first row-alignment warning or
    error: the rows paired out of step, the triads against each other or
    the accelerometer's rows against the poses, with the fix the check
    gives; None without one (its notes: a pairing not named)."""
    for f in getattr(found, "findings", None) or ():
        if f.check == "row-alignment" and f.level in ("error", "warning"):
            return {"level": f.level, "triad": f.triad, "message": f.message, "fix": (f.figures or {}).get("fix")}
    return None
