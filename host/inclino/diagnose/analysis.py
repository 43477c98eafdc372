"""`diagnose(ds)`: baseline, residual study, effect selection, gains,
structure test (the method is described in core.py and docs/diagnose.md)."""
from __future__ import annotations

import time

import numpy as np

from inclino.engines import reference as ref
from inclino.formats.dataset import RawDataset
from inclino.errors import DataError

from . import core, forward, robust, selection, study
from ._blas import one_blas_thread
from .core import CHANNELS, EFFECT_NAMES, SEPARABLE_MIN, TRIAD_UNITS, TRIADS, Design
from .result import Diagnosis, Effect, Gain

AZI_MIN_INC_DEG = 5.0  # azimuth is compared only where it is well defined
AMBIGUOUS_CORR = 0.9
GN_ITERATIONS = 3  # re-linearisations after each change of the model (forward.py)


def parse_effects(spec) -> list | None:
    if spec is None:
        return None
    names = [s.strip() for s in (spec.split(",") if isinstance(spec, str) else spec) if s.strip()]
    bad = [s for s in names if s not in EFFECT_NAMES]
    if bad:
        raise DataError(f"unknown effect(s) {', '.join(bad)} (the library has: {', '.join(EFFECT_NAMES)})")
    if not names:
        raise DataError("--effects names no effect")
    return names


class _Attitude:
    def __init__(self, bl, ok=None):
        self.bl = bl
        self.ok = np.ones(len(bl.G), bool) if ok is None else ok
        self.Ainv = {k: np.linalg.inv(v) for k, v in bl.A.items()}
        self.a0 = ref.attitude(bl.G, bl.B)
        self.azi_rows = (self.a0["inc"] >= AZI_MIN_INC_DEG) & (self.a0["inc"] <= 180.0 - AZI_MIN_INC_DEG)

    def rms(self, R):
        """(azimuth RMS, inclination RMS) in degrees of the attitude error the
        residuals R (n, 6) amount to at the poses (outlier rows left out)."""
        g = self.bl.G + R[:, :3] @ self.Ainv["acc"].T
        b = self.bl.B + R[:, 3:] @ self.Ainv["mag"].T
        a = ref.attitude(g, b)
        di = (a["inc"] - self.a0["inc"])[self.ok]
        inc = float(np.sqrt(np.mean(di ** 2)))
        rows = self.azi_rows & self.ok
        if not rows.any():
            return None, inc
        da = ref.angle_diff(a["azi"], self.a0["azi"])[rows]
        return float(np.sqrt(np.mean(da ** 2))), inc


# A longer run is thinned to every k-th row first (inclino.formats.dataset.thin;
# peak memory about 11 kB per row)
MAX_ROWS = 40_000


def diagnose(ds: RawDataset, effects=None, alpha: float = core.DEFAULT_ALPHA, folds: int = core.DEFAULT_FOLDS,
             keep_plot_data: bool = False) -> Diagnosis:
    """Diagnose a raw dataset with turntable poses; raises DataError on bad
    input.  effects: names (list or comma-separated) to test, default all."""
    from inclino.formats.dataset import thin

    ds, thinned = thin(ds, MAX_ROWS)
    with one_blas_thread():
        r = _diagnose(ds, effects, alpha, folds, keep_plot_data)
    if thinned:
        r.baseline.setdefault("selection", {}).setdefault("notes", []).append(thinned)
    return r


NB = 25  # the baseline's columns: 12 per triad and the dip


def _diagnose(ds, effects, alpha, folds, keep_plot_data) -> Diagnosis:
    t_start = time.perf_counter()
    if not (0.0 < alpha < 1.0):
        raise DataError("alpha must be between 0 and 1")
    wanted = parse_effects(effects)
    m = _Model(ds, folds)
    testable, not_testable = _screen_candidates(m, wanted)
    steps, kept, pvals = _select(m, alpha)
    out = _assemble(m, alpha, testable, not_testable, steps, kept, pvals, keep_plot_data)
    out.elapsed_s = time.perf_counter() - t_start
    return out


