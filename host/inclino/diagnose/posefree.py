"""Diagnosis without poses: what the invariants show.

Without the turntable's poses (a field recalibration, a hand-tumbled log, a
bench whose poses are not trusted) each row still has what holds at any
orientation: |g| = G, |b| = F and, with both triads, the angle between them
= the dip.  The baseline is the pose-free calibration -- per triad a
symmetric 3x3 and an offset (the accelerometer's axes are the body frame),
the fluxgate's full 3x3 when the dip ties it to the accelerometer, and the
dip -- fitted to those invariants by Gauss-Newton.  Candidates are the
library effects an invariant can see, in the same parameters as the
pose-based diagnosis (inclino.model.effects):

* scale-nonlinearity per axis (raw = v + k2 v^2 + b),
* temperature-bias and temperature-scale per axis (with a temp_c column
  that changes),
* field-drift of the total and of the dip (with time, or the reading order),
* rig-field per rig axis angle in the file (inc_deg, azi_deg, tf_deg
  columns that turn): the |b| and dip invariants as harmonics 1-2 of the
  angle -- a field that changes with the rig's position (its direction
  across the field, which no invariant sees, needs the poses).

The selection is the pose-based one (core.Design: forward stepwise, F-test
at alpha/m, cross-validation that must fall overall and on the effect's
own invariants, backward pass; each candidate tested, and its own
invariants pooled, with every invariant weighed by its noise with that
candidate in the model).  Independent shots are held out one pose at a
time; a serially correlated log is held out in K blocks, its held-out gain
needed in all blocks but one, and a driven candidate must also beat what
the log's slow structure gives any such driver: time or a rig angle its
own values shifted in time (a circular-shift test), a temperature the
same effect driven by generic slow profiles in reading order at the
temperature's own timescale (_slow_rival: a line against its continuum;
where it cannot, the candidate is listed as confounded with that slow
structure, not named).  All on cluster means where several
rows share a pose (calib.covariance.cluster_labels): hundreds of readings
at one face are one observation of that face, not hundreds.  What needs
the poses is listed as such: the turntable's own errors, a declination
drift, the sampling skew, the absolute orientation of either triad.
"""
from __future__ import annotations

import time as _time

import numpy as np
from scipy import stats

from inclino.errors import DataError
from inclino.formats.dataset import ID_COLUMNS, RawDataset
from inclino.holds import declared_static
from inclino.calib.thermal import DIAGNOSE_MIN_SPAN_C, diagnose_tests

from . import serial as bartlett
from .core import DEFAULT_ALPHA, DEFAULT_FOLDS, Design, make_folds
from .result import Diagnosis, Effect, Gain

INV = ("|g|", "|b|", "dip")
UNITS = {"|g|": "g", "|b|": "nT", "dip": "deg"}
MIN_CLUSTERS = 12
RIG_MIN_SPAN_DEG = 30.0
GN_ITERATIONS = 4
OUTLIER_P = 1e-3
LOO_MAX_CLUSTERS = 200  # independent shots up to this many poses are held out one at a time (beyond: K blocks)

NEEDS_POSES = [
    ("turntable-inclination-offset", "an offset of the turntable's inclination scale shows only against the poses"),
    ("turntable-azimuth-offset", "the turntable's north reference (a declination offset) is a rotation no invariant "
                                 "sees"),
    ("turntable-azimuth-axis-tilt", "the turntable's own geometry shows only against the poses"),
    ("turntable-inclination-axis-skew", "the turntable's own geometry shows only against the poses"),
    ("field-drift (declination)", "a declination drift turns the field about the vertical: |b| and the dip stay"),
    ("sample-skew", "the fluxgate's sampling skew needs the rotation rate, i.e. poses with time"),
    ("rig-field (its direction)", "the part of a rig field across the Earth field changes no invariant: with the "
                                  "poses its full vector is fitted"),
    ("misalignment", "the rotation of the sensor block against the probe's axes: no invariant sees it"),
]

NEEDS_MAG = {"turntable-azimuth-offset", "field-drift (declination)", "sample-skew", "rig-field (its direction)"}


class _PF:
    """The data reduced to clusters, and the invariant model."""

    def __init__(self, ds: RawDataset, holds_of: RawDataset | None = None):
        """holds_of: the log whose static holds are used (default ds; the
        same rows read with an effect injected, for sizing it on the holds
        the diagnosis of the injected log reads: signature_z)."""
        from inclino import holds as _holds
        from inclino.calib.common import world_of
        from inclino.calib.covariance import cluster_labels

        self.has_acc, self.has_mag = ds.has_acc, ds.has_mag
        n0 = len(ds)
        lab = cluster_labels(ds)
        settings = np.zeros(n0, bool) if _holds.labelled(ds) else _holds.setting_changes(ds)
        if settings.any():  # partial poses (a face label, a rig axis's setting): consecutive rows at one of them
            lab = np.cumsum(settings)
        # no pose, no pose id: the readings' own static holds (inclino.holds) are the poses of a step-and-hold
        # log when they determine the model; the rows read while moving between them are then left out.  Holds
        # in too few directions (a six-face session) leave every row a pose of its own; with an accelerometer,
        # every effect named is then confounded with the motion (its acceleration is in |g| and the dip).  A
        # magnetometer alone reads the field whether it turns or not (a delay common to its axes keeps |b|):
        # its rows read while turning are readings like the held ones, and a hand that pauses at a few
        # orientations (BROAD's trial 05: 109 holds, most with z down) does not make them suspect
        self.holds = None
        self.hold_labels = None  # (n,) each row's hold, -1 moving, of a step-and-hold log (inclino.holds.find)
        sel = np.ones(n0, bool)
        if not _holds.labelled(ds):
            H = _holds.find(ds if holds_of is None else holds_of)
            if H.step_and_hold:
                hl = H.labels
                lev = _holds.leverage(ds, H)
                only = H.count >= MIN_CLUSTERS and lev <= _holds.HOLDS_MAX_LEVERAGE
                if only:
                    sel = hl >= 0
                    lab = hl[sel]
                elif H.rows_moving:
                    # a setting's rows are not one orientation when the sensor turns during them: every row a pose
                    lab = np.arange(n0)
                self.holds = dict(H.to_dict(), moving_rows_left_out=bool(only), leverage_max=lev)
                self.hold_labels = hl
        k = int(lab.max()) + 1
        self.n_rows, self.k = n0, k
        cnt = np.bincount(lab, minlength=k).astype(float)
        self.count = cnt

        def mean(x):
            out = np.zeros((k,) + np.shape(x)[1:])
            np.add.at(out, lab, np.asarray(x, float)[sel])
            return out / cnt.reshape((-1,) + (1,) * (np.ndim(x) - 1))
        self.acc = mean(ds.acc) if self.has_acc else None
        self.mag = mean(ds.mag) if self.has_mag else None

        self.own_var = {}
        for tri, ok in (("acc", self.has_acc), ("mag", self.has_mag)):
            if ok:
                x = np.asarray(getattr(ds, tri), float)[sel]
                d = x - getattr(self, tri)[lab]
                ss = np.zeros((k, 3))
                np.add.at(ss, lab, d * d)
                self.own_var[tri] = ss / np.maximum(cnt - 1.0, 1.0)[:, None] / cnt[:, None]
        t = ds.columns.get("t_s")
        self.time_name = "time" if t is not None and np.ptp(t) > 0 else "reading order"
        self.t = mean(t) if t is not None and np.ptp(t) > 0 else mean(np.arange(n0, dtype=float))
        temp = ds.columns.get("temp_c")
        self.temp = mean(temp) if diagnose_tests(temp) else None
        self.angles = {}
        for c, name in (("inc_deg", "inc"), ("azi_deg", "azi"), ("tf_deg", "tf")):
            if c in ds.columns:
                r = np.unwrap(np.radians(np.asarray(ds.columns[c], float)))
                if np.degrees(np.ptp(r)) >= RIG_MIN_SPAN_DEG:
                    self.angles[name] = np.degrees(np.arctan2(mean(np.sin(r)), mean(np.cos(r))))
        m = ds.meta
        self.G = float(m.get("gravity_g", 1.0))
        F = m.get("field_nT")
        # without the header's field: the radius of the sphere the raw readings lie on, as calibrate takes it
        # (calib.common.world_of); the median |b| holds the hard-iron offset too (a VMU931 log: median 176 871 nT
        # about a sphere of 36 549 nT, every |b| residual 4.8 times too large)
        self.F = float(F) if F is not None else (world_of(ds)["field_nT"] if self.has_mag else 50000.0)
        self.F_given = F is not None
        self.dip0 = m.get("dip_deg")
        self.chans = [x for x, ok in (("|g|", self.has_acc), ("|b|", self.has_mag),
                                      ("dip", self.has_acc and self.has_mag)) if ok]
        if k < MIN_CLUSTERS:
            raise DataError(f"too few distinct orientations for a pose-free diagnosis: {k} (needs {MIN_CLUSTERS}; "
                            f"rows at one pose count once)")

    # ---- parameters: the baseline's, then each candidate's
    def base_params(self) -> list:
        out = []
        if self.has_acc:
            out += [("acc", "M", i) for i in range(6)] + [("acc", "b", i) for i in range(3)]
        if self.has_mag:
            out += [("mag", "M", i) for i in range(9 if self.has_acc else 6)] + [("mag", "b", i) for i in range(3)]
        if "dip" in self.chans:
            out.append(("dip",))
        return out


def _sym(v):
    return np.array([[v[0], v[3], v[4]], [v[3], v[1], v[5]], [v[4], v[5], v[2]]])


def _ellipsoid_start(raw, target):
    """A sphere of radius `target` through the readings: algebraic fit of
    x^T Q x + 2 p^T x = 1, then M = chol-like square root (symmetric)."""
    x = np.asarray(raw, float)
    s = np.abs(x).max()
    xs = x / s
    D = np.column_stack([xs[:, 0] ** 2, xs[:, 1] ** 2, xs[:, 2] ** 2, 2 * xs[:, 0] * xs[:, 1],
                         2 * xs[:, 0] * xs[:, 2], 2 * xs[:, 1] * xs[:, 2], 2 * xs])
    sol = np.linalg.lstsq(D, np.ones(len(xs)), rcond=None)[0]
    Q = _sym(sol[[0, 1, 2, 3, 4, 5]])
    p = sol[6:]
    try:
        c = -np.linalg.solve(Q, p)
        k = 1.0 + c @ Q @ c
        w, V = np.linalg.eigh(Q / k)
        if np.any(w <= 0):
            raise np.linalg.LinAlgError
        M = (V * np.sqrt(w)) @ V.T * target / s
        return M, c * s
    except np.linalg.LinAlgError:
        return np.eye(3) * target / np.median(np.linalg.norm(x - x.mean(0), axis=1)), x.mean(0)


