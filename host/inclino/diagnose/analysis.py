"""`diagnose(ds)`: baseline, residual study, effect selection, gains,
structure test (the method is described in core.py and docs/diagnose.md)."""
from __future__ import annotations

import time

import numpy as np

from inclino.engines import reference as ref
from inclino.formats.dataset import POSE_COLS, RawDataset
from inclino.errors import DataError

from . import core, forward, invariants, robust, selection, serial, study, tails
from ._blas import one_blas_thread
from .core import CHANNELS, EFFECT_NAMES, SEPARABLE_MIN, TRIAD_UNITS, TRIADS, Design
from .result import Diagnosis, Effect, Gain, pairing_of
from .names import RIG_AXES
from .runvars import AXIS_VARIABLES, run_variable_confounds

AZI_MIN_INC_DEG = 5.0  # azimuth is compared only where it is well defined
AMBIGUOUS_CORR = 0.9
GN_ITERATIONS = 3  # re-linearisations after each change of the model (forward.py)
COST_GROWTH_MAX = 2.0  # a refit step that multiplies the whitened cost by more has run far: it is damped (step)


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


MEANS_TEMP_C = 0.5  # a pose's rows averaged together span at most this much of temp_c (pose_means) ...
MEANS_TEMP_NOISE_K = 5.0  # ... plus this many times the temperature reading's noise (its steps within a pose)


def pose_means(ds: RawDataset) -> tuple:
    """(dataset, note): a run read several rows at each turntable pose as
    one row per pose, each column the mean of the pose's rows (the pose
    columns the pose's own), and the note that says so; (ds, None) when
    every pose has one row.  The rows of one pose share its turntable
    readout error, and the diagnosis' noise model (noise.py) draws one per
    row: kept apart, 231 rows at 30 poses with a 0.03 deg readout error
    each (sensor noise 0.3 mg, 25 nT, the 12-parameter model exact) read as
    serially correlated residuals (Ljung-Box p 1e-16 to 1e-53 on 8 of 8
    such runs, "structure no library effect explains") and named a
    turntable azimuth offset of 0.028 +- 0.005 deg that was not there.
    The poses are calib.covariance.cluster_labels' (a pose_id column, else
    runs of rows at the same indicated pose), as calibrate's clusters,
    each split where temp_c moves more than MEANS_TEMP_C (plus
    MEANS_TEMP_NOISE_K times the temperature reading's noise, from its steps
    within a pose) from its first row (a pose held while an oven ramps keeps
    its temperatures apart; a room's jitter does not split a pose)."""
    from inclino.calib.covariance import cluster_labels

    lab = cluster_labels(ds)
    n = len(ds)
    temp = ds.columns.get("temp_c")
    if temp is not None and n:
        # a pose held while the oven ramps: its rows are not one reading (a temperature effect is in them),
        # so a pose's rows are averaged only within MEANS_TEMP_C of the first of them -- beyond the
        # temperature reading's own noise (a room's 0.1-0.3 degC jitter split 120 poses into 174, and the
        # shared readout error was read as structure on 3 of 4 clean runs)
        temp = np.asarray(temp, float)
        d = np.diff(temp)[lab[1:] == lab[:-1]]
        noise = float(robust.mad_sigma(d[:, None])[0]) / np.sqrt(2.0) if len(d) >= 5 else 0.0  # a step is two readings
        tol = MEANS_TEMP_C + MEANS_TEMP_NOISE_K * noise
        new = np.ones(n, bool)
        t0 = temp[0]
        for i in range(1, n):
            if lab[i] == lab[i - 1] and abs(temp[i] - t0) <= tol:
                new[i] = False
            else:
                t0 = temp[i]
        lab = np.cumsum(new) - 1
    k = int(lab.max()) + 1 if n else 0
    if k == n:
        return ds, None
    size = np.bincount(lab, minlength=k)
    first = np.r_[0, np.flatnonzero(np.diff(lab)) + 1]
    cols = {}
    for c, v in ds.columns.items():
        v = np.asarray(v, float)
        cols[c] = v[first] if c in POSE_COLS else np.bincount(lab, weights=v, minlength=k) / size
    note = (f"{n} readings at {k} turntable poses ({size.min()}" + ("" if size.min() == size.max() else
                                                                 f" to {size.max()}")
            + " rows each): each pose's mean is diagnosed, the rows of one pose sharing its turntable readout error"
            + ("" if size.min() == size.max() else " (the means' sensor noise taken alike)"))
    return RawDataset(cols, dict(ds.meta)), note


# A longer run is thinned first (stratified random rows: inclino.formats.dataset.thin;
# peak memory about 11 kB per row)
MAX_ROWS = 40_000