class _Model:
    """The baseline fit and the model linearised at its current estimate.

    Made from the dataset: the poses prepared (core.prepare), the K folds,
    the 12-parameter baseline fitted with the noise and the outlier rows
    (core.fit_baseline); `noise_base` keeps that first noise.  `use(testable)`
    sets the candidates the design carries (their columns follow the
    baseline's NB); `refit(kept)` re-linearises by Gauss-Newton at the
    estimate of baseline + kept and re-estimates noise and outlier rows."""

    def __init__(self, ds, folds):
        d = core.prepare(ds)
        if int(folds) < 2:
            raise DataError("folds must be at least 2")
        self.d = d
        self.K = min(int(folds), d.n // 4)  # at least four readings in every fold
        bl0, noise = core.fit_baseline(d)
        self.out_rows = bl0.outliers if bl0.outliers is not None else np.zeros(d.n, bool)
        self.noise = self.noise_base = noise
        self.base = list(range(NB))
        self.bl0 = bl0
        self.testable = []
        self.idx = {}

    def start(self, testable):
        """The folds and the state at the baseline fit, then the design with `testable`."""
        self.fold_of = core.make_folds(self.d.n, self.K)
        self.state = {"A": dict(self.bl0.A), "c": dict(self.bl0.c), "dip": self.bl0.dip, "theta": {}}
        self.use(testable)

    def use(self, testable):
        """Build the design at the current state with these candidates."""
        self.testable = testable
        self.bl, self.X, self.y0 = self.build(self.state, testable)
        self.des = self.design(self.bl, self.noise, ~self.out_rows)
        self.idx = {c.key: NB + j for j, c in enumerate(testable)}

    def build(self, st, cands_now):
        """The model linearised at the state: (Baseline, X, pseudo-observation)."""
        d = self.d
        A, c, dip, th = st["A"], st["c"], st["dip"], st["theta"]
        G, Bv = forward.truth(d, dip, th)
        J = forward.pose_jacobian(d, A, c, dip, th)
        b = core.Baseline(A, c, dip, G, Bv, J, theta=dict(th), data=d)
        cols = forward.baseline_columns(d, A, c, dip, th, G, Bv)
        ccols = [forward.column(d, A, c, dip, th, cd) for cd in cands_now]
        y = d.Y - forward.readings(d, A, c, dip, th)
        for j, cd in enumerate(cands_now):
            if cd.key in th:
                y = y + th[cd.key] * ccols[j]
        return b, np.stack(cols + ccols, -1), y

    def design(self, b, nz, rows):
        return Design(self.y0, self.X, nz.whitener(b.Jpose), self.fold_of, self.K, rows=rows)

    def refit(self, kept_now):
        """Gauss-Newton: re-linearise at the estimate of the model base +
        kept_now, re-estimate the noise (robustly) and the outlier rows."""
        state, d = self.state, self.d
        S = self.base + [self.idx[k] for k in kept_now]
        for _ in range(GN_ITERATIONS):
            beta, _ = self.des.fit(S)
            beta = beta / self.des.colscale[S]
            A = {t: state["A"][t] + beta[12 * ti: 12 * ti + 12].reshape(3, 4)[:, :3] for ti, t in enumerate(TRIADS)}
            c = {t: state["c"][t] + beta[12 * ti: 12 * ti + 12].reshape(3, 4)[:, 3] for ti, t in enumerate(TRIADS)}
            th = {k: float(beta[NB + j]) for j, k in enumerate(kept_now)}
            state.update(A=A, c=c, dip=state["dip"] + float(beta[24]), theta=th)
            self.bl, self.X, self.y0 = self.build(state, self.testable)
            R = d.Y - self.bl.predict()
            self.noise, self.out_rows = robust.robust_noise(R, self.bl.Jpose,
                                                            dof_frac=1.0 - (4.5 + len(kept_now)) / d.n,
                                                            start=self.noise)
            self.des = self.design(self.bl, self.noise, ~self.out_rows)


def _screen_candidates(m: _Model, wanted):
    """The candidates to test: the wanted ones (all by default) that the data
    can test at all (core.untestable_reason) and that the poses tell from the
    baseline (separability >= SEPARABLE_MIN); sets m's design to them.
    Returns (testable, not_testable [(candidate, reason)]); raises
    DataError when a wanted effect cannot be tested or two wanted effects
    cannot be told apart."""
    d = m.d
    cands = [c for c in core.all_candidates() if wanted is None or c.name in wanted]
    testable, not_testable = [], []
    for c in cands:
        why = core.untestable_reason(d, c)
        (not_testable.append((c, why)) if why else testable.append(c))
    m.start(testable)
    sep = {c.key: m.des.separability(m.base, m.idx[c.key]) for c in testable}
    keep = []
    for c in testable:
        if sep[c.key] < SEPARABLE_MIN:
            not_testable.append((c, f"on these poses it cannot be told from the 12-parameter baseline "
                                    f"(only {100 * sep[c.key]:.2g} % of it is not absorbed)"))
        else:
            keep.append(c)
    if len(keep) < len(testable):
        testable = keep
        m.use(testable)
    if wanted is not None:
        for name in wanted:
            if not any(c.name == name for c in testable):
                why = "; ".join(sorted({r for c, r in not_testable if c.name == name}))
                raise DataError(f"cannot test {name}: {why}")
        for i, a in enumerate(testable):
            for b in testable[i + 1:]:
                r = m.des.partial_corr(m.base, m.idx[a.key], m.idx[b.key])
                if abs(r) > 0.999:
                    raise DataError(f"the poses cannot separate {a.name} ({a.sensor} {a.axis}) from {b.name} "
                                    f"({b.sensor} {b.axis}): their signatures agree to a correlation of {r:.4f}")
    return testable, not_testable


def _select(m: _Model, alpha):
    """Forward selection under the false-alarm control, then backward: keep
    the candidate with the smallest F-test p-value if p < alpha/m and it
    lowers the cross-validated residual, refit (m.refit) after each change;
    then drop kept effects whose p exceeds alpha once the others are in.
    Returns (steps, kept keys, p-values by key)."""
    base, idx = m.base, m.idx
    steps = []
    kept: list = []
    remaining = [c.key for c in m.testable]
    pvals = {}
    while remaining:
        des = m.des
        S = base + [idx[k] for k in kept]
        cv0 = des.cv(S)
        n_left = len(remaining)
        tests = sorted((des.ftest(S, [idx[k]])[0], k) for k in remaining)
        chosen = None
        for p, k in tests:
            if p >= alpha / n_left:
                break
            cv1 = des.cv(S + [idx[k]])
            if cv1 < cv0:
                chosen = (k, p, cv0, cv1)
                break
            steps.append({"effect": k, "p": p, "threshold": alpha / n_left, "cv_before": cv0, "cv_after": cv1,
                          "kept": False, "why": "no gain on held-out data"})
        if chosen is None:
            if tests:
                steps.append({"effect": tests[0][1], "p": tests[0][0], "threshold": alpha / n_left, "kept": False,
                              "why": "p above the threshold" if tests[0][0] >= alpha / n_left else "no CV gain"})
            break
        k, p, cv0, cv1 = chosen
        steps.append({"effect": k, "p": p, "threshold": alpha / n_left, "cv_before": cv0, "cv_after": cv1,
                      "kept": True})
        kept.append(k)
        pvals[k] = p
        remaining.remove(k)
        m.refit(kept)
    while kept:
        des = m.des
        S = base + [idx[k] for k in kept]
        drops = [(des.ftest([i for i in S if i != idx[k]], [idx[k]])[0], k) for k in kept]
        p, k = max(drops)
        if p <= alpha:
            for p2, k2 in drops:
                pvals[k2] = p2
            break
        kept.remove(k)
        steps.append({"effect": k, "p": p, "threshold": alpha, "kept": False, "why": "dropped: not significant "
                      "once the other effects were in"})
        m.refit(kept)
    return steps, kept, pvals


def _rms_ok(R, chans, ok):
    """RMS of the residuals R over the channels chans, outlier rows left out."""
    return float(np.sqrt(np.mean(R[ok][:, chans] ** 2)))


def _kept_effects(m: _Model, kept, pvals, est, se, S, R_final, Rs_final, Rs_cv_final, att, keep_plot_data):
    """Each kept effect with its estimate, standard error, p-value and gain
    (residual and attitude RMS without it vs with it, raw and held-out), the
    notes on candidates that look alike on these poses, and the plot entries.
    Returns (effects, notes, plot entries)."""
    des, d, bl, idx, noise = m.des, m.d, m.bl, m.idx, m.noise
    ok = ~m.out_rows
    J = bl.Jpose
    by_key = {c.key: c for c in m.testable}
    effects_out, plot_effects, notes = [], [], []
    for j, k in enumerate(kept):
        c = by_key[k]
        Sb = [i for i in S if i != idx[k]]
        Rb, Rbcv = noise.sensor_part(des.raw_residuals(Sb), J), noise.sensor_part(des.cv_residuals(Sb), J)
        ch = c.channels
        azb, inb = att.rms(Rb)
        aza, ina = att.rms(Rs_final)
        gain = Gain(_rms_ok(Rb, ch, ok), _rms_ok(Rs_final, ch, ok), _rms_ok(Rbcv, ch, ok),
                    _rms_ok(Rs_cv_final, ch, ok), azb, aza, inb, ina)
        e = Effect(c.name, c.sensor, c.axis, float(est[NB + j]), float(se[NB + j]), c.units, gain,
                   rms_units=TRIAD_UNITS[c.triad], p_value=float(pvals.get(k, np.nan)))
        effects_out.append(e)
        for other in m.testable:
            if other.key in kept:
                continue
            r = des.partial_corr(Sb, idx[k], idx[other.key])
            if abs(r) > AMBIGUOUS_CORR:
                notes.append(f"{c.name} ({c.sensor} {c.axis}) and {other.name} ({other.sensor} {other.axis}) look "
                             f"alike on these poses (correlation {r:.3f}): the data barely tell them apart")
        if keep_plot_data:
            plot_effects.append(_plot_entry(d, bl, c, m.X[:, :, idx[k]], noise, Rb, Rs_final))
    return effects_out, notes, plot_effects


def _residual_study(m: _Model, S, R, nz, ok):
    """The residual study of R under the model's columns S, the noise nz;
    outlier rows have no weight (residual 0, variance huge)."""
    var = nz.row_cov(m.bl.Jpose)[:, range(6), range(6)]
    var[m.out_rows] *= 1e12
    own = {ch: m.X[:, ch, [i for i in S if np.any(m.X[:, ch, i] != 0)]] for ch in range(6)}
    return study.study(m.d, m.bl, np.where(ok[:, None], R, 0.0), var, own)


def _assemble(m: _Model, alpha, testable, not_testable, steps, kept, pvals, keep_plot_data) -> Diagnosis:
    """The result: the final model's coefficients, the best-subset cross-check,
    the kept effects' gains, the residual study of the baseline and the
    structure test of the final model, the outlier rows, and the baseline
    section of the report."""
    des, d, bl, base, noise, noise_base = m.des, m.d, m.bl, m.base, m.noise, m.noise_base
    out_rows = m.out_rows
    S = base + [m.idx[k] for k in kept]
    est, se, s2 = des.coef(S)
    best_subset = _best_subset(des, base, kept, testable, m.idx, alpha, m.fold_of)
    att = _Attitude(bl, ~out_rows)
    J = bl.Jpose
    ok = ~out_rows

    R_final = des.raw_residuals(S)
    Rs_final, Rs_cv_final = noise.sensor_part(R_final, J), noise.sensor_part(des.cv_residuals(S), J)
    R_base = des.raw_residuals(base)
    Rs_base, Rs_base_cv = noise_base.sensor_part(R_base, J), noise_base.sensor_part(des.cv_residuals(base), J)

    effects_out, notes, plot_effects = _kept_effects(m, kept, pvals, est, se, S, R_final, Rs_final, Rs_cv_final,
                                                     att, keep_plot_data)

    # ---- residual study (baseline) and structure test (final)
    final_study = _residual_study(m, S, R_final, noise, ok)
    verdict = study.structure_verdict(final_study, alpha)
    base_study = _residual_study(m, base, R_base, noise_base, ok)
    _, zfin = robust.outlier_mask(R_final, noise, bl.Jpose)
    outliers = robust.describe(out_rows, zfin, d.order)

    def rms(R, chans):
        return _rms_ok(R, chans, ok)

    azr, inr = att.rms(Rs_base)
    dip_se = float(des.coef(base)[1][24])
    baseline = {
        "model": "per-triad 12-parameter model raw = A true + c referenced to the turntable poses, dip fitted",
        "rows": d.n, "kind": d.kind, "orientations": d.orientations,
        "field_nT": d.field_nT, "declination_deg": d.declination_deg, "gravity_g": d.gravity_g,
        "dip_deg": bl.dip, "dip_stderr_deg": dip_se,
        "acc": {"A": bl.A["acc"], "c": bl.c["acc"], "units": "g"},
        "mag": {"A": bl.A["mag"], "c": bl.c["mag"], "units": "nT"},
        "noise": noise_base.to_dict(),
        "rms": {"acc_g": [rms(Rs_base, [i]) for i in range(3)],
                "mag_nT": [rms(Rs_base, [i]) for i in range(3, 6)]},
        "cv_rms": {"acc_g": [rms(Rs_base_cv, [i]) for i in range(3)],
                   "mag_nT": [rms(Rs_base_cv, [i]) for i in range(3, 6)]},
        "rms_with_turntable_error": {"acc_g": [rms(R_base, [i]) for i in range(3)],
                                     "mag_nT": [rms(R_base, [i]) for i in range(3, 6)]},
        "azi_rms_deg": azr, "inc_rms_deg": inr,
        "residual_study": base_study,
        "outliers": {"method": (f"noise started from the per-channel MAD; rows whose whitened squared norm exceeds "
                                f"the chi-square point at p = {robust.OUTLIER_P:g}/n are set aside and the noise "
                                f"refitted without them; sizes in each channel's standard deviation under the "
                                f"final model"),
                     "rows": [o.to_dict() for o in outliers]},
        "selection": {
            "method": ("forward stepwise: keep the candidate with the smallest F-test p-value if p < alpha/m "
                       "(Bonferroni over the m candidates left) and it lowers the K-fold cross-validated "
                       "residual; noise re-estimated after each kept effect; backward pass at alpha"),
            "alpha": alpha, "folds": m.K, "tested": [c.key for c in testable],
            "not_testable": [{"effect": c.key, "reason": why} for c, why in not_testable],
            "steps": steps, "final_noise": noise.to_dict(), "final_s2": s2, "notes": notes,
            "best_subset": best_subset},
        "structure": verdict,
    }
    out = Diagnosis(baseline=baseline, effects=effects_out, unexplained=verdict["unexplained"], structure=verdict)
    if keep_plot_data:
        out.plot_data = {"effects": plot_effects, "baseline": _baseline_plot(d, bl, base_study, Rs_base)}
    return out


# --------------------------------------------------------------------------
# the shared best-subset selection as a cross-check of the kept effects
BEST_SUBSET_POOL = 8


def _best_subset(des, base, kept, testable, idx, alpha, fold_of):
    """The kept effects and the strongest other candidates (F-test p < alpha
    against the final model, up to BEST_SUBSET_POOL in all) through
    selection.select with the cross-validation folds as groups: the
    baseline's 25 columns are projected out (whitened, on all rows), every
    subset of the pool is scored by its K-fold held-out residual, the
    procedure is cross-validated nested, and each kept effect gets the
    drop-from-pool test.  None when nothing is kept or in the pool."""
    if len(kept) > BEST_SUBSET_POOL:
        # more kept effects than the exhaustive search affords (a chamber run
        # keeps all twelve temperature terms and the nonlinearities: up to
        # C(20, 8) subsets, each cross-validated nested, did not finish):
        # the stepwise choice stands alone
        return None
    S = base + [idx[k] for k in kept]
    rest = sorted((des.ftest(S, [idx[c.key]])[0], c.key) for c in testable if c.key not in kept)
    pool_keys = list(kept) + [k for p, k in rest if p < alpha][:max(0, BEST_SUBSET_POOL - len(kept))]
    if not pool_keys:
        return None
    rows = np.repeat(des.rows, 6)
    Xw = des.Xw.reshape(-1, des.Xw.shape[-1])[rows]
    yw = des.yw.reshape(-1)[rows]
    B = Xw[:, base]
    C = Xw[:, [idx[k] for k in pool_keys]]
    coef = np.linalg.lstsq(B, np.column_stack([C, yw]), rcond=None)[0]
    R = np.column_stack([C, yw]) - B @ coef
    groups = np.repeat(fold_of, 6)[rows]
    pb = selection.Problem(R[:, :-1], R[:, -1], np.ones(len(yw)), pool_keys, groups)
    s = selection.select(pb, max_terms=BEST_SUBSET_POOL, cv="group")
    d = s.to_dict()
    return {"method": "best subset of the pool (kept effects and the other candidates with p < alpha), scored by "
                      "the K-fold held-out residual (whitened, baseline projected out), nested K-fold for the "
                      "procedure, drop-from-pool test per kept effect (selection.py)",
            "pool": d["pool"], "chosen": d["chosen"], "agrees_with_the_stepwise_choice": set(d["chosen"]) == set(kept),
            "nested_cv_rms_whitened": d["nested_group_rms"],
            "rivals": [r["terms"] for r in d["rivals"]],
            "drop_tests": [{k: t[k] for k in ("term", "asked_for_by_the_data", "model_without_it",
                                               "nested_loo_rms_without", "nested_loo_rms_with")}
                           for t in d["drop_tests"]]}


# --------------------------------------------------------------------------
# what the plots show: the residual against the winning regressor
def _plot_entry(d, bl, c, col, noise, Rb, Ra):
    if c.sensor in core.TRIADS and c.axis in core.AXES:
        ch = (0 if c.sensor == "acc" else 3) + core.AXES.index(c.axis)
    else:
        w = (col ** 2 / noise.sigma ** 2).sum(0)
        ch = int(np.argmax(w))
    unit = TRIAD_UNITS[core.TRIADS[ch // 3]]
    sig = bl.signal(core.TRIADS[ch // 3])[:, ch % 3]
    if c.name == "temperature-bias":
        x, xl = d.temp, "temperature (degC)"
    elif c.name == "temperature-scale":
        x, xl = (d.temp - d.temp.mean()) * sig, f"(T - mean T) x signal ({unit} degC)"
    elif c.name == "scale-nonlinearity":
        x, xl = sig, f"{CHANNELS[ch]} signal ({unit})"
    else:
        x, xl = col[:, ch], f"{c.name} signature on {CHANNELS[ch]} ({unit} per {c.units})"
    return {"file": f"{c.name}_{c.sensor}_{c.axis}.png", "title": f"{c.name} ({c.sensor} {c.axis})",
            "x": x, "xlabel": xl, "ylabel": f"{CHANNELS[ch]} residual ({unit})",
            "before": Rb[:, ch], "after": Ra[:, ch]}


def _baseline_plot(d, bl, st, R):
    out = []
    for ch, name in enumerate(CHANNELS):
        fam = st[name]["strongest"]
        cols = study.family_columns(d, bl, ch).get(fam) if fam else None
        if cols is None:
            x, xl = np.arange(d.n, dtype=float), "reading (time order)"
        else:
            x, xl = cols[:, 0], f"{fam} regressor (first column, scaled)"
        out.append({"channel": name, "x": x, "xlabel": xl, "y": R[:, ch],
                    "ylabel": f"{name} residual ({TRIAD_UNITS[core.TRIADS[ch // 3]]})",
                    "p": st[name]["families"].get(fam, {}).get("p") if fam else None, "family": fam})
    return out