class _Model:
    def __init__(self, pf: _PF):
        self.pf = pf
        self.base = pf.base_params()
        self.cands = self._candidates()
        self.theta = {}  # candidate key -> value(s)
        self.x = self._start()

    def _candidates(self) -> list:
        pf = self.pf
        out = []
        for tri, ok in (("acc", pf.has_acc), ("mag", pf.has_mag)):
            if not ok:
                continue
            u = "g" if tri == "acc" else "nT"
            for ax in "xyz":
                out.append(("scale-nonlinearity", tri, ax, f"1/{u}", 1))
            if pf.temp is not None:
                for ax in "xyz":
                    out.append(("temperature-bias", tri, ax, f"{u}/degC", 1))
                for ax in "xyz":
                    out.append(("temperature-scale", tri, ax, "ppm/degC", 1))
        per = "s" if pf.time_name == "time" else "reading"
        if pf.has_mag:
            out.append(("field-drift", "field", "total", f"nT/{per}", 1))
        if "dip" in pf.chans:
            out.append(("field-drift", "field", "dip", f"deg/{per}", 1))
        if pf.has_mag:
            for ax in pf.angles:
                out.append(("rig-field", "rig", ax, "nT", 4 * len([c for c in pf.chans if c in ("|b|", "dip")])))
        return [c for c in out]

    def _start(self) -> dict:
        pf = self.pf
        x = {}
        if pf.has_acc:
            M, b = _ellipsoid_start(pf.acc, pf.G)
            x["acc"] = (M, b)
        if pf.has_mag:
            M, b = _ellipsoid_start(pf.mag, pf.F)
            x["mag"] = (M, b)
        if "dip" in pf.chans:
            g, bb = self.corrected(x, {})
            x["mag"] = (_turn_start(g, bb) @ x["mag"][0], x["mag"][1])
            g, bb = self.corrected(x, {})
            x["dip"] = float(np.median(self._dip(g, bb)))
        return x

    @staticmethod
    def _dip(g, b):
        c = np.einsum("ni,ni->n", g, b) / (np.linalg.norm(g, axis=1) * np.linalg.norm(b, axis=1))
        return np.degrees(np.arcsin(np.clip(c, -1, 1)))

    def corrected(self, x, theta):
        return self._triad("acc", x, theta), self._triad("mag", x, theta)

    def _triad(self, tri, x, theta):
        """One triad's corrected readings (None without the triad)."""
        pf = self.pf
        raw = pf.acc if tri == "acc" else pf.mag
        if raw is None:
            return None
        M, b = x[tri]
        z = raw - b
        if pf.temp is not None:
            dT = (pf.temp - pf.temp.mean())[:, None]
            cT = np.array([theta.get(f"temperature-bias:{tri}:{a}", 0.0) for a in "xyz"])
            ppm = np.array([theta.get(f"temperature-scale:{tri}:{a}", 0.0) for a in "xyz"])
            z = (z - cT * dT) / (1.0 + 1e-6 * ppm * dT)
        # the cubic rival (CUBIC_RIVAL, no library effect): raw = v + k3 v^3, inverted to first order
        z = z - np.array([theta.get(f"{CUBIC_RIVAL}:{tri}:{a}", 0.0) for a in "xyz"]) * z ** 3
        k2 = np.array([theta.get(f"scale-nonlinearity:{tri}:{a}", 0.0) for a in "xyz"])
        v = 2.0 * z / (1.0 + np.sqrt(np.maximum(1.0 + 4.0 * k2 * z, 1e-12)))
        return v @ M.T

    def residuals(self, x, theta, gb=None) -> np.ndarray:
        """(k, channels): the invariants' residuals (g, nT, deg); gb: the
        corrected readings (g, b) at (x, theta) when already computed."""
        pf = self.pf
        g, b = self.corrected(x, theta) if gb is None else gb
        tau = pf.t - pf.t.mean()
        cols = []
        for ch in pf.chans:
            if ch == "|g|":
                cols.append(np.linalg.norm(g, axis=1) - pf.G)
            elif ch == "|b|":
                F = pf.F + theta.get("field-drift:field:total", 0.0) * tau
                r = np.linalg.norm(b, axis=1) - F
                cols.append(r - self._rig(theta, "|b|"))
            else:
                d = x["dip"] + theta.get("field-drift:field:dip", 0.0) * tau
                cols.append(self._dip(g, b) - d - self._rig(theta, "dip"))
        return np.column_stack(cols)

    def _rig_cols(self, ax):
        ph = np.radians(self.pf.angles[ax])
        return np.column_stack([np.cos(ph), np.sin(ph), np.cos(2 * ph), np.sin(2 * ph)])

    def _rig(self, theta, ch):
        out = 0.0
        chans = [c for c in self.pf.chans if c in ("|b|", "dip")]
        for ax in self.pf.angles:
            v = theta.get(f"rig-field:rig:{ax}")
            if v is None:
                continue
            j = chans.index(ch)
            out = out + self._rig_cols(ax) @ np.asarray(v)[4 * j:4 * j + 4]
        return out

    def cand_columns(self, v, theta, key, n) -> np.ndarray:
        """(k, m, n): the residuals' change per unit of each entry of the
        candidate, central differences at (v, theta)."""
        x = self.unpack(v)
        cur = np.atleast_1d(np.asarray(theta.get(key, np.zeros(n)), float))
        h = _step(self, key)
        cols = []
        for e in range(n):
            tp, tm = dict(theta), dict(theta)
            a, b = cur.copy(), cur.copy()
            a[e] += h
            b[e] -= h
            tp[key] = a if n > 1 else float(a[0])
            tm[key] = b if n > 1 else float(b[0])
            cols.append((self.residuals(x, tp) - self.residuals(x, tm)) / (2 * h))
        return np.stack(cols, -1)

    # ---- the parameters as one vector
    def pack(self, x):
        out = []
        for tri in ("acc", "mag"):
            if tri not in x:
                continue
            M, b = x[tri]
            if tri == "mag" and self.pf.has_acc:
                out += list(M.ravel())
            else:
                out += [M[0, 0], M[1, 1], M[2, 2], M[0, 1], M[0, 2], M[1, 2]]
            out += list(b)
        if "dip" in x:
            out.append(x["dip"])
        return np.array(out)

    def unpack(self, v):
        x, i = {}, 0
        for tri, ok in (("acc", self.pf.has_acc), ("mag", self.pf.has_mag)):
            if not ok:
                continue
            if tri == "mag" and self.pf.has_acc:
                M = v[i:i + 9].reshape(3, 3)
                i += 9
            else:
                M = _sym(v[i:i + 6])
                i += 6
            x[tri] = (M, v[i:i + 3].copy())
            i += 3
        if "dip" in self.pf.chans:
            x["dip"] = float(v[i])
        return x

    def jacobian(self, v, theta, keys) -> tuple:
        """(residual (k, m), columns (k, m, p)): the baseline's parameters,
        then each candidate of keys (one column per entry)."""
        x = self.unpack(v)
        g0, b0 = self.corrected(x, theta)
        r0 = self.residuals(x, theta, (g0, b0))
        cols = []
        scale = np.maximum(np.abs(v), 1e-6)
        # a baseline parameter moves one triad's corrected readings (the dip: neither); the other's are the
        # ones at v, the same numbers a recomputation would give
        owner = [p[0] for p in self.pf.base_params()]
        for j in range(len(v)):
            h = 1e-6 * scale[j]
            vp, vm = v.copy(), v.copy()
            vp[j] += h
            vm[j] -= h
            xp, xm = self.unpack(vp), self.unpack(vm)
            if owner[j] == "acc":
                gbp, gbm = (self._triad("acc", xp, theta), b0), (self._triad("acc", xm, theta), b0)
            elif owner[j] == "mag":
                gbp, gbm = (g0, self._triad("mag", xp, theta)), (g0, self._triad("mag", xm, theta))
            else:
                gbp = gbm = (g0, b0)
            cols.append((self.residuals(xp, theta, gbp) - self.residuals(xm, theta, gbm)) / (2 * h))
        for key, n in keys:
            cur = np.atleast_1d(np.asarray(theta.get(key, np.zeros(n)), float))
            for e in range(n):
                h = _step(self, key)
                tp, tm = dict(theta), dict(theta)
                a, b = cur.copy(), cur.copy()
                a[e] += h
                b[e] -= h
                tp[key] = a if n > 1 else float(a[0])
                tm[key] = b if n > 1 else float(b[0])
                cols.append((self.residuals(x, tp) - self.residuals(x, tm)) / (2 * h))
        return r0, np.stack(cols, -1)


def _step(model, key):
    name, tri, _ = key.split(":")
    F = model.pf.F
    if name == "scale-nonlinearity":
        return 1e-4 if tri == "acc" else 1e-4 / F
    if name == CUBIC_RIVAL:
        return 1e-4 if tri == "acc" else 1e-4 / F ** 2
    if name == "temperature-bias":
        return 1e-5 if tri == "acc" else 0.1
    if name == "temperature-scale":
        return 1.0
    if name == "field-drift":
        return 1e-3
    return 1.0


def signature_z(ds: RawDataset, key: str, w=None, folds: int = DEFAULT_FOLDS,
                holds_of: RawDataset | None = None) -> float:
    """How many noise standard deviations one unit of candidate `key` (for
    a group, the combination w of its columns) is in this dataset's
    invariants, once the baseline has absorbed what it can: the pose-free
    counterpart of plans.signature_z, under the data's own noise and serial
    correlation (what the F-test sees).  On a log whose effects are named
    only where its holds confirm them (holds_view), in that view.  holds_of: the same rows with the
    effect in them, whose static holds (inclino.holds.find) are the ones
    used: an effect can change which rows read as held (a temperature bias
    that drifts a long hold's reading past the 0.5 deg turn cuts it in
    several).  For injecting effects into real readings at the benchmark's
    sizes."""
    return signature_poses(ds, key, w, folds, holds_of)["z"]


def signature_poses(ds: RawDataset, key: str, w=None, folds: int = DEFAULT_FOLDS,
                    holds_of: RawDataset | None = None) -> dict:
    """{"z": signature_z, "top_share": the largest share of its squared
    size one pose holds (what the signature's sum of squares beyond the
    baseline loses when that pose is left out)}.  A signature one pose
    carries most of is what that pose's being an outlier would show, and
    the diagnosis sets such a pose aside (the rows beyond the chi-square
    point of the baseline's residual): an injected temperature bias on
    SAP6 IB's magnetometer z, 80 % of it on one of the 24 shots, put that
    shot 12.5 sigma out, and beside the other 23 it was at p 0.001; the
    MPU-6050 session's z nonlinearity rests on its one long hold read with
    z down."""
    return diagnose_posefree(ds, folds=folds, _signature=(key, w), _holds_of=holds_of)