def diagnose(ds: RawDataset, effects=None, alpha: float = core.DEFAULT_ALPHA, folds: int = core.DEFAULT_FOLDS,
             keep_plot_data: bool = False, thinned: str | None = None, checks=None) -> Diagnosis:
    """Diagnose a raw dataset with turntable poses; raises DataError on bad
    input.  effects: names (list or comma-separated) to test, default all.
    checks: the checks before any fit (a checks.CheckReport) when the caller
    ran them: kept in the result (`checks`), and without poses given to
    `calibrate`'s own fit, whose refusal or warning is kept too
    (`calibrate`: posefree.calibrate_says)."""
    from inclino import checks as pre
    from inclino.formats.dataset import thin

    held = checks.one_orientation if checks is not None else pre.one_orientation(ds)
    if held:  # one orientation held: the data determine no model, whatever the structure of its residuals
        raise DataError(pre.undetermined(held, len(ds)))
    if ds.has_pose and ds.has_acc and ds.has_mag:
        ds, means = pose_means(ds)
        thinned = "; ".join(x for x in (means, thinned) if x) or None
    ds, note = thin(ds, MAX_ROWS)
    # `thinned` came in as the note of a run the caller thinned already (thin(ds, MAX_ROWS))
    thinned = "; ".join(x for x in (thinned, note) if x) or None
    bad = pre.not_a_temperature(ds)
    if bad is not None:  # a pose angle or a sensor axis: no temperature effect is tested against it
        import dataclasses

        ds = dataclasses.replace(ds, columns={k: v for k, v in ds.columns.items() if k != "temp_c"})
        left_out = f"temp_c left out: it does not look like a temperature: {bad[0]}"
        thinned = f"{thinned}; {left_out}" if thinned else left_out  # a note, as the thinning's
    if not ds.has_pose or not (ds.has_acc and ds.has_mag):
        # without the turntable's poses (or with one triad): what the invariants show (posefree.py)
        if effects is not None:
            raise DataError("--effects needs a dataset with both triads and the turntable's poses (inc_deg, "
                            "azi_deg, tf_deg): without them the diagnosis tests what the invariants can show")
        from .posefree import diagnose_posefree

        with one_blas_thread():
            r = diagnose_posefree(ds, alpha=alpha, folds=folds, keep_plot_data=keep_plot_data)
        present = [c for c in POSE_COLS if c in ds.columns]
        missing = [c for c in POSE_COLS if c not in present]
        # one triad first: an accelerometer-only six-face log with inc and tf from its face labels was told
        # its poses lacked an azimuth, which no accelerometer needs
        why = ("one triad only (the pose-based model needs both)"
               + ("" if ds.has_pose else f"; its {' and '.join(present)} read as rig angles" if present else
                  ", and no turntable poses")
               if not (ds.has_acc and ds.has_mag) else
               "no turntable poses" if not present else
               f"poses incomplete: no {', '.join(missing)} column; the angles there are read as rig angles")
        if ds.has_pose:  # the poses are there: what these effects need is the pose-based model's second triad
            r.baseline["selection"]["needs_label"] = "needs the pose-based model (both triads)"
        r.baseline["selection"]["notes"].insert(0, f"pose-free diagnosis ({why}): the invariants |g|, |b| and the "
                                                   f"dip against time, temperature, reading order and rig angles")
        if thinned:
            r.baseline["selection"]["notes"].append(thinned)
        from inclino.calib.motion import figures

        r.motion = figures(ds)
        from .posefree import calibrate_says

        if checks is not None:
            r.checks = checks.to_dict()
            r.pairing = pairing_of(checks)
        with one_blas_thread():
            r.calibrate = calibrate_says(ds, checks, static=bool(checks is not None and checks.declared_static))
        return r
    with one_blas_thread():
        r = _diagnose(ds, effects, alpha, folds, keep_plot_data)
    if thinned:
        r.baseline.setdefault("selection", {}).setdefault("notes", []).append(thinned)
    if checks is not None:
        r.checks = checks.to_dict()
        r.pairing = pairing_of(checks)
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
    baseline's NB; a one-parameter effect has one column, the rig field one
    per direction of its basis: `idx[key]` is the list); `refit(kept)`
    re-linearises by Gauss-Newton at the estimate of baseline + kept and
    re-estimates noise and outlier rows."""

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
        self.dropped_rig = {}  # key -> full parameter vector of a rig field the cross-check dropped
        self.rig_joint = frozenset()  # the kept rig axes the bases were made identifiable for (_rig_identify)
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
        self.des = self.X = None  # the design with the earlier candidates goes before this one is built
        self.bl, self.X, self.y0, sizes = self.build(self.state, testable)
        self.des = self.design(self.bl, self.noise, ~self.out_rows)
        self.idx, j = {}, NB
        for cd, k in zip(testable, sizes):
            self.idx[cd.key] = list(range(j, j + k))
            j += k

    def cols(self, keys) -> list:
        return [i for k in keys for i in self.idx[k]]

    def build(self, st, cands_now):
        """The model linearised at the state: (Baseline, X, pseudo-observation, columns per candidate)."""
        d = self.d
        A, c, dip, th = st["A"], st["c"], st["dip"], st["theta"]
        G, Bv = forward.truth(d, dip, th)
        J = forward.pose_jacobian(d, A, c, dip, th)
        b = core.Baseline(A, c, dip, G, Bv, J, theta=dict(th), data=d)
        cols = forward.baseline_columns(d, A, c, dip, th, G, Bv)
        sizes = []
        y = d.Y - forward.readings(d, A, c, dip, th)
        for cd in cands_now:
            cl = forward.columns(d, A, c, dip, th, cd)
            cols += cl
            sizes.append(len(cl))
            if cd.key in th:
                for v, col in zip(np.atleast_1d(th[cd.key]), cl):
                    y = y + float(v) * col
            del cl
        # the columns into the design one at a time, each dropped once copied (np.stack held the list
        # and the stacked copy at once: two designs' worth)
        X = np.empty(cols[0].shape + (len(cols),))
        for j in range(len(cols)):
            X[..., j] = cols[j]
            cols[j] = None
        return b, X, y, sizes

    def design(self, b, nz, rows):
        des = Design(self.y0, self.X, nz.whitener(b.Jpose), self.fold_of, self.K, rows=rows)
        des.serial = True  # rows in time order: neighbours that share their error deflate the F-tests (serial)
        des.tails = True  # heavy-tailed noise: a signature on a few rows is tested by its sandwich too (tails)
        return des

    def state_after(self, kept_now, beta):
        """The state a Gauss-Newton step of the model base + kept_now gives
        (beta unscaled, in the order of base + cols(kept_now))."""
        st = self.state
        A = {t: st["A"][t] + beta[12 * ti: 12 * ti + 12].reshape(3, 4)[:, :3] for ti, t in enumerate(TRIADS)}
        c = {t: st["c"][t] + beta[12 * ti: 12 * ti + 12].reshape(3, 4)[:, 3] for ti, t in enumerate(TRIADS)}
        th, pos = {}, NB
        for k in kept_now:
            n = len(self.idx[k])
            v = np.asarray(beta[pos:pos + n], float)
            th[k] = float(v[0]) if n == 1 and not k.startswith("rig-field:") else v.copy()
            pos += n
        return {"A": A, "c": c, "dip": st["dip"] + float(beta[24]), "theta": th}

    def step(self, kept_now, S):
        """The state one Gauss-Newton step of the model base + kept_now
        (columns S of the current design) gives; damped (Levenberg-Marquardt:
        the step's normal equations with lam times their diagonal added)
        where the full step multiplies the cost (the whitened residual in the
        current metric, _cost) by more than COST_GROWTH_MAX, or leaves the
        triads' matrices or the pose Jacobian unbounded (_bounded); no step
        that does not: the state as it is.

        Nearly collinear terms make the full step run far: a rig field of the
        inclination axis on a continuous rotation at three inclinations,
        whose sum with the dip and the fluxgate's 3x3 fits to 35 nT in the
        linear model, moved the dip 22-93 deg and left 3 000-24 000 nT in the
        readings (the selection then dropped both rig fields of that run as
        not significant).  A step is not damped where it merely raises the
        cost: a large term the noise still holds (a 2 deg inclination
        offset, read as 2 deg of readout noise before it is in the model)
        costs little in that metric, and the step that puts it in leaves
        its second-order part (tens of nT) for the next step to take; kept
        only where the cost fell, the offset never came in and the
        cross-checks then dropped it."""
        des = self.des
        cs = des.colscale[S]
        G, b = des.G[np.ix_(S, S)], des.b[S]
        # the current state in the design's (scaled) columns: the baseline's part is the step, a kept
        # term's its whole value (its signature is added back into the pseudo-observation)
        cur = np.zeros(len(S))
        pos = NB
        for k in kept_now:
            n = len(self.idx[k])
            cur[pos:pos + n] = np.atleast_1d(self.state["theta"].get(k, np.zeros(n))) * cs[pos:pos + n]
            pos += n
        here = self.state_after(kept_now, cur / cs)  # the state as it is, in the model base + kept_now
        # every state weighed in one metric, the current one's (the step minimises the linearised cost in
        # it): a trial's own pose Jacobian would change the whitening under it (a 1.6 deg azimuth offset
        # turns it by 1.6 deg, and with the readout noise still holding the offset the better state cost more)
        W = self.noise.whitener(self.bl.Jpose[~self.out_rows])
        cost0, _ = self._cost(here, W)
        D = np.diag(np.diag(G))
        for lam in (0.0, 1e-4, 1e-2, 1.0, 1e2, 1e4):
            with np.errstate(all="ignore"):
                step = Design._solve(G + lam * D, b - G @ cur)
            if not np.isfinite(step).all():
                continue
            trial = self.state_after(kept_now, (cur + step) / cs)
            cost, J = self._cost(trial, W)
            if np.isfinite(cost) and self._bounded(trial, J) and cost <= COST_GROWTH_MAX * cost0:
                return trial
        return here

    def _cost(self, st, W):
        """(The residual's sum of squares at the state st whitened by W (per
        row, outlier rows left out); the pose Jacobian there)."""
        d = self.d
        A, c, dip, th = st["A"], st["c"], st["dip"], st["theta"]
        ok = ~self.out_rows
        with np.errstate(all="ignore"):
            J = forward.pose_jacobian(d, A, c, dip, th)
            R = (d.Y - forward.readings(d, A, c, dip, th))[ok]
            if not (np.isfinite(R).all() and np.isfinite(J).all()):
                return np.inf, J
            cost = float((np.einsum("nij,nj->ni", W, R) ** 2).sum())
        return (cost if np.isfinite(cost) else np.inf), J

    def _bounded(self, state, J) -> bool:
        """A step keeps each triad's matrix, and the readings' sensitivity to
        the pose, within a factor 2 of the current ones: a larger change is
        collinear terms cancelling each other (their sum fits, each one is
        arbitrary), not a calibration."""
        for t in TRIADS:
            a0, a1 = np.linalg.norm(self.state["A"][t]), np.linalg.norm(state["A"][t])
            if not (np.isfinite(a1) and 0.5 * a0 <= a1 <= 2.0 * a0):
                return False
        j0, j1 = np.abs(self.bl.Jpose).max(), np.abs(J).max()
        return bool(np.isfinite(j1) and j1 <= 2.0 * j0)

    def refit(self, kept_now):
        """Gauss-Newton: re-linearise at the estimate of the model base +
        kept_now, re-estimate the noise (robustly) and the outlier rows."""
        d = self.d
        th = self.state["theta"]
        stale = [k for k in th if k not in kept_now]  # dropped terms leave the state before the fit, so that
        if stale:  # a step is weighed against the model it fits, not against one with them still in
            self.state = dict(self.state, theta={k: v for k, v in th.items() if k in kept_now})
        if not _rig_identify(self, kept_now) and stale:
            self.use(self.testable)
        S = self.base + self.cols(kept_now)
        for _ in range(GN_ITERATIONS):
            state = self.step(kept_now, S)
            # the design at the old state is not used again: its arrays (the largest of a diagnosis) go
            # before the new state's are built
            self.des = self.X = None
            built = None
            built = self.build(state, self.testable)
            self.state = state
            self.bl, self.X, self.y0, _ = built
            R = d.Y - self.bl.predict()
            self.noise, self.out_rows = robust.robust_noise(R, self.bl.Jpose,
                                                            dof_frac=1.0 - (4.5 + len(S) - NB) / d.n,
                                                            start=self.noise)
            self.des = self.design(self.bl, self.noise, ~self.out_rows)


def _rig_bases(m: _Model, cands, joint=()) -> dict:
    """Per rig-field candidate, the directions of its full parameter vector
    (harmonics x components in its axis' frame) that the baseline does not
    absorb: the whitened columns with the baseline projected out, their
    singular directions kept where at least RIG_SEPARABLE_MIN of the
    direction is left.  The axes in `joint` are taken in RIG_AXES order
    (azimuth, inclination, toolface), each also without what those before
    it keep (_rig_identify).  Sets d.rig_basis (forward.columns reads it);
    returns axis -> the reason it is not testable, when none is left."""
    d, bl = m.d, m.bl0
    d.rig_basis = {}
    why = {}
    rows = ~m.out_rows
    Linv = m.noise_base.whitener(bl.Jpose)[rows]
    Xb = np.stack(forward.baseline_columns(d, bl.A, bl.c, bl.dip, {}, bl.G, bl.B), -1)[rows]
    Bw = np.einsum("nij,njp->nip", Linv, Xb).reshape(-1, Xb.shape[-1])
    Q0, _ = np.linalg.qr(Bw)
    Qj = Q0
    order = {ax: i for i, ax in enumerate(RIG_AXES)}
    for cd in sorted((c for c in cands if c.name == "rig-field"), key=lambda c: order[c.axis]):
        Q = Qj if cd.axis in joint else Q0
        F = np.einsum("ij,njp->nip", bl.A["mag"], forward.rig_full(d, cd.axis))  # (n, 3, P)
        Xf = np.zeros((d.n, 6, F.shape[-1]))
        Xf[:, 3:, :] = F
        W = np.einsum("nij,njp->nip", Linv, Xf[rows]).reshape(-1, F.shape[-1])
        norms = np.sqrt((W ** 2).sum(0))
        norms[norms == 0] = 1.0
        Wn = W / norms
        Wp = Wn - Q @ (Q.T @ Wn)
        _, sv, Vt = np.linalg.svd(Wp, full_matrices=False)
        pre = np.sqrt(((Wn @ Vt.T) ** 2).sum(0))
        keep = sv > core.RIG_SEPARABLE_MIN * np.maximum(pre, 1e-300)
        if not keep.any():
            why[cd.axis] = "on these poses the 12-parameter baseline absorbs a field that moves with this axis"
            continue
        d.rig_basis[cd.axis] = (Vt[keep].T / norms[:, None])
        if cd.axis in joint:
            Qj, _ = np.linalg.qr(np.concatenate([Qj, Wp @ Vt[keep].T], axis=1))
    return why


def _rig_identify(m: _Model, kept_now) -> bool:
    """The rig fields' bases for the model base + kept_now, made
    identifiable.  A field fixed to the azimuth platform is the inclination
    axis' h = 0 and part of the azimuth axis' h = 1 at once (forward.rig_full;
    a field fixed to the inclination arm likewise the toolface axis' h = 0 and
    part of the inclination axis' h = 0-1): with two such fields kept, the
    pair is free along the shared directions.  The fit does not see that
    freedom, but the sizes do -- they followed the start of the fit (BROAD
    05: 133 to 995 nT between versions, with stated errors of 6-21 nT, as the
    pseudo-inverse gives a free direction no variance; on the emulator, two
    400 nT fields came out at 6 556 and 6 636 nT) -- and so do the tests that
    project one out of the other (tails.sandwich then gave p = 1 to a field
    worth 10^5 in F).  So, while two or more are kept, the shared directions
    are the outer axis' (the one that turns the other: what is fixed to the
    azimuth platform turns with the azimuth) and come out of the inner axis'
    basis; with one kept, each axis has its own whole basis again.  The span
    of the kept fields is the same either way, and the state's fields are
    carried over.  Returns whether a basis changed (then m's design is
    rebuilt at the carried-over state)."""
    d = m.d
    rig = [c for c in m.testable if c.name == "rig-field"]
    axes = [c.axis for c in rig if c.key in kept_now]
    joint = frozenset(axes) if len(axes) >= 2 else frozenset()
    if joint == m.rig_joint:  # the bases already made for these kept fields (the screening's, for none or one)
        return False
    m.rig_joint = joint
    old = dict(d.rig_basis)
    why = _rig_bases(m, rig, joint=joint)
    for c in rig:  # nothing left of an inner axis beside the outer ones: it keeps its basis (not expected: the
        if c.axis in why:  # selection would not keep a field the kept ones already span)
            d.rig_basis[c.axis] = old[c.axis]
    if all(d.rig_basis[c.axis].shape == old[c.axis].shape and np.allclose(d.rig_basis[c.axis], old[c.axis])
           for c in rig):
        d.rig_basis = old
        return False
    th = dict(m.state["theta"])
    have = [ax for ax in axes if forward.rig_key(ax) in th]
    if have:
        field = sum(forward.rig_full(d, ax, th) @ (old[ax] @ np.asarray(th[forward.rig_key(ax)], float))
                    for ax in have)  # (n, 3) nT: the kept fields' sum at the state
        cols = [forward.rig_full(d, ax, th) @ d.rig_basis[ax] for ax in axes]
        coef = np.linalg.lstsq(np.concatenate(cols, -1).reshape(3 * d.n, -1), field.reshape(-1), rcond=None)[0]
        for ax, v in zip(axes, np.split(coef, np.cumsum([c.shape[-1] for c in cols])[:-1])):
            th[forward.rig_key(ax)] = v
        m.state = dict(m.state, theta=th)
    m.use(m.testable)
    return True


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
    rig_why = _rig_bases(m, testable)
    for c in list(testable):
        if c.name == "rig-field" and c.axis in rig_why:
            testable.remove(c)
            not_testable.append((c, rig_why[c.axis]))
    m.start(testable)
    sep = {c.key: (1.0 if c.name == "rig-field" else m.des.separability(m.base, m.idx[c.key][0]))
           for c in testable}
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
                r = m.des.canon_corr(m.base, m.idx[a.key], m.idx[b.key])
                if abs(r) > 0.999:
                    raise DataError(f"the poses cannot separate {a.name} ({a.sensor} {a.axis}) from {b.name} "
                                    f"({b.sensor} {b.axis}): their signatures agree to a correlation of {r:.4f}")
    return testable, not_testable


def pose_axes_acted_as(cand) -> tuple:
    """The turntable axes (0 inc, 1 azi, 2 tf) whose readout error the
    candidate's change of the readings is, row by row: every axis for a
    turntable effect; the azimuth for a declination drift -- the field
    turning about the vertical by delta(t) reads exactly as the probe turned
    in azimuth by -delta(t) (gravity, being vertical, does not see it), so
    its column is the pose Jacobian's azimuth column times time; none for an
    effect of the sensors or of the field's size and dip."""
    if cand.sensor == "turntable":
        return (0, 1, 2)
    if cand.name == "field-drift" and cand.axis == "declination":
        return (1,)
    return ()


def _part(m: _Model, R, cand):
    """The residual a candidate's gain is measured on: R net of each row's
    turntable readout error (its conditional mean given the noise model) on
    the axes the candidate does not act as (pose_axes_acted_as): the sensor
    part for an effect of the sensors or the world, the whole residual for a
    turntable effect -- the readout error on an axis the effect acts as
    would be taken out with the effect.  Of a declination drift, the sensor
    part keeps about 5 % on the bench's plans: while its gain was taken
    there, drifts with p = 0 and a falling whitened held-out residual failed
    the own-channel check (at z = 6-10, and at z = 98 with spiked rows).
    On the whole residual it would carry the inclination and toolface
    readout errors, which the accelerometer pins; net of those, it keeps
    the drift and the azimuth readout error it competes with."""
    acted = pose_axes_acted_as(cand)
    if len(acted) == 3:
        return R
    return m.noise.sensor_part(R, m.bl.Jpose, axes=[k for k in range(3) if k not in acted])


TURNTABLE_GAIN_UNITS = "whitened noise SD, both triads"


def _gain_rms(m: _Model, R, cand, ok) -> float:
    """The RMS a candidate's gain is given in (its units: _gain_units),
    rows `ok`, of the residual R: its triad's channels in the triad's
    units; for a turntable effect both triads' six channels whitened by
    each row's noise covariance (sensor noise and turntable readout error
    through the pose Jacobian, Noise.row_cov), the metric the fit and its
    selection use.  A pose error moves both triads, and on one of them
    alone its whole residual is mostly the readout error: an
    inclination-axis skew at z = 10.8 (p = 1e-26, estimated within 0.6 % of
    the truth, whitened held-out residual 1.017 -> 0.983) raised the
    fluxgate's 34.32 nT by 0.06 nT and was dropped as contradicting its own
    held-out data.  Each channel divided by its own standard deviation (the
    covariance's diagonal) still weighs the readout error's correlated
    part as if it were independent: an azimuth offset of -0.036 deg at
    z = 9.6 on the static plan (p = 1e-16, azimuth RMS 0.059 -> 0.055 deg,
    the whitened held-out residual falling) raised that RMS from 0.9943 to
    0.9945 and was dropped (case seed 935660852)."""
    if cand.sensor == "turntable":  # the design's whiteners (Noise.whitener of the pose Jacobian)
        return float(np.sqrt(np.mean(np.einsum("nij,nj->ni", m.des.Linv[ok], R[ok]) ** 2)))
    return _rms_ok(R, cand.channels, ok)


def _gain_units(cand) -> str:
    return TURNTABLE_GAIN_UNITS if cand.sensor == "turntable" else TRIAD_UNITS[cand.triad]


def _own_cv(m: _Model, S, cand) -> float:
    """The held-out RMS of the candidate's own channels (outlier rows left
    out) under the model columns S: what its printed gain is."""
    return _gain_rms(m, _part(m, m.des.cv_residuals(S), cand), cand, ~m.out_rows)


def _select(m: _Model, alpha):
    """Forward selection under the false-alarm control, then backward: keep
    the candidate with the smallest F-test p-value if p < alpha/m, it lowers
    the cross-validated residual (whitened, all channels) and it lowers the
    held-out residual of its own channels (the gain the report prints);
    refit (m.refit) after each change; then drop kept effects whose p
    exceeds alpha once the others are in.  Returns (steps, kept keys,
    p-values by key)."""
    base = m.base
    steps = []
    kept: list = []
    remaining = [c.key for c in m.testable]
    by_key = {c.key: c for c in m.testable}
    pvals = {}
    while remaining:
        des = m.des
        S = base + m.cols(kept)
        cv0 = des.cv(S)
        n_left = len(remaining)
        tests = sorted((des.ftest(S, m.idx[k])[0], k) for k in remaining)
        chosen = None
        for p, k in tests:
            if p >= alpha / n_left:
                break
            S1 = S + m.idx[k]
            cv1 = des.cv(S1)
            own0, own1 = _own_cv(m, S, by_key[k]), _own_cv(m, S1, by_key[k])
            if cv1 < cv0 and own1 < own0:
                chosen = (k, p, cv0, cv1, own0, own1)
                break
            steps.append({"effect": k, "p": p, "threshold": alpha / n_left, "cv_before": cv0, "cv_after": cv1,
                          "own_cv_rms_before": own0, "own_cv_rms_after": own1, "kept": False,
                          "why": "no gain on held-out data" if cv1 >= cv0 else
                          "its own channels' held-out residual does not fall"})
        if chosen is None:
            if tests:
                steps.append({"effect": tests[0][1], "p": tests[0][0], "threshold": alpha / n_left, "kept": False,
                              "why": "p above the threshold" if tests[0][0] >= alpha / n_left else "no CV gain"})
            break
        k, p, cv0, cv1, own0, own1 = chosen
        steps.append({"effect": k, "p": p, "threshold": alpha / n_left, "cv_before": cv0, "cv_after": cv1,
                      "own_cv_rms_before": own0, "own_cv_rms_after": own1, "kept": True})
        kept.append(k)
        pvals[k] = p
        remaining.remove(k)
        des = None  # the old design goes before refit builds the new one
        m.refit(kept)
    _backward(m, kept, pvals, steps, alpha)
    return steps, kept, pvals


def _backward(m: _Model, kept, pvals, steps, alpha):
    """Drop kept effects whose p-value rose above alpha once the others are in."""
    while kept:
        des = m.des
        S = m.base + m.cols(kept)
        drops = [(des.ftest([i for i in S if i not in m.idx[k]], m.idx[k])[0], k) for k in kept]
        p, k = max(drops)
        if p <= alpha:
            for p2, k2 in drops:
                pvals[k2] = p2
            break
        kept.remove(k)
        steps.append({"effect": k, "p": p, "threshold": alpha, "kept": False, "why": "dropped: not significant "
                      "once the other effects were in"})
        des = None  # the old design goes before refit builds the new one
        m.refit(kept)


def _rms_ok(R, chans, ok):
    """RMS of the residuals R over the channels chans, outlier rows left out."""
    return float(np.sqrt(np.mean(R[ok][:, chans] ** 2)))


def _invariants(m: _Model, keys, S):
    """Invariant residuals (invariants.residuals) of the model base + keys
    after a Gauss-Newton step from the current state (_Model.step)."""
    st = m.step(keys, S)
    return invariants.residuals(m.d, st["A"], st["c"], st["dip"], st["theta"])


def _rig_amplitude(m: _Model, k, theta_k, cov_k):
    """(RMS over the rows and fluxgate axes of the rig field's reading change
    that the baseline cannot absorb (nT), its standard error, per-harmonic
    amplitudes in the axis' frame): the size of the disturbance as the data
    show it (forward.unabsorbed; the rest of it went into the fitted
    calibration, _rig_calibration_error says how much that costs)."""
    d = m.d
    axis = k.split(":")[2]
    V = d.rig_basis[axis]
    A_mag = m.state["A"]["mag"]
    Z = np.einsum("ij,njp->nip", A_mag, forward.rig_full(d, axis, m.state["theta"]) @ V)  # (n, 3, r)
    Zr = forward.unabsorbed(d, A_mag, m.state["dip"], Z)
    Q = np.einsum("nip,niq->pq", Zr, Zr) / (3 * d.n)
    th = np.asarray(theta_k, float)
    QS = Q @ cov_k
    q = float(th @ Q @ th)
    # the noise in the estimate adds tr(Q cov) to its square on average: taken off
    a = float(np.sqrt(max(q - float(np.trace(QS)), 0.0)))
    # var(a^2) = 4 th'Q cov Q th + 2 tr((Q cov)^2) (Gaussian), and d a = d a^2 / 2a; th'Q cov Q th at the
    # estimate is high by tr((Q cov)^2) on average, taken off (with the first-order plug-in alone the
    # stated error came out 0.8-1.6 x what the plan allows, plans.rig_rms_stderr)
    t2 = float(np.trace(QS @ QS))
    v = max(float(th @ QS @ Q @ th) - 0.5 * t2, 0.5 * t2)
    se = float(np.sqrt(v)) / max(a, 0.5 * float(np.sqrt(max(q, 0.0))), 1e-300)
    full = V @ th
    harm = {}
    for j, (h, kind) in enumerate(forward.rig_terms(axis)):
        harm.setdefault(h, np.zeros(3))
        harm[h] = harm[h] + full[3 * j:3 * j + 3] ** 2
    return a, se, {f"h{h}_nT": float(np.sqrt(v.sum())) for h, v in harm.items()}


def _rig_calibration_error(m: _Model, kept, k) -> dict:
    """The error a calibration made on this rig carries when it ignores the
    rig field: the fit without it (the baseline then absorbs what it can of
    the field into the fluxgate's 3x3 and offset) against the fit with it,
    over the Li 2021 grid at toolfaces 0/120/240 (azimuth where I >= 5 deg)."""
    from inclino.calib.runs import li2021_grid

    S = m.base + m.cols(kept)
    Sb = [i for i in S if i not in m.idx[k]]
    sw = m.state_after(kept, m.des.fit(S)[0] / m.des.colscale[S])
    so = m.state_after([x for x in kept if x != k], m.des.fit(Sb)[0] / m.des.colscale[Sb])
    I, A, T = li2021_grid((0.0, 120.0, 240.0))
    d = m.d
    g, f = ref.body_vectors(I, A, T, d.field_nT, sw["dip"], d.declination_deg, d.gravity_g)
    acc = g @ sw["A"]["acc"].T + sw["c"]["acc"]
    mag = f @ sw["A"]["mag"].T + sw["c"]["mag"]
    a = ref.attitude((acc - so["c"]["acc"]) @ np.linalg.inv(so["A"]["acc"]).T,
                     (mag - so["c"]["mag"]) @ np.linalg.inv(so["A"]["mag"]).T)
    ok = I >= AZI_MIN_INC_DEG
    da = ref.angle_diff(a["azi"], A + d.declination_deg)[ok]
    di = a["inc"] - I
    return {"azi_rms_deg": float(np.sqrt(np.mean(da ** 2))), "inc_rms_deg": float(np.sqrt(np.mean(di ** 2))),
            "what": "a calibration fitted on this rig without the rig field, against one with it, over the Li 2021 "
                    "grid (toolfaces 0/120/240): the error the rig's field leaves in the probe's calibration when "
                    "it is not modelled"}


def _effect_checks(m: _Model, kept, att):
    """Per kept effect, the checks before it is named: its gain (the final
    model without it against with it, raw and held-out, on its own
    channels), its own held-out residual must fall, and it must not make
    the invariants of what it acts on worse (invariants.compare).  Returns
    key -> dict(gain, invariants, passed, reason)."""
    des, d, bl, noise = m.des, m.d, m.bl, m.noise
    ok = ~m.out_rows
    J = bl.Jpose
    by_key = {c.key: c for c in m.testable}
    S = m.base + m.cols(kept)
    R_final = des.raw_residuals(S)
    inv_with = _invariants(m, kept, S)
    out = {}
    R_cv_final = des.cv_residuals(S)
    for k in kept:
        c = by_key[k]
        Sb = [i for i in S if i not in m.idx[k]]
        Rb, Rbcv = _part(m, des.raw_residuals(Sb), c), _part(m, des.cv_residuals(Sb), c)
        Ra, Racv = _part(m, R_final, c), _part(m, R_cv_final, c)
        units = _gain_units(c)
        azb, inb = att.rms(Rb)
        aza, ina = att.rms(Ra)
        gain = Gain(*(_gain_rms(m, R, c, ok) for R in (Rb, Ra, Rbcv, Racv)), azb, aza, inb, ina)
        inv = invariants.compare(inv_with, _invariants(m, [x for x in kept if x != k], Sb), invariants.which(c), ok)
        reasons = []
        if not gain.cv_rms_after < gain.cv_rms_before:
            reasons.append(f"it raises its own cross-validated residual ({gain.cv_rms_before:.4g} -> "
                           f"{gain.cv_rms_after:.4g} {units})")
        for name, r in inv.items():
            if r["worse"]:
                reasons.append(f"it makes the pose-free {name} residual worse ({r['rms_without']:.4g} -> "
                               f"{r['rms_with']:.4g})")
        out[k] = {"gain": gain, "units": units, "invariants": inv, "passed": not reasons, "reasons": reasons,
                  "Rb": Rb, "Rs_final": Ra, "Sb": Sb}
    return out


def _cross_check(m: _Model, kept, pvals, steps, alpha, att):
    """Drop, one at a time (the worst first), kept effects that fail their
    checks, refitting after each: they fit the poses but contradict the
    invariants (or their own held-out data), a sign of pose error or of a
    rig effect the model lacks -- reported, not named as causes.  Returns
    (checks of the effects that stay, contradicted records)."""
    contradicted = []
    while True:
        checks = _effect_checks(m, kept, att)
        bad = [k for k in kept if not checks[k]["passed"]]
        if not bad:
            return checks, contradicted
        worst = max(bad, key=lambda k: (len(checks[k]["reasons"]),
                                        checks[k]["gain"].cv_rms_after / max(checks[k]["gain"].cv_rms_before, 1e-300)))
        est = m.state["theta"].get(worst)
        if worst.startswith("rig-field:"):  # its field, whatever basis its axis has once it is gone (_rig_identify)
            m.dropped_rig[worst] = m.d.rig_basis[worst.split(":")[2]] @ np.asarray(est, float)
        ck = checks[worst]
        contradicted.append({"effect": worst, "estimate": est, "p": float(pvals.get(worst, np.nan)),
                             "reasons": ck["reasons"], "gain": ck["gain"].to_dict(),
                             "invariants": ck["invariants"],
                             "verdict": "fits the poses but contradicts the invariants" if any(
                                 "pose-free" in r for r in ck["reasons"]) else
                             "fits the poses but not its own held-out data"})
        kept.remove(worst)
        pvals.pop(worst, None)
        steps.append({"effect": worst, "kept": False, "why": "cross-check failed: " + "; ".join(ck["reasons"])})
        m.refit(kept)
        _backward(m, kept, pvals, steps, alpha)


def _kept_effects(m: _Model, kept, pvals, est, cov, S, checks, keep_plot_data):
    """Each kept effect with its estimate, standard error, p-value and gain
    (from its checks), and the plot entries.  Returns (effects, plot entries)."""
    d, bl, noise = m.d, m.bl, m.noise
    by_key = {c.key: c for c in m.testable}
    effects_out, plot_effects = [], []
    pos = NB
    for k in kept:
        c = by_key[k]
        n = len(m.idx[k])
        ck = checks[k]
        detail = {"checks": {"own_cv": "passed", "invariants": ck["invariants"]}}
        if c.name == "rig-field":
            a, se, harm = _rig_amplitude(m, k, est[pos:pos + n], cov[pos:pos + n, pos:pos + n])
            detail.update({"model": f"a field moving with the turntable's {c.axis} axis, harmonics "
                                    f"{', '.join(str(h) for h in sorted({h for h, _ in forward.rig_terms(c.axis)}))} "
                                    f"of its angle in the frame that axis turns in (effects.RigField)",
                           "harmonics_rms_nT": harm, "directions": n, "whose": "the rig's, not the probe's",
                           "calibration_error_if_ignored": _rig_calibration_error(m, kept, k)})
            value, stderr, units = a, se, "nT RMS"
        else:
            value, stderr, units = float(est[pos]), float(np.sqrt(max(cov[pos, pos], 0.0))), c.units
        e = Effect(c.name, c.sensor, c.axis, value, stderr, units, ck["gain"],
                   rms_units=ck["units"], p_value=float(pvals.get(k, np.nan)), detail=detail)
        effects_out.append(e)
        if keep_plot_data:
            plot_effects.append(_plot_entry(d, bl, c, m.X[:, :, m.idx[k][0]], noise, ck["Rb"], ck["Rs_final"]))
        pos += n
    return effects_out, plot_effects


CONFOUND_CORR = 0.9


def _driver(c) -> str:
    if c.name.startswith("temperature-"):
        return "temperature"
    if c.name == "field-drift":
        return "time"
    if c.name == "sample-skew":
        return "rotation"
    if c.name == "scale-nonlinearity":
        return "reading"
    return "pose"


def separating_acquisition(a, b) -> str:
    """What acquisition would tell candidates a and b apart."""
    da, db = _driver(a), _driver(b)
    pair = {da, db}
    if pair == {"time", "pose"}:
        return ("randomise the pose order (or read the first poses again at the end of the run), so that time and "
                "pose stop rising together")
    if pair == {"temperature", "time"}:
        return "cycle the temperature up and down (or hold it while time passes), so that it stops rising with time"
    if pair == {"temperature", "pose"}:
        return "visit the poses in a fresh random order at each temperature"
    if "rotation" in pair:
        return "rotate both ways and at two rates"
    if pair == {"reading", "pose"}:
        return ("add poses at which each axis reads between its extremes (tilts between the faces), and turn the "
                "probe in its clamp so that a reading is not tied to one rig position")
    if a.name == "rig-field" or b.name == "rig-field":
        return ("turn the probe in its clamp (the same rig position at another toolface) or turn the axis the "
                "rig field follows through a full turn at several settings of the others")
    if pair == {"temperature"}:
        return "a wider temperature range, with poses that load each axis at every temperature"
    if pair == {"time"}:
        return "a longer run, or the field measured by a reference magnetometer beside the bench"
    return "more poses, spread over every axis of the turntable"


def _confounds(m: _Model, kept, contradicted, alpha=core.DEFAULT_ALPHA):
    """For each named (and each contradicted) effect, the other candidates
    the run cannot tell from it: how much of its fitted signature another
    candidate's columns reproduce (the multiple correlation, whitened, once
    the baseline and the other kept effects are projected out), from
    CONFOUND_CORR up, with the acquisition that would separate them.

    A rig field has 12-15 columns: one correlation of its fitted signature
    says little of whether another axis' field would do as well (on the
    bench's oven plan an azimuth-axis field is reproduced 0.85-0.9 by a
    toolface-axis field, and at z = 9-12 the wrong one was kept in ~1 % of
    draws, silently).  Where either side is a rig field, the other is also
    reported when it explains the signal on its own and the named one adds
    nothing beside it that the selection would keep (F-tests at the forward
    selection's Bonferroni threshold, alpha over the candidates): the run
    cannot tell them apart."""
    by_key = {c.key: c for c in m.testable}
    out = []
    est = {c["effect"]: c["estimate"] for c in contradicted if c["effect"] in by_key}
    for k, full in m.dropped_rig.items():  # a dropped rig field in its axis' basis as it is now
        if k in est:
            est[k] = np.linalg.lstsq(m.d.rig_basis[k.split(":")[2]], full, rcond=None)[0]
    est.update({k: m.state["theta"][k] for k in kept})
    for k, th in est.items():
        if th is None:
            continue
        others_kept = [x for x in kept if x != k]
        for c in m.testable:
            j = c.key
            if j == k:
                continue
            base = m.base + m.cols([x for x in others_kept if x != j])
            r = m.des.signal_corr(base, m.idx[k], np.atleast_1d(th), m.idx[j])
            multi = len(m.idx[k]) > 1 or len(m.idx[j]) > 1
            if r < CONFOUND_CORR and multi and r > 0.5:
                bonf = alpha / len(m.testable)  # the forward selection's threshold
                if m.des.ftest(base, m.idx[j])[0] < bonf and m.des.ftest(base + m.idx[j], m.idx[k])[0] >= bonf:
                    out.append({"effect": k, "with": j, "correlation": r, "named": k in kept,
                                "separate_by": separating_acquisition(by_key[k], c)})
                continue
            if r >= CONFOUND_CORR:
                out.append({"effect": k, "with": j, "correlation": r, "named": k in kept,
                            "separate_by": separating_acquisition(by_key[k], c)})
    return out


_RUN_DRIVER = {"time": "time", "reading order": "time", "temperature": "temperature",
               **{v: k for k, v in AXIS_VARIABLES.items()}}


def _run_driver(c) -> str | None:
    """The run variable a candidate is a function of: time (a drift),
    temperature, or the angle of one turntable axis (a rig field)."""
    if c.name == "rig-field":
        return c.axis
    d = _driver(c)
    return d if d in ("time", "temperature") else None


def _run_variable_rivals(m: _Model, kept, effects_out, run_conf, alpha, confounds) -> list:
    """Each named effect whose driver (time, temperature, a turntable axis's
    angle) goes with another of the run's variables (run_variable_confounds:
    time rising with the inclination axis when the poses are taken in
    order) set beside the candidates driven by that other variable, one at
    a time in its place: the cross-validated residual (whitened, all
    channels) with the named effect and with the rival instead, and the
    F-test of each beside the other at the forward selection's threshold.
    Recorded in the effect's detail ("run_confounds"); the pairs the run
    cannot tell apart (the named effect adds nothing the selection would
    keep beside the rival, or the rival does as well on held-out data) are
    returned as confounds, with the acquisition that would separate them."""
    by_key = {c.key: c for c in m.testable}
    des = m.des
    bonf = alpha / max(len(m.testable), 1)
    known = {(c["effect"], c["with"]) for c in confounds}
    out = []
    for e, k in zip(effects_out, kept):
        dk = _run_driver(by_key[k])
        if dk is None:
            continue
        others = m.base + m.cols([x for x in kept if x != k])
        cv_none = cv_named = None
        rows = []
        for rv in run_conf:
            a, b = _RUN_DRIVER.get(rv["a"]), _RUN_DRIVER.get(rv["b"])
            if dk not in (a, b) or a == b:
                continue
            other, var = (b, rv["b"]) if a == dk else (a, rv["a"])
            rivals = [c for c in m.testable if c.key not in kept and _run_driver(c) == other]
            if not rivals:
                continue
            if cv_none is None:
                cv_none, cv_named = des.cv(others), des.cv(others + m.idx[k])
            cvs = [des.cv(others + m.idx[c.key]) for c in rivals]
            best, cv_rival = rivals[int(np.argmin(cvs))], min(cvs)
            p_named = des.ftest(others + m.idx[best.key], m.idx[k])[0]
            p_rival = des.ftest(others + m.idx[k], m.idx[best.key])[0]
            # a pair the signatures' correlation already reports (_confounds) is not told apart, whatever the F-test
            apart = bool(p_named < bonf and cv_named < cv_rival) and (k, best.key) not in known
            row = {"variable": var, "correlation": float(rv["correlation"]), "rival": best.key,
                   "cv_without_either": cv_none, "cv_with_effect": cv_named, "cv_with_rival_instead": cv_rival,
                   "p_effect_beside_rival": p_named, "p_rival_beside_effect": p_rival, "told_apart": apart,
                   "separate_by": separating_acquisition(by_key[k], best)}
            rows.append(row)
            if not apart and (k, best.key) not in known:
                known.add((k, best.key))
                out.append({"effect": k, "with": best.key, "correlation": float(abs(rv["correlation"])),
                            "named": True, "via": var, "separate_by": row["separate_by"]})
        if rows:
            e.detail["run_confounds"] = rows
    return out


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
    checks, contradicted = _cross_check(m, kept, pvals, steps, alpha, _Attitude(m.bl, ~m.out_rows))
    des, d, bl, base, noise, noise_base = m.des, m.d, m.bl, m.base, m.noise, m.noise_base
    out_rows = m.out_rows
    att = _Attitude(bl, ~out_rows)
    S = base + m.cols(kept)
    est, se, s2 = des.coef(S)
    cov = des.coef_cov(S)
    serial_f = dict(zip(kept, serial.scale_cov(des, S, cov, [m.idx[k] for k in kept])))
    best_subset = _best_subset(des, base, kept, testable, m.idx, alpha, m.fold_of)
    J = bl.Jpose
    ok = ~out_rows

    R_final = des.raw_residuals(S)
    R_base = des.raw_residuals(base)
    Rs_base, Rs_base_cv = noise_base.sensor_part(R_base, J), noise_base.sensor_part(des.cv_residuals(base), J)

    effects_out, plot_effects = _kept_effects(m, kept, pvals, est, cov, S, checks, keep_plot_data)
    for e, k in zip(effects_out, kept):
        e.detail["serial_inflation"] = serial_f[k]
    confounds = _confounds(m, kept, contradicted, alpha)
    by_key = {c.key: c for c in testable}
    notes = []
    for cf in confounds:
        a, b = by_key[cf["effect"]], by_key[cf["with"]]
        notes.append(f"{_label(a)} and {_label(b)} are confounded in this run (correlation {cf['correlation']:.3f}): "
                     f"the data cannot tell them apart; {cf['separate_by']}")
    run_conf = run_variable_confounds(d)
    confounds += _run_variable_rivals(m, kept, effects_out, run_conf, alpha, confounds)

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
            "best_subset": best_subset,
            "checks": ("a kept effect is named only when its own channels' held-out residual (net of the turntable's "
                       "readout error on the turntable axes it does not act as: for a declination drift net of the "
                       "inclination and toolface readout errors; for a turntable effect the whole residual of both "
                       "triads, each channel in its noise SD) falls and it does not make the pose-free invariants "
                       "(|g|, |b|, dip of the readings it corrects) worse; one that fails is reported under "
                       "'contradicted', not as a cause")},
        "structure": verdict,
        "run_variables": run_conf,
        "serial_correlation": dict(serial.summary(des, S), channels=list(CHANNELS),
                                   inflation_by_effect=serial_f),
        "heavy_tails": tails.summary(des, S),
    }
    out = Diagnosis(baseline=baseline, effects=effects_out, unexplained=verdict["unexplained"], structure=verdict,
                    contradicted=contradicted, confounded=confounds)
    if keep_plot_data:
        out.plot_data = {"effects": plot_effects, "baseline": _baseline_plot(d, bl, base_study, Rs_base)}
    return out


def _label(c) -> str:
    return f"{c.name} ({c.sensor} {c.axis})"


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
    S = base + [i for k in kept for i in idx[k]]
    single = [k for k in kept if len(idx[k]) == 1]  # the rig field (several columns) is not a pool term
    rest = sorted((des.ftest(S, idx[c.key])[0], c.key) for c in testable if c.key not in kept and len(idx[c.key]) == 1)
    pool_keys = single + [k for p, k in rest if p < alpha][:max(0, BEST_SUBSET_POOL - len(single))]
    if not pool_keys:
        return None
    base = base + [i for k in kept if len(idx[k]) > 1 for i in idx[k]]  # a kept rig field stays in the model
    cols = list(base) + [idx[k][0] for k in pool_keys]  # only these columns are whitened, of the rows fitted
    Xw = des.whitened(cols, des.rows).reshape(-1, len(cols))
    yw = des.yw[des.rows].reshape(-1)
    B = Xw[:, :len(base)]
    C = Xw[:, len(base):]
    coef = np.linalg.lstsq(B, np.column_stack([C, yw]), rcond=None)[0]
    R = np.column_stack([C, yw]) - B @ coef
    groups = np.repeat(fold_of[des.rows], 6)
    pb = selection.Problem(R[:, :-1], R[:, -1], np.ones(len(yw)), pool_keys, groups)
    s = selection.select(pb, max_terms=BEST_SUBSET_POOL, cv="group")
    d = s.to_dict()
    return {"method": "best subset of the pool (kept effects and the other candidates with p < alpha), scored by "
                      "the K-fold held-out residual (whitened, baseline projected out), nested K-fold for the "
                      "procedure, drop-from-pool test per kept effect (selection.py)",
            "pool": d["pool"], "chosen": d["chosen"], "agrees_with_the_stepwise_choice": set(d["chosen"]) == set(single),
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