def diagnose_posefree(ds: RawDataset, alpha: float = DEFAULT_ALPHA, folds: int = DEFAULT_FOLDS,
                      _signature=None, _holds_of=None, keep_plot_data: bool = False) -> Diagnosis:
    """keep_plot_data: keep what `diagnose --plot` draws (Diagnosis.plot_data:
    each invariant's residual against time or the reading order, and each
    named effect's own invariant against its driver, before and after)."""
    t_start = _time.perf_counter()
    if not (0.0 < alpha < 1.0):
        raise DataError("alpha must be between 0 and 1")
    pf = _PF(ds, _holds_of)
    confirm = isinstance(_signature, tuple) and _signature[0] == "confirm"
    if isinstance(_signature, tuple) and not confirm and (view := _holds_view(ds, pf)) is not None:
        # an effect on such a log is named only where its held rows confirm it: its size is the one there
        return diagnose_posefree(view, folds=folds, _signature=_signature)
    mdl = _Model(pf)
    k, chans = pf.k, pf.chans
    K = min(int(folds), k // 4)
    if K < 2:
        raise DataError("too few distinct orientations to cross-validate a pose-free diagnosis")
    fold_of = make_folds(k, K)
    cand_keys = {f"{c[0]}:{c[1]}:{c[2]}": c for c in mdl.cands}
    ncol = {key: c[4] for key, c in cand_keys.items()}
    state = {"v": mdl.pack(mdl.x), "theta": {}}
    nb = len(state["v"])

    def refit(kept):
        keys = [(kk, ncol[kk]) for kk in kept]
        for _ in range(GN_ITERATIONS):
            r, X = mdl.jacobian(state["v"], state["theta"], keys)
            W, rows = _weights(r)
            des = Design(-r, X, W, fold_of, K, rows=rows)
            beta, _ = des.fit(list(range(X.shape[-1])))
            beta = beta / des.colscale

            def stepped(f):
                v = state["v"] + f * beta[:nb]
                th = dict(state["theta"])
                pos = nb
                for kk, n in keys:
                    cur = np.atleast_1d(np.asarray(th.get(kk, np.zeros(n)), float)) + f * beta[pos:pos + n]
                    th[kk] = cur if n > 1 else float(cur[0])
                    pos += n
                return v, th

            # a full Gauss-Newton step unless it raises the weighted cost of the rows it was fitted on (a poor
            # start far from the invariants' minimum): then halved until it does not
            Wd = np.diagonal(W, axis1=1, axis2=2)[rows]
            cost0 = float(np.sum((Wd * r[rows]) ** 2))
            f = 1.0
            for _ in range(12):
                v, th = stepped(f)
                r1 = mdl.residuals(mdl.unpack(v), th)
                if np.all(np.isfinite(r1)) and float(np.sum((Wd * r1[rows]) ** 2)) <= cost0:
                    break
                f /= 2.0
            else:
                break
            state["v"], state["theta"] = v, th

    def design(testable):
        """The model at the state with every testable candidate's columns,
        the pseudo-observation giving kept effects' totals."""
        keys = [(kk, ncol[kk]) for kk in testable]
        r, X = mdl.jacobian(state["v"], state["theta"], keys)
        y = -r
        pos = nb
        idx = {}
        for kk, n in keys:
            idx[kk] = list(range(pos, pos + n))
            if kk in state["theta"]:
                y = y + X[:, :, pos:pos + n] @ np.atleast_1d(state["theta"][kk])
            pos += n
        W, rows = _weights(r)
        des = Design(y, X, W, fold_of, K, rows=rows)
        des._W = W
        des.inflation = serial["inflation"]
        # each test's own Bartlett inflation too (diagnose.serial), in time order: the lag-1 figure above
        # counts the neighbouring rows only, while a smooth candidate gathers the slow part of the error
        des.serial, des.serial_order = True, order_t
        return des, idx, r, rows

    def _weights(r):
        """Per channel the residuals' robust spread; rows beyond the chi-square
        point (Bonferroni) set aside, each against the spread and its own
        noise (_own_noise): a pose is set aside for a residual its own rows
        do not allow, not for being a short stop whose mean its rows leave
        uncertain."""
        s = np.maximum(1.4826 * np.median(np.abs(r - np.median(r, 0)), 0), 1e-12)
        own = _own_noise(mdl, state)
        d2 = (r ** 2 / (s ** 2 + own)).sum(1)
        # the threshold follows the rows' own typical size (as calib.joint.robust_threshold): an effect the
        # model does not hold yet inflates many rows and must not make them outliers; a few spikes do not
        # move the median
        scale_ = max(1.0, float(np.median(d2)) / stats.chi2.ppf(0.5, r.shape[1]))
        rows = d2 <= scale_ * stats.chi2.isf(OUTLIER_P / len(r), r.shape[1])
        if rows.mean() < 0.8:
            rows = np.ones(len(r), bool)
        s = np.maximum(np.sqrt(np.mean(r[rows] ** 2, 0)), 1e-12)
        W = np.zeros((len(r), r.shape[1], r.shape[1]))
        W[:, range(r.shape[1]), range(r.shape[1])] = 1.0 / s
        return W, rows

    serial = {"inflation": 1.0}
    order_t = np.argsort(pf.t, kind="stable")
    refit([])
    testable = list(cand_keys)
    base = list(range(nb))
    des, idx, r_base, rows = design(testable)
    # the noise's own serial correlation between neighbouring rows (in time order), of the baseline's
    # residuals with their slow part (a trend an effect makes) taken off
    rho = max(_lag1(bartlett.highpass(r_base[order_t][rows[order_t]])), _lag1(bartlett.highpass(r_base[rows])))
    serial.update(rho=rho, inflation=(1.0 + rho) / (1.0 - rho))
    des.inflation = serial["inflation"]
    shift_test = serial["rho"] >= SHIFT_TEST_RHO and not declared_static(ds)
    blockwise = serial["rho"] >= SHIFT_TEST_RHO

    def shift_tested(rec) -> bool:
        """Whether a driven candidate also needs the circular-shift test (a
        temperature: the test against slow profiles, _slow_rival), from
        the record of its Bartlett factor (serial.factor): on a log whose
        neighbouring rows correlate, or whose residual, with the candidate in
        the model, still shares its slow part (a hand-turned IMU under a large
        white noise: BROAD's lag-1 is 0.06, its Ljung-Box p 1e-40; the
        candidate in the model, so that an effect the baseline lacks does not
        make its own log look correlated).  Always on the means of static
        holds: their noise is independent from hold to hold, but they are
        read in the order a hand or a rig took them, and what that order
        shares -- neighbouring orientations, a part warming up -- can be
        slower than a few holds' lag, where the Ljung-Box test does not look:
        a driver slow in reading order takes it (on 70 % of QMC5883L's
        1 142 holds a field drift in reading order at p 0.001, its circular
        shifts at p 0.1; a null temperature on 70 % of CK's accelerometer
        holds in 7 of 40 draws at p ~0.001, with lag-1 0.0 and Ljung-Box
        p 0.2)."""
        if declared_static(ds):
            return False
        if shift_test:
            return True
        if pf.holds and pf.holds["moving_rows_left_out"]:
            return True
        return rec["gated"]
    if not blockwise and k <= LOO_MAX_CLUSTERS:
        # independent shots: each pose held out alone (leave-one-pose-out).  K blocks of a 24-shot log leave
        # 19 shots to fit ~30 parameters, a harsher test than the calibration's own use of all 24 (an effect of
        # 8 columns at z = 12 gained on such blocks about half the time); one pose out is the held-out error of
        # a fit on the poses the log has.  Neighbouring rows that share their errors keep the blocks (one
        # held-out row would be predicted by its neighbours)
        K, fold_of = k, np.arange(k)
        des, idx, r_base, rows = design(testable)
        des.inflation = serial["inflation"]
    base_rms = {c: float(np.sqrt(np.mean(r_base[rows, j] ** 2))) for j, c in enumerate(chans)}
    fit_failed = _fit_failed(pf, des, base, rows, r_base, base_rms)
    # the baseline's held-out prediction, of the same fit as base_rms (before any effect is added: with the
    # effects kept it is theirs, the final model's, reported as prediction_with_effects)
    prediction = _prediction(des, base, rows, chans)
    def own_noise(S1):
        """The design weighed by each invariant's noise taken from the model
        S1 (the candidate in it): an effect not yet in the model inflates
        the spread of the invariant it acts on, which would weigh that
        invariant down in its own test (a rig field of z = 12 on |b| of a
        24-shot log came out at p 5e-4-0.01, and was missed)."""
        d0, rows1 = des, des.rows
        R1 = d0.raw_residuals(S1)[rows1]
        # each invariant's unbiased noise: its residuals' sum of squares over its own degrees of freedom (the
        # rows less the leverage the fit puts on that invariant), as the held-out prediction below
        h = d0.leverage(S1)[rows1].sum(0)
        s1 = np.sqrt((R1 ** 2).sum(0) / np.maximum(len(R1) - h, 1.0))
        W1 = np.zeros_like(des._W)
        W1[:, range(len(s1)), range(len(s1))] = 1.0 / np.maximum(s1, 1e-300)
        d1 = Design(des.yraw, des.Xraw, W1, fold_of, K, rows=rows1)
        d1.inflation = des.inflation
        d1.serial, d1.serial_order = des.serial, des.serial_order
        d1.noise = np.maximum(s1, 1e-300)
        return d1

    def ftest_own_noise(S, cols):
        """The F-test of adding cols under own_noise(S + cols)."""
        d1 = own_noise(list(S) + list(cols))
        return d1.ftest(S, cols)[0], d1

    def _confirm(keys):
        """{key: p} of the effects of `keys` on these data, a backward pass
        as the selection's: all refitted together, each tested beside the
        others as the selection tests it (the F-test under the invariants'
        own noise; for a driven effect, the circular-shift or slow-structure
        test where the selection asks for it), the least significant dropped
        while its p is at alpha or above, the rest refitted.  A dropped
        effect keeps the p it was dropped with; a key that is no candidate
        here is left out."""
        nonlocal des, idx, rows
        keys = [kk for kk in keys if kk in idx]
        out = {}
        while keys:
            refit(keys)
            des, idx, _, rows = design(testable)
            ps = {}
            for kk in keys:
                S = base + [i for x in keys if x != kk for i in idx[x]]
                p, d1 = ftest_own_noise(S, idx[kk])
                if kk.split(":")[0] in DRIVEN and shift_tested(d1.serial_record(S, idx[kk])):
                    if kk.split(":")[0] in SLOW_DRIVERS:
                        p = max(p, _slow_rival(mdl, state, des, S, kk, ncol[kk], order_t)["p"])
                    else:
                        p = max(p, _shift_p(mdl, state, des, S, kk, ncol[kk], alpha))
                ps[kk] = float(p)
            out.update(ps)
            worst = max(keys, key=lambda kk: ps[kk])
            if ps[worst] < alpha:
                break
            keys.remove(worst)
            state["theta"].pop(worst, None)
        return out

    if confirm:
        return _confirm(_signature[1])
    if _signature is not None and _signature != "debug":
        key, w = _signature
        if key not in idx:
            raise DataError(f"{key} is not a candidate on these data")
        cols = idx[key]
        # under the noise the F-test weighs the invariants by (own_noise: each invariant's residual spread with
        # the candidate in the model), so that a size is in the test's own units where a log has several
        # invariants
        d1 = own_noise(base + list(cols))
        ws = (np.ones(len(cols)) if w is None else np.asarray(w, float)) * d1.colscale[cols]
        z2, loss = _signature_per_pose(d1, base, cols, ws)
        sf = bartlett.factor(d1, base, cols, ws)
        infl = max(d1.inflation, sf["f"])
        if key.split(":")[0] in DRIVEN and shift_tested(sf):
            # what the test deflates this driver's F by on these data: its circular-shift null (a log with
            # slow structure in its residuals, as a tumbled one, gives any smooth driver a large F by chance:
            # a null temperature cycled 2.5 times reaches F ~ 70-80 on CK's log, where the lag-1 correlation
            # alone says 6)
            if key.split(":")[0] in SLOW_DRIVERS:
                # a temperature: the level of the slow structure at its timescale (_slow_rival)
                infl = max(infl, _slow_rival(mdl, state, des, base, key, len(cols), order_t)["inflation"])
            else:
                infl = max(infl, _shift_p(mdl, state, des, base, key, len(cols), None))
        return {"z": float(np.sqrt(max(z2, 0.0) / infl)),
                "top_share": float(np.max(loss, initial=0.0) / max(z2, 1e-300))}
    def _beside_cubic(kk) -> dict:
        """The temperature term kk of the model `kept` tested beside a cubic
        nonlinearity of its own axis (CUBIC_RIVAL, fitted with it): {"p_beside"
        (the temperature term's F-test with the cubic in the model),
        "p_cubic_beside" (the cubic's with the temperature term in it),
        "cubic_takes_it" (that p below alpha),
        "correlation" (the term's fitted signature with the cubic's, beyond
        the others), "gain_share" (of the term's gain the cubic keeps in its
        place, _swap_share)}."""
        _, tri, ax = kk.split(":")
        rv = f"{CUBIC_RIVAL}:{tri}:{ax}"
        ncol[rv] = 1
        d2, idx2, _, _ = design(testable + [rv])
        others = base + [i for x in kept if x != kk for i in idx2[x]]
        p_cubic = float(d2.ftest(others + idx2[kk], idx2[rv])[0])
        return {"p_beside": float(d2.ftest(others + idx2[rv], idx2[kk])[0]), "p_cubic_beside": p_cubic,
                "cubic_takes_it": p_cubic < alpha,
                "correlation": d2.signal_corr(others, idx2[kk], np.atleast_1d(state["theta"].get(kk, 1.0)),
                                              idx2[rv]),
                "gain_share": _swap_share(d2, others, idx2[kk], idx2[rv])}

    own = {kk: _own_chan(kk, chans) for kk in testable}
    kept, steps, pvals = [], [], {}
    cubic_checks = {}
    slow_confounds = {}
    remaining = list(testable)
    if _signature == "debug":
        return {kk: des.ftest(base, idx[kk]) for kk in testable}
    while remaining:
        S = base + [i for kk in kept for i in idx[kk]]
        tests = sorted(((*ftest_own_noise(S, idx[kk]), kk) for kk in remaining), key=lambda t: (t[0], t[2]))
        chosen = None
        for p, d1, kk in tests:
            if p >= alpha / len(remaining):
                break
            # held out under the same noise as the test: each invariant weighed by its noise with the
            # candidate in the model
            S1 = S + idx[kk]
            cv0, cv1 = d1.cv(S), d1.cv(S1)
            # the own invariants pooled each in units of its noise with the candidate in the model (as the
            # test): in units of the baseline's spread, an invariant the effect inflated counts for little
            # beside one it does not touch (a rig field on |b| alone: its 4 dip columns' fitted noise
            # outweighed the gain on |b|)
            o0, o1 = _own_cv(d1, S, own[kk], d1.rows, d1.noise), _own_cv(d1, S1, own[kk], d1.rows, d1.noise)
            if blockwise:
                f0 = _own_cv(d1, S, own[kk], d1.rows, d1.noise, fold_of)
                f1 = _own_cv(d1, S1, own[kk], d1.rows, d1.noise, fold_of)
                better = int(np.sum(f1 < f0))
            else:
                better = K
            if (kk.split(":")[0] in DRIVEN and cv1 < cv0 and o1 < o0 and better >= K - 1
                    and shift_tested(d1.serial_record(S, idx[kk]))):
                # a temperature is set against the same effect with generic slow profiles at its timescale
                # (_slow_rival); time itself and a rig angle against their own circular shifts (_shift_p): a
                # temperature cycled 2.5 times, rolled, is about the same sinusoid again, and the shifts far
                # enough from it are its quadrature phase only, where an effect's own leakage counts as null
                if kk.split(":")[0] not in SLOW_DRIVERS:
                    ps = _shift_p(mdl, state, des, S, kk, ncol[kk], alpha / len(remaining))
                    if ps >= alpha / len(remaining):
                        steps.append({"effect": kk, "p": p, "p_circular_shift": ps, "kept": False,
                                      "why": "its driver shifted in time explains the data as well (circular-shift "
                                             "test: the log's rows are serially correlated)"})
                        continue
                elif (rv := _slow_rival(mdl, state, des, S, kk, ncol[kk], order_t))["p"] >= alpha / len(remaining):
                    steps.append({"effect": kk, "p": p, "slow_structure": rv, "kept": False,
                                  "why": f"the same effect with a generic slow profile in {pf.time_name} (1-"
                                         f"{2 * rv['half_cycles']} half-cycles over the run) takes about as much: "
                                         f"p = {rv['p']:.2g} against that level"})
                    slow_confounds[kk] = {"effect": kk, "with": f"slow structure in {pf.time_name} at its driver's "
                                                               f"timescale ({rv['half_cycles']} half-cycles over the "
                                                               f"run)",
                                          "correlation": rv["correlation"], "named": False, "slow_structure": rv,
                                          "separate_by": "a driver that does not follow the reading order's slow "
                                                         "course: cycle it faster than the run's slow structure, or "
                                                         "hold the probe still (a static log) while it changes"}
                    continue
            # every held-out block but one must gain: on a log whose neighbouring rows share their errors (a
            # probe turned by hand) a small gain on the pooled blocks can come from one or two of them.  Shots
            # whose errors are independent need the pooled gain only: five blocks of a 24-shot log hold ~5 shots
            # each, and an effect at z = 12 gained on 3 of them as often as not
            if cv1 < cv0 and o1 < o0 and (better >= K - 1 or not blockwise):
                chosen = (kk, p, o0, o1)
                break
            steps.append({"effect": kk, "p": p, "kept": False, "folds_gaining": better,
                          "why": "no gain on held-out data" if not (cv1 < cv0 and o1 < o0) else
                          f"it gains on only {better} of {K} held-out blocks"})
        if chosen is None:
            if tests and tests[0][0] >= alpha / len(remaining):
                steps.append({"effect": tests[0][2], "p": tests[0][0], "kept": False, "why": "p above the threshold"})
            break
        kk, p, o0, o1 = chosen
        steps.append({"effect": kk, "p": p, "kept": True, "own_cv_rms_before": o0, "own_cv_rms_after": o1})
        kept.append(kk)
        pvals[kk] = p
        remaining.remove(kk)
        refit(kept)
        des, idx, _, rows = design(testable)
    # backward
    while kept:
        S = base + [i for kk in kept for i in idx[kk]]
        drops = [(des.ftest([i for i in S if i not in idx[kk]], idx[kk])[0], kk) for kk in kept]
        p, kk = max(drops)
        if p <= alpha:
            pvals.update({k2: p2 for p2, k2 in drops})
            break
        kept.remove(kk)
        state["theta"].pop(kk, None)
        steps.append({"effect": kk, "p": p, "kept": False, "why": "dropped: not significant once the others were in"})
        refit(kept)
        des, idx, _, rows = design(testable)
    # a temperature term against a cubic nonlinearity of its own axis: a temperature term is a function of the
    # temperature alone, a nonlinearity of the axis' reading alone; where the orientations and the temperature
    # share a slow course in time (a tumble whose swing narrows as the part warms), an unmodelled cubic of the
    # axis is taken by the temperature (acc z^3 of 2e-3 g on 2000 smooth rows under a ramp: a temperature term
    # of acc z named on 4 of 12 seeds).  Fitted beside that cubic, the temperature term must still be
    # significant at alpha (the backward pass's level) to be named
    cubic_confounds = {}
    while True:
        refused = None
        for kk in [x for x in kept if x.split(":")[0] in SLOW_DRIVERS]:
            chk = _beside_cubic(kk)
            if chk["p_beside"] >= alpha:
                refused = (kk, chk)
                break
            cubic_checks[kk] = chk
        if refused is None:
            break
        kk, chk = refused
        _, tri, ax = kk.split(":")
        kept.remove(kk)
        state["theta"].pop(kk, None)
        steps.append({"effect": kk, "p": pvals.pop(kk, None), "beside_cubic": chk, "kept": False,
                      "why": f"dropped: not significant beside a cubic nonlinearity of {tri} {ax} (p = "
                             f"{chk['p_beside']:.2g} beside it)"})
        cubic_confounds[kk] = {"effect": kk, "with": f"a cubic nonlinearity of {tri} {ax}", "beside_cubic": chk,
                               "correlation": chk["correlation"], "gain_share": chk["gain_share"], "named": False,
                               "separate_by": f"read the {tri} {ax} axis through its whole range at each of several "
                                              f"temperatures (a temperature term is the same at one temperature "
                                              f"whatever the reading, a nonlinearity the same at one reading "
                                              f"whatever the temperature)"}
        refit(kept)
        des, idx, _, rows = design(testable)
    # the final model: estimates, gains (on the effect's own invariant), confounds
    S = base + [i for kk in kept for i in idx[kk]]
    est, se, s2 = des.coef(S)
    cov = des.coef_cov(S)
    serial_f = dict(zip(kept, bartlett.scale_cov(des, S, cov, [idx[kk] for kk in kept])))
    R_final, R_cv = des.raw_residuals(S), des.cv_residuals(S)
    # the final model's held-out prediction (_prediction), checked against the same held-out folds of poses
    prediction_final = _prediction(des, S, rows, chans) if kept else None
    effects = []
    pos = nb
    for kk in kept:
        name, sensor, axis, units, n = cand_keys[kk]
        Sb = [i for i in S if i not in idx[kk]]
        Rb, Rbcv = des.raw_residuals(Sb), des.cv_residuals(Sb)
        j = own[kk][:1]  # the gain on the effect's first invariant, in its units
        rms = lambda R: float(np.sqrt(np.mean(R[rows][:, j] ** 2)))  # noqa: E731
        gain = Gain(rms(Rb), rms(R_final), rms(Rbcv), rms(R_cv), None, None, float("nan"), float("nan"))
        if n > 1:
            ph = mdl._rig_cols(axis)
            th = est[pos:pos + n]
            amp = float(np.sqrt(np.mean((ph @ th[:4]) ** 2)))
            detail = {"model": f"|b| (and dip) as harmonics 1-2 of the {axis} angle in the file: a field that changes "
                               f"with the rig's position (pose-free: its direction across the field is not seen)",
                      "whose": "the rig's, not the probe's"}
            e = Effect(name, sensor, axis, amp, float(np.sqrt(np.trace(cov[pos:pos + 4, pos:pos + 4]) / 2)),
                       "nT RMS of |b|", gain, rms_units=UNITS[chans[j[0]]], p_value=pvals.get(kk, np.nan),
                       detail=detail)
        else:
            e = Effect(name, sensor, axis, float(est[pos]), float(np.sqrt(max(cov[pos, pos], 0))), units, gain,
                       rms_units=UNITS[chans[j[0]]], p_value=pvals.get(kk, np.nan),
                       detail={"gain_on": [chans[i] for i in j]})
        e.detail["serial_inflation"] = serial_f[kk]
        if kk in cubic_checks:
            e.detail["beside_cubic"] = cubic_checks[kk]
        effects.append(e)
        pos += n
    confounded = []
    # each kept effect's signature: its refitted value, or (a refit whose Gauss-Newton step every halving made
    # worse left it unset) its linear estimate in the final model
    at, pos = {}, len(base)
    for kk in kept:
        at[kk] = state["theta"].get(kk, est[pos:pos + len(idx[kk])])
        pos += len(idx[kk])
    for kk in kept:
        others = [x for x in kept if x != kk]
        for jj in testable:
            if jj == kk:
                continue
            b2 = base + [i for x in others if x != jj for i in idx[x]]
            rc = des.signal_corr(b2, idx[kk], np.atleast_1d(at[kk]), idx[jj])
            # a temperature's bias and its scale term on one axis differ only through that axis's reading: a
            # second view, on the data rather than on the fitted signature, whether the other in the effect's
            # place keeps as much of its gain as a signal correlated at CONFOUND_CORR would (a temperature bias
            # on mag x injected into a tumbled log came out as a temperature scale on mag x, the bias in its
            # place keeping 99 % of the gain at a signature correlation of 0.88)
            share = _swap_share(des, b2, idx[kk], idx[jj]) if _siblings(kk, jj) and jj not in kept else 0.0
            if rc >= CONFOUND_CORR or share >= CONFOUND_CORR ** 2:
                confounded.append({"effect": kk, "with": jj, "correlation": rc, "named": True,
                                   "gain_share": share, "separate_by": _separate(kk, jj, pf)})
    confounded += [c for kk, c in slow_confounds.items() if kk not in kept]
    confounded += list(cubic_confounds.values())
    if serial["rho"] >= MOVING_RHO and not declared_static(ds):
        for kk in kept:
            confounded.append({"effect": kk, "with": "the motion between neighbouring rows", "correlation": serial["rho"],
                               "named": True,
                               "separate_by": "a static log: hold each orientation still while it is read (or declare "
                                              "the run static if it is), so that motion and sampling between the "
                                              "axes stop shaping the invariants"})
    if effects and pf.holds and not pf.holds["moving_rows_left_out"] and pf.has_acc and not declared_static(ds):
        # a step-and-hold log whose holds do not determine the model: what the selection found may rest on the
        # rows read while moving, whose acceleration no sensor effect models.  The second view is the holds
        # alone (each hold one pose, the baseline fitted to them again): an effect is named where it is
        # significant there beside the others at alpha, and otherwise reported as confounded with the motion
        h = pf.holds
        view = _holds_view(ds, pf)
        try:
            held = {} if view is None else diagnose_posefree(
                view, alpha=alpha, folds=folds, _signature=("confirm", [f"{e.name}:{e.sensor}:{e.axis}" for e in effects]))
        except (DataError, np.linalg.LinAlgError, ValueError, ArithmeticError):
            held = {}  # the holds alone cannot be fitted: they confirm nothing
        named = []
        for e in effects:
            kk = f"{e.name}:{e.sensor}:{e.axis}"
            p_held = held.get(kk)
            if p_held is not None and p_held < alpha:
                e.detail["holds_view"] = {"holds": h["holds"], "p": p_held}
                named.append(e)
                continue
            confounded.append({"effect": kk, "with": f"the motion between the log's {h['holds']} static holds",
                               "share": h["rows_moving"] / max(h["rows_moving"] + h["rows_held"], 1),
                               "correlation": float("nan"),  # no regressor to correlate: a share of rows
                               "named": False, "estimate": e.estimate, "units": e.units, "p_on_holds": p_held,
                               "separate_by": "static holds in more directions (enough to determine the model: the "
                                              "rows read while moving are then left out), or poses for the holds"})
        effects = named
    undetermined = _undetermined(ds, pf) if effects else None
    if undetermined:
        # the calibration refuses these data (the orientations leave a triad's ellipsoid free): an effect
        # found on them rests on that freedom (a compass turned in one plane takes a scale nonlinearity of the
        # axis it barely turns), so it is not named
        from inclino.calib import motion
        separate_by = (motion.FIX if "moved while it was read" in undetermined else
                       "orientations that determine the ellipsoid (turned about more than one axis, through more of "
                       "the sphere), or poses")
        for e in effects:
            confounded.append({"effect": f"{e.name}:{e.sensor}:{e.axis}", "with": undetermined,
                               "undetermined": True, "correlation": float("nan"), "named": False,
                               "estimate": e.estimate, "units": e.units, "separate_by": separate_by})
        effects = []
    # an effect not named (the holds do not confirm it, or the calibration refuses the data) loses its records
    # as a named effect confounded with something (a MinIMU-9 log's mag x nonlinearity was "confounded ...
    # (named)" and "not named")
    named_keys = {f"{e.name}:{e.sensor}:{e.axis}" for e in effects}
    confounded = [c for c in confounded if not c["named"] or c["effect"] in named_keys]
    structure = _structure(pf, R_final, rows, chans, alpha)
    if any(kk not in kept for kk in slow_confounds):
        # the temperature's own terms were refused as the run's slow course: the same structure against the
        # temperature column is that slow course again, not a temperature the library lacks
        for x in structure["significant"]:
            if x["test"] == "temperature":
                x["follows"] = f"not told apart from the run's slow course in {pf.time_name}: see confounded"
    from .runvars import run_variable_confounds

    run_conf = run_variable_confounds(_RunVars(pf))
    # a magnetometer's effects are no question on a log without one: said once, below, as not testable
    not_testable = [{"effect": n, "reason": why} for n, why in NEEDS_POSES if pf.has_mag or n not in NEEDS_MAG]
    if pf.temp is None:
        not_testable.append({"effect": "temperature-bias, temperature-scale",
                             "reason": f"no temp_c column that changes by {DIAGNOSE_MIN_SPAN_C:g} degC or more"})
    if not pf.angles and pf.has_mag:
        not_testable.append({"effect": "rig-field", "reason": "no rig angle column (inc_deg, azi_deg, tf_deg) that "
                                                              f"turns by {RIG_MIN_SPAN_DEG:g} deg or more"})
    if not pf.has_mag:
        not_testable.append({"effect": "field-drift, rig-field, magnetometer effects",
                             "reason": "no magnetometer columns"})
    if not pf.has_acc:
        not_testable.append({"effect": "accelerometer effects, the dip", "reason": "no accelerometer columns"})
    baseline = {
        "model": ("pose-free: per triad a symmetric 3x3 and an offset fitted to the invariants (|g| = G, |b| = F"
                  + (", the dip angle constant; the fluxgate's full 3x3 against the accelerometer's axes"
                     if "dip" in chans else "") + ")"),
        "mode": "invariants", "rows": pf.n_rows, "clusters": k, "rows_per_cluster_max": int(pf.count.max()),
        "invariants": chans, "field_nT": pf.F, "field_from_header": pf.F_given, "gravity_g": pf.G,
        "dip_deg": mdl.unpack(state["v"]).get("dip"),
        "rms": base_rms, "fit_failed": fit_failed, "time_axis": pf.time_name,
        "serial_correlation": {"lag1": serial["rho"], "f_test_inflation": serial["inflation"],
                               "ljung_box_p": bartlett.summary(des, S)["ljung_box_p"],
                               "inflation_by_effect": serial_f,
                               "what": "neighbouring rows' residuals correlate (a log read while moving): the F-tests "
                                       "count n (1 - rho) / (1 + rho) independent rows, or fewer where a test's own "
                                       "Bartlett factor 1 + 2 sum_k rho_e(k) rho_x(k) (its candidate's signature x "
                                       "against the residual e of the model with it, time order, where a Ljung-Box "
                                       "test finds the residual correlated) is larger; a named effect's standard "
                                       "error grows by the square root of its factor"},
        "selection": {"method": "forward stepwise on the invariants (F-test at alpha/m, cross-validation -- "
                                "leave-one-pose-out on independent shots, K blocks on serially correlated rows -- "
                                "overall and on the effect's own invariant must fall, each invariant weighed by its noise with the candidate "
                                "in the model; on a serially correlated log in all held-out blocks but one), backward "
                                "pass at alpha; clusters of rows at one pose count once",
                      "alpha": alpha, "folds": K, "tested": testable, "not_testable": not_testable,
                      "needs_poses": [n for n, _ in NEEDS_POSES], "steps": steps, "final_s2": s2,
                      "notes": _hold_notes(pf), "best_subset": None},
        "holds": pf.holds,
        "structure": structure, "run_variables": run_conf,
        "prediction": {"what": f"the baseline's residual RMS per invariant predicted on poses not fitted (the fit's "
                               f"noise and each value's leverage, {nb} parameters) and achieved on "
                               + ("each pose held out alone" if K == k else f"{K} held-out blocks of poses"),
                       "by_invariant": prediction},
        "prediction_with_effects": None if prediction_final is None else {
            "what": f"the same of the model with the effects named ({len(S)} parameters)",
            "by_invariant": prediction_final},
    }
    out = Diagnosis(baseline=baseline, effects=effects, unexplained=structure["unexplained"], structure=structure,
                    confounded=confounded)
    if keep_plot_data:
        out.plot_data = _plot_data(mdl, state, des, base, S, idx, own, rows, r_base, R_final, effects)
    out.elapsed_s = _time.perf_counter() - t_start
    return out


def _plot_data(mdl, state, des, base, S, idx, own, rows, r_base, R_final, effects) -> dict:
    """What `diagnose --plot` draws of a pose-free diagnosis (plots.write):
    per invariant the baseline's residual and the final model's against
    time (or the reading order); per named effect the residual of its own
    invariant without it and with it against its driver (the axis's
    corrected reading, the temperature, time, the rig angle)."""
    pf = mdl.pf
    tl = "time (s)" if pf.time_name == "time" else "reading order (row)"
    t = pf.t[rows]
    base_ent = [{"channel": c, "x": t, "y": r_base[rows, j], "after": R_final[rows, j] if effects else None,
                 "xlabel": tl, "ylabel": f"{c} residual ({UNITS[c]})"} for j, c in enumerate(pf.chans)]
    g, b = mdl.corrected(mdl.unpack(state["v"]), state["theta"])
    ents = []
    for e in effects:
        kk = f"{e.name}:{e.sensor}:{e.axis}"
        j = own[kk][0]
        Rb = des.raw_residuals([i for i in S if i not in idx[kk]])
        if e.name == "scale-nonlinearity":
            x = (g if e.sensor == "acc" else b)[:, "xyz".index(e.axis)]
            xl = f"{e.sensor} {e.axis} corrected reading ({'g' if e.sensor == 'acc' else 'nT'})"
        elif e.name.startswith("temperature"):
            x, xl = pf.temp, "temperature (degC)"
        elif e.name == "rig-field":
            x, xl = pf.angles[e.axis], f"rig {e.axis} angle (deg)"
        else:
            x, xl = pf.t, tl
        ents.append({"x": x[rows], "before": Rb[rows, j], "after": R_final[rows, j], "xlabel": xl,
                     "ylabel": f"{pf.chans[j]} residual ({UNITS[pf.chans[j]]})",
                     "title": f"{e.name} ({e.sensor} {e.axis})", "file": f"{e.name}_{e.sensor}_{e.axis}.png"})
    return {"mode": "invariants", "baseline": base_ent, "effects": ents}


FIT_FAILED_LINEAR = 2.0  # in-sample RMS this many times the fit's own linearised step's: not converged
FIT_FAILED_RAW = 1.5  # in-sample RMS this many times the raw readings' scaled to G (F): worse than no calibration


def _fit_failed(pf, des, base, rows, r_base, base_rms) -> str | None:
    """Why the baseline's residuals are no fitted model's, or None.  A fit
    at its least squares leaves no more than its own linearised step at that
    point (des.raw_residuals: what one more Gauss-Newton step would leave),
    and no more than the raw readings scaled to G (F), which the model holds
    (M = s I, b = 0).  On readings that do not determine the ellipsoid (a
    phone at one orientation in a car; a magnetometer turned through a cap)
    the refit stops far from either: |g| 0.65 g where the raw |g| spreads
    0.04 g, |b| 8 464 nT where its step leaves 250 nT."""
    lin = des.raw_residuals(base)
    out = []
    for j, c in enumerate(pf.chans):
        u = UNITS[c]
        b0 = base_rms[c]
        lj = float(np.sqrt(np.mean(lin[rows, j] ** 2)))
        if b0 > FIT_FAILED_LINEAR * lj:
            out.append(f"{c} {b0:.4g} {u} where one more step of the fit leaves {lj:.4g} {u} (it did not converge)")
            continue
        raw = pf.acc if c == "|g|" else pf.mag if c == "|b|" else None
        if raw is None:
            continue
        n = np.linalg.norm(raw[rows], axis=1)
        ident = (pf.G if c == "|g|" else pf.F) * float(np.sqrt(np.mean((n / np.median(n) - 1.0) ** 2)))
        if b0 > FIT_FAILED_RAW * ident:
            out.append(f"{c} {b0:.4g} {u} where the raw readings scaled to {'G' if c == '|g|' else 'F'} leave "
                       f"{ident:.4g} {u} (worse than no calibration)")
    return "; ".join(out) or None


def _prediction(des, S, rows, chans) -> dict:
    """Each invariant's residual RMS on poses the fit of the columns S has not
    seen, predicted from that fit alone and achieved on the held-out folds:
    its noise s_j^2 = sum r^2 / sum (1 - h), h each value's leverage (what the
    fit leans on it; serially correlated rows weigh (1 + rho) / (1 - rho)
    times more), and a value held out with its fold erring by
    s_j^2 (1 + x^T G_-f^-1 x) (Design.heldout_factor: the fold's values
    leaning on one another included)."""
    R, R_cv = des.raw_residuals(S), des.cv_residuals(S)
    h = np.clip(des.leverage(S) * des.inflation, 0.0, 0.95)
    hf = 1.0 + (des.heldout_factor(S) - 1.0) * des.inflation
    out = {}
    for j, c in enumerate(chans):
        hj = h[rows, j]
        s2j = float(np.sum(R[rows, j] ** 2) / max(np.sum(1.0 - hj), 1e-12))
        pin = float(np.sqrt(s2j * np.mean(hf[rows, j])))
        ach = float(np.sqrt(np.mean(R_cv[rows, j] ** 2)))
        out[c] = {"predicted_heldout_rms": pin, "achieved_heldout_rms": ach,
                  "ratio": ach / pin if pin > 0 else float("nan")}
    return out


def holds_view(ds) -> RawDataset | None:
    """The held rows of a step-and-hold log with an accelerometer whose
    holds alone leave the pose-free model undetermined, each hold one pose:
    the view in which an effect found on every row of it must be confirmed
    to be named (and in which signature_z sizes one); None for any other
    log."""
    return _holds_view(ds, _PF(ds))


def _signature_per_pose(des, base, cols, ws) -> tuple:
    """(z2, loss): the squared whitened norm of the candidate's signature
    (its columns `cols` combined by ws, in the design's scaled units)
    beyond the baseline `base`, and per pose (a design row: a hold, a shot,
    a row of a moving log) what of it that pose holds: the sum of squares
    the signature's regression on the baseline loses when it is left out
    (e_i' (I - H_ii)^-1 e_i, H the baseline's hat matrix)."""
    rows = des.rows
    X = des.whitened(list(base) + list(cols), rows)
    n, ch, _ = X.shape
    nb = len(base)
    A = X[:, :, :nb].reshape(-1, nb)
    c = (X[:, :, nb:] @ np.asarray(ws, float)).ravel()
    Ginv = np.linalg.pinv(A.T @ A)
    e = (c - A @ (Ginv @ (A.T @ c))).reshape(n, ch)
    Xb = X[:, :, :nb]
    H = np.einsum("nip,pq,njq->nij", Xb, Ginv, Xb)
    eye = np.eye(ch)
    try:
        loss = np.einsum("ni,ni->n", e, np.linalg.solve(eye[None] - H, e[:, :, None])[:, :, 0])
    except np.linalg.LinAlgError:  # a pose that alone fixes a baseline term: leaving it out loses all of it
        loss = np.array([float(e[i] @ np.linalg.pinv(eye - H[i]) @ e[i]) for i in range(n)])
    return float(e.ravel() @ e.ravel()), np.maximum(loss, 0.0)


def _holds_view(ds, pf):
    """The second view of a step-and-hold log with an accelerometer whose
    holds alone leave the model undetermined (every row is then a pose, the
    rows read while moving among them): its held rows only, each hold one
    pose (a pose_id column).  None for any other log, and for a run declared
    static (its rows are all held)."""
    h = pf.holds
    if not (h and not h["moving_rows_left_out"] and pf.has_acc) or declared_static(ds):
        return None
    if h["leverage_max"] > HOLDS_VIEW_MAX_LEVERAGE:
        # a term of the baseline rests on one hold (a six-face session: leverage 1.00): fitted to the holds
        # again, that hold is fitted exactly, and an effect tested there takes what the others' small
        # differences leave (imucal's session without its face labels: nonlinearities of -0.3 to -0.55 /g at
        # p 1e-22 on its 31 holds).  Nothing can be confirmed there
        return None
    if h["holds"] < MIN_CLUSTERS:
        return None
    lab = pf.hold_labels
    sel = np.flatnonzero(lab >= 0)
    cols = {c: np.asarray(v)[sel] for c, v in ds.columns.items() if c not in ID_COLUMNS}
    cols["pose_id"] = lab[sel].astype(float)
    return RawDataset(cols, dict(ds.meta))


HANDEDNESS_WHY = "a magnetometer axis mirrored in the data, or the accelerometer's gravity sign turned"


def calibrate_says(ds, found=None, static: bool = False) -> dict | None:
    """What `calibrate` says of these data, the calibration fitted as it
    fits it (calib.fit, joint, on the checks `found` when they are these
    rows': not run again): {"level": "error", "message", "why"} when it
    refuses them; {"level": "warning", "message"} when, without a header
    dip, the checks warned of a mirrored magnetometer and the fit may have
    turned the field; else None.  The pose-free baseline need not fit what
    `calibrate` fits:
    - its fluxgate's full 3x3 started from a symmetric, positive definite
      ellipsoid: on micropython-fusion's MPU9150 log with its y column
      negated it fitted a dip of +71.4 deg (the header's +66.5) and the
      report said nothing of a mirror, while `calibrate` fitted -P (the
      field turned through 180 deg, a dip of -70.7) and refused (why:
      HANDEDNESS_WHY, from errors.MirroredAxesError);
    - it is fitted whatever the orientations: on the x-IMU3 log of
      xioTechnologies/Fusion, which never tilts far, `calibrate` refused the
      accelerometer's readings as on no ellipsoid while the baseline left a
      |g| residual of 0.6 g and called its structure unexplained."""
    from inclino.calib import _refuse_turned_field, fit
    from inclino.errors import CalibrationError, MirroredAxesError

    try:
        with np.errstate(all="ignore"):
            cal, _ = fit(ds, "joint", report=False, static=static, found=found)
            turned = _refuse_turned_field(ds, cal, found)  # fit raised its refusal; this is the warning
    except (DataError, CalibrationError) as e:
        why = HANDEDNESS_WHY if isinstance(e, MirroredAxesError) else "the data do not determine what it fits"
        return {"level": "error", "message": str(e).removesuffix("; no calibration written"), "why": why}
    except (ArithmeticError, ValueError, np.linalg.LinAlgError):
        return None  # a fit that fails on the arithmetic says nothing of the data
    return {"level": "warning", "message": turned} if turned else None


def calibration_refused(ds) -> str | None:
    """Why the pose-free calibration refuses these data (_undetermined), or
    None."""
    return _undetermined(ds, _PF(ds))


def _undetermined(ds, pf) -> str | None:
    """Why the pose-free calibration refuses these data (a triad's
    ellipsoid not determined by the orientations: calib.triad.fit_sphere on
    the rows it would fit), or None."""
    from inclino import holds
    from inclino.calib import triad
    from inclino.errors import CalibrationError

    for kind, name, R in (("acc", "accelerometer", pf.G), ("mag", "magnetometer", pf.F)):
        if not getattr(ds, f"has_{kind}", False):
            continue
        raw = np.asarray(getattr(ds, kind), float)
        hs = holds.determining(ds, (kind,))
        if hs is not None:
            raw = raw[hs[0] >= 0]
        try:
            with np.errstate(all="ignore"):
                triad.fit_sphere(raw, R, 1e-3 * R, min_rows=10, what=f"the {name}")
        except (CalibrationError, DataError) as e:
            if kind == "acc" and hs is None:
                # a log read mostly while moving whose directions span the sphere: the hand's acceleration keeps
                # the ellipsoid free, not the orientations (calib.motion.named, as calibrate says it)
                from inclino.calib import motion
                moved = motion.named(ds)
                if moved is not None:
                    return moved.removesuffix("; no calibration written").replace(f"; {motion.FIX}", "")
            return str(e)
    return None


def _hold_notes(pf) -> list:
    h = pf.holds
    if not h:
        return []
    if h["moving_rows_left_out"] and not h["rows_moving"]:
        return [f"no poses: {h['holds']} static holds found in the readings ({h['rows_held']} rows), each hold one pose"]
    if h["moving_rows_left_out"]:
        why = ("their motion's acceleration is no sensor effect" if pf.has_acc else
               "the holds alone determine the model, each hold once")
        return [f"no poses: {h['holds']} static holds found in the readings ({h['rows_held']} rows, each hold one "
                f"pose); the {h['rows_moving']} rows read while moving between them are left out ({why})"]
    if not pf.has_acc:
        return [f"no poses: {h['holds']} static holds found in the readings ({h['rows_held']} rows), but alone they "
                f"leave the model undetermined (a hold's leverage {h['leverage_max']:.2f}: too few, or too few "
                f"directions); so every row counts as a pose, the {h['rows_moving']} rows read while turning "
                f"included (a magnetometer reads the field whether it turns or not: no motion in |b|)"]
    return [f"no poses: {h['holds']} static holds found in the readings ({h['rows_held']} rows), but alone they leave "
            f"the model undetermined (a hold's leverage {h['leverage_max']:.2f}: too few, or too few directions); so "
            f"every row counts as a pose, and what the {h['rows_moving']} rows read while moving show is confounded "
            f"with the motion: an effect is named only where the holds alone confirm it"]


# the second view of a log whose holds leave the model undetermined (_holds_view) needs no hold to carry more
# than this of a baseline term (the MPU-6050's 55 holds with its short stop kept: 0.87; six faces: 1.00)
HOLDS_VIEW_MAX_LEVERAGE = 0.95

MOVING_RHO = 0.5  # a lag-1 correlation of the residuals from which a log is read as taken while moving


SHIFT_TEST_RHO = 0.3  # from this lag-1 correlation on, a driver's effect also needs the circular-shift test
SHIFT_MIN_FRACTION = 0.05
SHIFTS = 199
SHIFT_MAX_CORR = 0.3
SHIFT_MIN_COUNT = 20  # fewer unrelated shifts than this: all of them are used (the test errs towards refusing)


def _turn_start(g, b) -> np.ndarray:
    """The rotation of the magnetometer's axes onto the accelerometer's that
    makes the dip most nearly constant, as a start (identity when the data
    do not give one).  Each triad's ellipsoid start is symmetric, so their
    relative turn starts at zero; Gauss-Newton on the 3x3's elements then
    steps along the turn's tangent, which lengthens every reading by
    1 + angle^2 / 2 (7.6 nT of |b| at 50 000 nT for a 1 degree turn, ten
    times a hold mean's noise): on 40 holds the step was halved four times
    at every pass and the fit stopped with the dip 1.06 deg off where one
    more step left 0.013 deg.  g_i^T R b_i = sin(dip) |g_i| |b_i| is linear
    in R's nine elements: solved with the constant set to 1, and the
    nearest rotation kept when it narrows the dip's spread."""
    gu = g / np.linalg.norm(g, axis=1, keepdims=True)
    bu = b / np.linalg.norm(b, axis=1, keepdims=True)
    eye = np.eye(3)
    if len(gu) < 12 or not np.all(np.isfinite(gu)) or not np.all(np.isfinite(bu)):
        return eye
    d0 = np.einsum("ni,ni->n", gu, bu)
    if abs(float(np.median(d0))) < 0.1:  # a dip near 0: the constant does not fix the scale
        return eye
    A = (gu[:, :, None] * bu[:, None, :]).reshape(len(gu), 9)
    sol, *_ = np.linalg.lstsq(A, np.ones(len(gu)), rcond=None)
    u, _, vt = np.linalg.svd(sol.reshape(3, 3) * np.sign(np.median(d0)))
    rot = u @ vt
    if np.linalg.det(rot) <= 0:
        return eye
    d1 = np.einsum("ni,ni->n", gu, bu @ rot.T)
    return rot if np.std(d1) < np.std(d0) else eye


def _lag1(r) -> float:
    """The largest lag-1 correlation (in the file's order) of the baseline's
    invariant residuals over the channels, robust (Spearman), in [0, 0.98]:
    neighbouring rows of a log read while the probe moves share its motion,
    so n of them are worth about n (1 - rho) / (1 + rho) independent ones."""
    best = 0.0
    for j in range(r.shape[1]):
        x = r[:, j]
        if len(x) < 10 or np.ptp(x) == 0:
            continue
        rho = stats.spearmanr(x[1:], x[:-1]).statistic
        if np.isfinite(rho):
            best = max(best, float(rho))
    return float(min(max(best, 0.0), 0.98))


DRIVEN = ("temperature-bias", "temperature-scale", "field-drift", "rig-field")


def _shift_p(mdl, state, des, S, key, n, threshold) -> float:
    """Circular-shift test of a driven candidate (temperature, time, a rig
    angle) on serially correlated rows: its driver is rolled against the
    readings by SHIFTS shifts of at least SHIFT_MIN_FRACTION of the run (the
    driver's own smoothness and the noise's correlation kept, their link
    broken) and the F statistic recomputed for each.  Their mean, against
    the F distribution's, is how much the rows' correlation inflates F for
    this driver; the data's own F, deflated by it, gives p (threshold: not
    used, kept for the call's symmetry; None: that inflation is returned
    instead of p)."""
    pf = mdl.pf
    name, _, ax = key.split(":")
    attr = {"temperature-bias": "temp", "temperature-scale": "temp", "field-drift": "t"}.get(name)
    k = pf.k
    keep = des.rows
    Xs = des.whitened(S, keep).reshape(-1, len(S))
    y = des.yw[keep].ravel()
    Q, _ = np.linalg.qr(Xs)
    ry = y - Q @ (Q.T @ y)
    rss0 = float(ry @ ry)
    W = np.diagonal(_weights_of(des), axis1=1, axis2=2)[keep]  # (k_kept, m)
    dof = len(y) - len(S) - n

    def cols():
        X = mdl.cand_columns(state["v"], state["theta"], key, n)[keep] * W[:, :, None]
        Xc = X.reshape(-1, n)
        return Xc - Q @ (Q.T @ Xc)

    def F_of(Xc, r, rss, dof_):
        c = np.linalg.lstsq(Xc, r, rcond=None)[0]
        gain = float(r @ (Xc @ c))
        return (gain / n) / (max(rss - gain, 1e-300) / max(dof_, 1))
    X_obs = cols()
    f_obs = F_of(X_obs, ry, rss0, dof)
    # the shifted drivers are measured beyond the driver itself (its fitted signature taken off the
    # residual and off their columns, as _slow_rival does): a ramp rolled by a third of the run is still
    # correlated 0.3 with itself, and an effect that is there then leaked into its own null (a 0.05 nT/s
    # drift of |b| on 39 hand-held holds, p 7e-15, read as p 0.03 against its shifts and was refused)
    Q1, _ = np.linalg.qr(X_obs)
    ry1 = ry - Q1 @ (Q1.T @ ry)
    rss1 = float(ry1 @ ry1)
    dof1 = dof - n
    lo = max(1, int(SHIFT_MIN_FRACTION * k))
    shifts = np.unique(np.linspace(lo, k - lo, min(SHIFTS, max(k - 2 * lo + 1, 1))).astype(int))
    orig = getattr(pf, attr) if attr else pf.angles[ax]
    # only shifts whose driver is nearly unrelated to the original (|correlation| <= SHIFT_MAX_CORR): a
    # periodic driver (a temperature cycled 2.5 times) rolled by about a period is the driver again, and
    # its F would carry the effect itself into the null.  Shifts chosen by the driver alone, never by the
    # readings, leave the null distribution as it was
    def feats(v):
        if attr:
            return (np.asarray(v, float),)
        r = np.radians(v)
        return np.cos(r), np.sin(r), np.cos(2 * r), np.sin(2 * r)
    f0 = feats(orig)

    def corr(a, b):
        a, b = a - a.mean(), b - b.mean()
        d = np.sqrt((a @ a) * (b @ b))
        return abs(float(a @ b) / d) if d > 0 else 0.0
    far = [sh for sh in shifts if max(corr(a, b) for a, b in zip(f0, feats(np.roll(orig, sh)))) <= SHIFT_MAX_CORR]
    if len(far) >= SHIFT_MIN_COUNT:
        shifts = np.asarray(far)
    fs = []
    try:
        for sh in shifts:
            v = np.roll(orig, sh)
            if attr:
                setattr(pf, attr, v)
            else:
                pf.angles[ax] = v
            Xs_ = cols()
            fs.append(F_of(Xs_ - Q1 @ (Q1.T @ Xs_), ry1, rss1, dof1))
    finally:
        if attr:
            setattr(pf, attr, orig)
        else:
            pf.angles[ax] = orig
    if not fs:
        return 1.0
    c = max(1.0, float(np.mean(fs)) / (dof1 / max(dof1 - 2, 1)))
    if threshold is None:
        return c
    return float(stats.f.sf(f_obs / c, n, max(dof / c, 1.0)))


def _own_noise(mdl, state) -> np.ndarray:
    """(k, channels): the variance each pose's invariant residuals have from
    its own rows' scatter (pf.own_var: a pose's mean's variance per raw axis,
    its rows' scatter about their mean over their count), carried through the
    model at the state by differences.  A hold of hundreds of quiet rows has
    next to none; a 16-row stop still settling after a turn (the MPU-6050
    session's rows 8952-8968: twice the log's noise on each axis, its rows
    trending) has 1.9 mg on |g|, more than the robust spread of the holds'
    residuals (0.8-1.2 mg); its residual is 4.3 mg.  Judged against that
    spread alone, such a stop sat
    at the chi-square point, and whether it was set aside followed where the
    median residual sat: out at 0 and 0.25 times an injected temperature
    bias, in at 0.5 times, another such stop (rows 4749-4765) out at 1 time;
    and the log's slow structure with it (the slow rivals' level 1.0 or 3.3)."""
    pf = mdl.pf
    x, th = mdl.unpack(state["v"]), state["theta"]
    r0 = mdl.residuals(x, th)
    out = np.zeros_like(r0)
    for tri, var in pf.own_var.items():
        raw = getattr(pf, tri)
        sd = np.sqrt(var)
        try:
            for a in range(3):
                if not np.any(sd[:, a]):
                    continue
                p = raw.copy()
                p[:, a] += sd[:, a]
                setattr(pf, tri, p)
                out += (mdl.residuals(x, th) - r0) ** 2
        finally:
            setattr(pf, tri, raw)
    return out


def _weights_of(des):
    """The per-row whitening the design was built with (diagonal)."""
    return des._W


class _RunVars:
    """What runvars.run_variable_confounds reads, from the cluster means."""

    def __init__(self, pf):
        self.n = pf.k
        self.t = pf.t if pf.time_name == "time" else None
        self.temp = pf.temp
        z = np.zeros(pf.k)
        self.inc = pf.angles.get("inc", z)
        self.azi = pf.angles.get("azi", z)
        self.tf = pf.angles.get("tf", z)


def _own_chan(key, chans) -> list:
    name, sensor, axis = key.split(":")
    if name == "rig-field":
        return [chans.index(c) for c in ("|b|", "dip") if c in chans]
    if name == "field-drift":
        return [chans.index("|b|" if axis == "total" else "dip")]
    if sensor == "acc":
        return [chans.index("|g|")]
    return [chans.index("|b|")]


def _own_cv(des, S, j, rows, scale, folds=None) -> float:
    """Held-out RMS of the effect's own invariant(s), each in units of
    `scale` (its noise: |b| in nT and the dip in degrees pooled); with
    folds, one per fold."""
    R = des.cv_residuals(S)[:, j] / scale[j]
    if folds is None:
        return float(np.sqrt(np.mean(R[rows] ** 2)))
    return np.array([np.sqrt(np.mean(R[rows & (folds == f)] ** 2)) for f in range(int(folds.max()) + 1)])


def _siblings(a, b) -> bool:
    """Two temperature terms (SLOW_DRIVERS) of one sensor axis."""
    (na, *ax_a), (nb_, *ax_b) = a.split(":"), b.split(":")
    return na in SLOW_DRIVERS and nb_ in SLOW_DRIVERS and ax_a == ax_b


def _swap_share(des, others, a, b) -> float:
    """The share of the gain of the columns a (beside `others`) that the
    columns b keep in their place: 1 - (rss(others + b) - rss(others + a))
    / (rss(others) - rss(others + a)), in the design's whitened units, on
    its rows; 0 when a gains nothing."""
    def rss(S):
        R = des.raw_residuals(S)[des.rows] * np.diagonal(des._W, axis1=1, axis2=2)[des.rows]
        return float(np.sum(R ** 2))
    r0, ra = rss(others), rss(list(others) + list(a))
    if r0 - ra <= 0.0:
        return 0.0
    return float(1.0 - (rss(list(others) + list(b)) - ra) / (r0 - ra))


def _separate(a, b, pf) -> str:
    drivers = {a.split(":")[0], b.split(":")[0]}
    if drivers == {"temperature-bias", "temperature-scale"}:
        return (f"turn the {a.split(':')[1]} {a.split(':')[2]} axis through both signs (along and against the "
                f"field) at each temperature: a bias keeps its sign there, a scale term turns with the reading")
    if "field-drift" in drivers and "rig-field" in drivers:
        return ("randomise the order of the positions (or repeat the first ones at the end), so that time and the "
                "rig's position stop rising together")
    if "field-drift" in drivers and drivers & {"temperature-bias", "temperature-scale"}:
        return "cycle the temperature up and down, so that it stops rising with time"
    return "more orientations, spread over the sphere, in a random order"


def _structure(pf, R, rows, chans, alpha) -> dict:
    """The final invariant residuals against generic families: time (or the
    reading order), temperature, each rig angle (harmonics 1-2), the
    channel's own triad's direction (quadratic terms); Ljung-Box in order.
    A channel whose residual, its slow part taken off, still correlates
    from row to row (serial.row_correlated: a sensor's low-pass filter, the
    probe's motion) has each family's F-test deflated by the family's
    Bartlett factor against the residual with it (serial.columns_factor,
    in time order), and its whiteness test asks for more than AR(p) noise
    (serial.prewhitened_ljung_box)."""
    from .study import ljung_box

    tests = []
    serial_by = {}
    tau = (pf.t - pf.t.mean()) / max(np.ptp(pf.t), 1e-300)
    fams = {"time" if pf.time_name == "time" else "reading order": np.column_stack([tau, tau ** 2])}
    if pf.temp is not None:
        dT = (pf.temp - pf.temp.mean()) / max(np.ptp(pf.temp), 1e-300)
        fams["temperature"] = np.column_stack([dT, dT ** 2])
    for ax, a in pf.angles.items():
        ph = np.radians(a)
        fams[f"{ax} angle"] = np.column_stack([np.cos(ph), np.sin(ph), np.cos(2 * ph), np.sin(2 * ph)])
    for tri, raw in (("acc", pf.acc), ("mag", pf.mag)):
        if raw is None:
            continue
        u = raw / np.linalg.norm(raw, axis=1, keepdims=True)
        iu = np.triu_indices(3)
        fams[f"{tri} direction"] = (u[:, :, None] * u[:, None, :])[:, iu[0], iu[1]]
    order = np.argsort(pf.t[rows], kind="stable")
    for j, ch in enumerate(chans):
        y = R[rows, j]
        correlated = bartlett.row_correlated(y[order], len(chans))
        factors = {}
        for fam, Z in fams.items():
            X0 = np.ones((len(y), 1))
            X1 = np.column_stack([X0, Z[rows]])
            r0 = y - X0 @ np.linalg.lstsq(X0, y, rcond=None)[0]
            r1 = y - X1 @ np.linalg.lstsq(X1, y, rcond=None)[0]
            q = np.linalg.matrix_rank(X1) - 1
            dof = len(y) - q - 1
            if q <= 0 or dof <= 0:
                continue
            rss0, rss1 = float(r0 @ r0), float(r1 @ r1)
            F = ((rss0 - rss1) / q) / (rss1 / dof) if rss1 > 0 else np.inf
            if correlated:
                Zc = Z[rows] - Z[rows].mean(0)
                f = bartlett.columns_factor(Zc[order], r1[order])
                factors[fam] = f
                F, dof = F / f, max(dof / f, 1.0)
            tests.append((float(stats.f.sf(F, q, dof)), ch, fam))
        if correlated:
            p_lb, ar = bartlett.prewhitened_ljung_box(y[order])
        else:
            (p_lb, _), ar = ljung_box(y / max(np.std(y), 1e-300), int(min(10, max(1, len(y) // 5)))), 0
        serial_by[ch] = {"correlated": bool(correlated), "ar_order": int(ar), "factors": factors}
        tests.append((p_lb, ch, "whiteness"))
    m = len(tests)
    p, ch, fam = min(tests) if tests else (1.0, None, None)
    thr = alpha / max(m, 1)
    return {"alpha": alpha, "tests": m, "threshold": thr, "min_p": p, "worst": {"channel": ch, "test": fam},
            "unexplained": bool(p < thr),
            "significant": [dict({"channel": c, "test": f, "p": q},
                                 **({"ar_order": serial_by[c]["ar_order"]}
                                    if f == "whiteness" and serial_by[c]["correlated"] else {}))
                            for q, c, f in sorted(tests) if q < thr],
            "serial": {"by_channel": serial_by,
                       "what": ("a channel whose residual, its slow part taken off, correlates from row to row "
                                f"(Ljung-Box of {bartlett.LJUNG_BOX_LAGS} lags, p < {bartlett.GATE_P:g} over the "
                                "channels): each family's F-test is deflated by the Bartlett factor "
                                "1 + 2 sum_k w_k rho_e(k) rho_Z(k) of its columns Z against the residual e with "
                                "them (time order), and the whiteness test is of the residual less an AR(p) noise "
                                f"model (p <= {bartlett.AR_MAX_ORDER}, by AIC)")}}


CONFOUND_CORR = 0.9  # a named effect and a rival: this signature correlation, or (its temperature sibling,
#                     _siblings) the rival keeping its square of the effect's gain in its place (_swap_share)
SLOW_RIVALS_MAX = 40  # rival timescales at most (a driver without a slow course has no slow structure to meet)
SLOW_DRIVERS = {"temperature-bias": "temp", "temperature-scale": "temp"}
CUBIC_RIVAL = "cubic-nonlinearity"  # raw = v + k3 v^3 per axis: no library effect, the rival a temperature term of
#                                    that axis must be significant beside (_beside_cubic)


def _half_cycles(d, order) -> int:
    """The driver's timescale in reading order: the number of half-cycles
    (DCT-II index) at which the cumulative power of its detrended values, in
    that order, reaches half (a ramp 1, a temperature cycled 2.5 times 5)."""
    z = np.asarray(d, float)[order]
    z = z - z.mean()
    k = len(z)
    if k < 4 or not np.any(z):
        return 0
    from scipy.fft import dct

    c = dct(z, type=2, norm="ortho")[1:] ** 2
    return int(np.searchsorted(np.cumsum(c) / c.sum(), 0.5) + 1)


def _slow_rival(mdl, state, des, S, key, n, order) -> dict:
    """The test of candidate `key` (a temperature term) against the slow
    structure in reading order at its driver's own timescale: the driver is
    replaced by a sinusoid of 1 .. 2 h half-cycles over the run in reading
    order (h: the driver's own, _half_cycles), its phase free (two columns),
    and what each such rival takes from the residual of the model S, per
    degree of freedom, is the level of the slow structure the same effect
    would meet with a generic profile at that timescale.  The driver's own
    gain is set against their mean (a line against its continuum:
    Thomson's harmonic F-test, with rivals for the neighbouring
    frequencies): F(1, the rivals' degrees of freedom).  The rivals are
    measured beyond the driver (its signature taken off them and the
    residual): an effect that is there is not counted as structure, and
    the rival at the driver's own timescale measures its quadrature.
    A log read while moving carries slow structure of its own (the probe
    carried through a field that changes in space, an offset that creeps
    while the hand holds it): a smooth driver at the right phase takes part
    of it, about as much as the rivals take.  Returns {"p", "inflation"
    (the rivals' mean gain per degree of freedom over the residual
    variance), "rivals", "dof", "half_cycles" (the driver's), "best"
    (the half-cycles of the rival that takes most per degree of freedom),
    "correlation" (the driver's signature with the span of the rival
    closest to it: near 1 at its own timescale)}."""
    pf = mdl.pf
    attr = SLOW_DRIVERS.get(key.split(":")[0])
    out = {"p": 0.0, "inflation": 1.0, "rivals": 0, "dof": 0, "half_cycles": 0, "best": 0, "correlation": 0.0}
    if attr is None or getattr(pf, attr) is None:
        return out
    orig = getattr(pf, attr)
    h = _half_cycles(orig, order)
    if h < 1:
        return out
    keep = des.rows
    W = np.diagonal(_weights_of(des), axis1=1, axis2=2)[keep]
    Xs = des.whitened(S, keep).reshape(-1, len(S))
    y = des.yw[keep].ravel()
    Q, _ = np.linalg.qr(Xs)
    ry = y - Q @ (Q.T @ y)
    rss0 = float(ry @ ry)

    def sig():
        x = (mdl.cand_columns(state["v"], state["theta"], key, n)[keep] * W[:, :, None]).reshape(-1, n)
        return x - Q @ (Q.T @ x)

    def gain(x, r, scale=None):
        """the gain of the columns x on r, and their rank (relative to `scale`, the columns' norm before a
        projection took them off something)"""
        sv = np.linalg.svd(x, compute_uv=False)
        top = float(np.max(np.linalg.norm(x, axis=0))) if scale is None else scale
        q = int(np.sum(sv > 1e-6 * max(top, 1e-300)))
        if q == 0:
            return 0.0, 0
        c = np.linalg.lstsq(x, r, rcond=1e-6 * max(top, 1e-300) / max(sv[0], 1e-300))[0]
        return float(r @ (x @ c)), q
    xd = sig()
    gd, qd = gain(xd, ry)
    # the rivals are measured beyond the driver (its signature taken off them and off the residual), as the
    # serial factor is on the residual with the candidate in the model: a driver that is there is not
    # counted as structure, and a rival at its own timescale measures the structure in its quadrature
    Qd, _ = np.linalg.qr(xd)
    rd = ry - Qd @ (Qd.T @ ry)
    tau = np.empty(pf.k)
    tau[order] = (np.arange(pf.k) + 0.5) / pf.k
    a = np.std(orig) * np.sqrt(2.0)
    d = xd.ravel()
    gains, dofs, best, cmax = [], [], (-1.0, 0, 0.0), 0.0
    try:
        for j in range(1, min(2 * h, SLOW_RIVALS_MAX) + 1):
            xr = []
            for f in (np.cos, np.sin):
                setattr(pf, attr, orig.mean() + a * f(np.pi * j * tau))
                xr.append(sig())
            xr = np.column_stack(xr)
            Qr, _ = np.linalg.qr(xr)
            corr = float(np.sqrt(np.sum((Qr.T @ d) ** 2) / max(d @ d, 1e-300)))
            cmax = max(cmax, corr)
            g, q = gain(xr - Qd @ (Qd.T @ xr), rd, float(np.max(np.linalg.norm(xr, axis=0))))
            if q == 0:
                continue
            gains.append(g)
            dofs.append(q)
            if g / q > best[0]:
                best = (g / q, j, corr)
    finally:
        setattr(pf, attr, orig)
    dof = len(y) - Q.shape[1] - qd
    if not gains or qd == 0 or dof <= 0:
        return dict(out, half_cycles=h)
    s2 = max(rss0 - gd, 1e-300) / dof
    level = sum(gains) / sum(dofs)
    infl = max(1.0, level / s2)
    F = (gd / qd) / (s2 * infl)
    q2 = float(sum(dofs)) if infl > 1.0 else float(dof)
    return {"p": float(stats.f.sf(F, qd, q2)), "inflation": infl, "rivals": len(gains), "dof": q2,
            "half_cycles": h, "best": int(best[1]), "correlation": float(cmax)}

