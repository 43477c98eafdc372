"""The calibration's noise model, fitted to the data, and the whitening it
gives the fits.

A calibration run's residuals are not one white noise of a known size:

* each triad has its own noise (an ADIS16210 reading at 16 samples scatters
  by ~1.5e-4 g, the fluxgate by ~1.3 nT; a MEMS part of a phone by mg);
* readings at one pose share that pose's error (the turntable's readout,
  a face set by hand, a gimbal's gears) and any slow drift while the
  probe sits there: hundreds of readings at one pose are one cluster, not
  hundreds of independent measurements.

So each row's residual r_i (m channels) in cluster c is modelled as

    r_i = e_i + u_c,   e_i ~ N(0, S)   (sensor noise of one row),
                       u_c ~ N(0, C_c) (shared by the cluster's rows),

S = B diag(v) B^T (v: per-channel variance of one row in the sensor's raw
units; B maps raw units to the residual's units, e.g. the calibration's M),
C_c = J_c diag(q) J_c^T + B diag(p) B^T (q: the pose error per turntable
axis, through the pose Jacobian J_c; p: a per-channel cluster effect, slow
drift while the probe sits at the pose -- fitted only when some cluster has
more than one row, since for single rows it cannot be told from v).

The variances are fitted by restricted maximum likelihood (REML: the
likelihood of the residuals with the fitted parameters integrated out, so
that a run of six poses and twelve parameters does not shrink the pose
error by the parameters it spent) on the cluster means and the
within-cluster scatter.  The fit is then whitened with this model: a
cluster of n rows carries the information of its mean, with covariance
S/n + C_c, not n independent rows (`ClusterWhitener`), and the parameter
covariance follows.
"""
from __future__ import annotations

from dataclasses import dataclass, field

import numpy as np
from scipy import optimize, linalg

from inclino.formats.dataset import ID_COLUMNS, POSE_COLS

POSE_TOL_DEG = 1e-6


def cluster_labels(ds) -> np.ndarray:
    """One label per row: rows read at one pose share a label.

    A `pose_id` (or `segment`, `cluster`) column names the pose; otherwise,
    with pose columns, a cluster is a run of consecutive rows at the same
    indicated pose (a pose set again later is a new setting, with its own
    pose error); without either, every row is its own cluster."""
    n = len(ds)
    cols = getattr(ds, "columns", {})
    for c in ID_COLUMNS:
        if c in cols:
            v = np.asarray(cols[c], float)
            new = np.ones(n, bool)
            new[1:] = v[1:] != v[:-1]
            return np.cumsum(new) - 1
    if all(c in cols for c in POSE_COLS):
        P = np.stack([np.asarray(cols[c], float) for c in POSE_COLS], -1)
        new = np.ones(n, bool)
        new[1:] = np.any(np.abs(np.diff(P, axis=0)) > POSE_TOL_DEG, axis=1)
        return np.cumsum(new) - 1
    return np.arange(n)


def _relabel(labels) -> tuple[np.ndarray, int]:
    _, inv = np.unique(np.asarray(labels), return_inverse=True)
    return inv, int(inv.max()) + 1 if len(inv) else 0


@dataclass
class NoiseComponents:
    """Fitted noise: `sigma` (m,) one row's sensor noise per channel (raw
    units), `sigma_cluster` (m,) the per-channel cluster effect (0 when not
    fitted), `sigma_pose_deg` (3,) the pose error per turntable axis (inc,
    azi, tf; None without poses), with the counts they came from."""
    channels: list
    sigma: np.ndarray
    sigma_cluster: np.ndarray
    sigma_pose_deg: np.ndarray | None
    n_rows: int
    n_clusters: int
    rows_per_cluster_max: int
    method: str = "REML"
    notes: list = field(default_factory=list)

    def per_cell(self) -> np.ndarray:
        """Noise of one new reading at a new pose, per channel, raw units
        (sensor and cluster effect; the pose error is separate)."""
        return np.sqrt(self.sigma ** 2 + self.sigma_cluster ** 2)

    def to_dict(self) -> dict:
        d = {"method": self.method, "rows": self.n_rows, "clusters": self.n_clusters,
             "rows_per_cluster_max": self.rows_per_cluster_max,
             "sigma": dict(zip(self.channels, np.asarray(self.sigma, float).tolist())),
             "sigma_cluster": dict(zip(self.channels, np.asarray(self.sigma_cluster, float).tolist()))}
        if self.sigma_pose_deg is not None:
            d["sigma_pose_deg"] = dict(zip(("inc", "azi", "tf"), np.asarray(self.sigma_pose_deg, float).tolist()))
        if self.notes:
            d["notes"] = list(self.notes)
        return d


def _cluster_sums(R, lab, k):
    n_c = np.bincount(lab, minlength=k).astype(float)
    mean = np.zeros((k, R.shape[1]))
    np.add.at(mean, lab, R)
    mean /= n_c[:, None]
    D = R - mean[lab]
    W = np.zeros((k, R.shape[1]))  # only the diagonal of the within scatter is needed (S diagonal in raw units)
    np.add.at(W, lab, D * D)
    return n_c, mean, W


# clusters whitened at a time in the restricted likelihood's term (bounds its work arrays to a few MB)
REML_CHUNK = 4096
# values per fitted parameter above which the starts are searched on the plain likelihood first (the
# restricted one differs from it by about P / N of the variance) and only the best optima are refined
# under REML; below it every start is fitted under REML directly
STAGED_VALUES_PER_PARAMETER = 50


def _reml_term(Linv, Xc, inv_scale, chunk=REML_CHUNK):
    """log det F and, per cluster, Y_c F^-1 Y_c^T (k, m, m), for
    F = sum_c Xs_c^T M_c^-1 Xs_c and Y_c = M_c^-1 Xs_c, where Xs_c = diag(inv_scale)
    Xc_c and M_c^-1 = Linv_c^T Linv_c.  The clusters are whitened a chunk at
    a time (Xw_c = Linv_c Xs_c; F = sum Xw_c^T Xw_c) and again for the second
    term (T_c = Xw_c Lf^-T with F = Lf Lf^T: Y_c F^-1 Y_c^T = Linv_c^T T_c
    T_c^T Linv_c), so that no (k, m, P) array besides Xc is held (the
    channels' scaling goes into the whitener).  None when F does not factor
    (the parameters not determined)."""
    k, m, P = Xc.shape
    Ls = Linv * inv_scale[None, None, :]
    F = np.zeros((P, P))
    for lo in range(0, k, chunk):
        A = (Ls[lo:lo + chunk] @ Xc[lo:lo + chunk]).reshape(-1, P)
        F += A.T @ A
    try:
        Lf = np.linalg.cholesky(F)
    except np.linalg.LinAlgError:
        return None
    d = np.diagonal(Lf)
    if not np.all(d > 0):
        return None
    ld = 2.0 * float(np.log(d).sum())
    Q = np.empty((k, m, m))
    for lo in range(0, k, chunk):
        Li = Linv[lo:lo + chunk]
        A = (Ls[lo:lo + chunk] @ Xc[lo:lo + chunk]).reshape(-1, P)
        T = linalg.solve_triangular(Lf, A.T, lower=True, check_finite=False).T.reshape(-1, m, P)
        Q[lo:lo + chunk] = np.swapaxes(Li, 1, 2) @ (T @ np.swapaxes(T, 1, 2)) @ Li
    return ld, Q


def fit_components(R, labels, Jpose=None, X=None, start_sigma=None, floor=None,
                   channels=None, X_means=None, pose_floor_deg=None) -> NoiseComponents:
    """REML variance components of residuals R (n, m) in raw units.

    labels: (n,) cluster of each row; Jpose: (n, m, 3) the residual's change
    per degree of each turntable axis, raw units (None: no pose error);
    X: (n, m, p) the residual's Jacobian in the fitted parameters, raw units
    (for the restricted likelihood; None: plain maximum likelihood);
    start_sigma: (m,) a starting sensor sigma; floor: (m,) the smallest
    sensor sigma allowed (default 1e-3 of each channel's RMS); pose_floor_deg:
    the smallest pose error allowed per turntable axis (default none: a
    caller that assumes a pose error gets the noise the residuals show on
    top of it, not a split that trades it for a cluster drift); X_means:
    instead of X, its cluster means (k, m, p) in the order of the sorted
    labels (a caller that builds them a chunk of rows at a time, without
    the n x m x p array).

    With many more values than parameters (N = clusters x channels >=
    STAGED_VALUES_PER_PARAMETER x p) each start is fitted on the plain
    likelihood (cheap: no p-column term) and the distinct optima are then
    refined under REML, the best REML value winning; a 40 000-row chamber
    run with 55 parameters took over 15 CPU minutes fitting every start
    under REML, for the same optimum."""
    R = np.asarray(R, float)
    n, m = R.shape
    lab, k = _relabel(labels)
    n_c, mean, W = _cluster_sums(R, lab, k)
    multi = bool(np.any(n_c > 1))
    rms = np.sqrt(np.maximum(np.mean(R ** 2, 0), 1e-300))
    floor = np.maximum(1e-3 * rms, 1e-300) if floor is None else np.asarray(floor, float)
    Jc = None
    if Jpose is not None:
        Jc = np.zeros((k, m, 3))
        np.add.at(Jc, lab, np.asarray(Jpose, float))
        Jc /= n_c[:, None, None]
    Xc = None  # the Jacobian's cluster means (k, m, P), raw units (the channels' scale goes into the whitener)
    scale = rms  # work in units of each channel's RMS
    if X_means is not None:
        Xc = np.asarray(X_means, float)
        if Xc.shape[0] != k:
            raise ValueError(f"X_means has {Xc.shape[0]} clusters, the labels {k}")
    elif X is not None:
        X = np.asarray(X, float)
        if k == n and np.array_equal(lab, np.arange(n)):  # every row its own cluster: the mean is the row
            Xc = X  # not copied (n x 6 x P: the largest array of the fit)
        else:
            Xc = np.zeros((k, m, X.shape[2]))
            np.add.at(Xc, lab, X)
            Xc /= n_c[:, None, None]
        del X
    ms, Ws = mean / scale, W / scale ** 2
    Jcs = None if Jc is None else Jc / scale[None, :, None]
    within_n = float(np.sum(n_c - 1.0))
    Wsum = Ws.sum(0)
    n_q = 3 if Jc is not None else 0
    n_p = m if multi else 0

    def unpack(th):
        e = np.exp(th)
        return e[:m], e[m:m + n_q], e[m + n_q:m + n_q + n_p]

    def nll(th, restricted=True):
        """Half the negative (restricted) log-likelihood and its gradient in th."""
        v, q, p = unpack(th)
        M = np.zeros((k, m, m))
        M[:, range(m), range(m)] = v / n_c[:, None]
        if n_p:
            M[:, range(m), range(m)] += p
        if n_q:
            JQ = Jcs * q[None, None, :]
            M += JQ @ np.swapaxes(Jcs, 1, 2)
        try:
            L = np.linalg.cholesky(M)
        except np.linalg.LinAlgError:
            return 1e300, np.zeros_like(th)
        Mi = np.linalg.inv(M)
        u = np.einsum("cij,cj->ci", Mi, ms)
        val = 2.0 * np.log(np.diagonal(L, axis1=1, axis2=2)).sum() + float((u * ms).sum())
        G = Mi - u[:, :, None] * u[:, None, :]
        if restricted and Xc is not None:
            term = _reml_term(np.linalg.inv(L), Xc, 1.0 / scale)
            if term is None:
                return 1e300, np.zeros_like(th)
            val += term[0]
            G -= term[1]
        Gd = np.diagonal(G, axis1=1, axis2=2)  # (k, m)
        gv = (Gd / n_c[:, None]).sum(0)
        if within_n > 0:
            val += within_n * np.log(v).sum() + float((Wsum / v).sum())
            gv = gv + within_n / v - Wsum / v ** 2
        grads = [gv * v]
        if n_q:
            grads.append(np.einsum("cik,cij,cjk->k", Jcs, G, Jcs) * q)
        if n_p:
            grads.append(Gd.sum(0) * p)
        return 0.5 * val, 0.5 * np.concatenate(grads)

    if start_sigma is not None:
        v0 = (np.asarray(start_sigma, float) / scale) ** 2
    elif within_n > 0:
        v0 = np.maximum(Wsum / within_n, 1e-6)
    else:
        v0 = np.full(m, 0.5)
    v0 = np.maximum(v0, (floor / scale) ** 2)
    q_lo = np.full(n_q, 1e-14) if pose_floor_deg is None else np.maximum(
        np.broadcast_to(np.asarray(pose_floor_deg, float) ** 2, (n_q,)), 1e-14)
    lo = np.concatenate([np.log((floor / scale) ** 2), np.log(q_lo), np.full(n_p, np.log(1e-10))])
    hi = np.concatenate([np.full(m, np.log(100.0)), np.full(n_q, np.log(100.0)), np.full(n_p, np.log(100.0))])
    hi = np.maximum(hi, lo + np.log(100.0))  # floors above the residuals' own scale (residuals far below the noise)
    bounds = list(zip(lo, hi))

    def descend(th0, restricted):
        f0 = nll(th0, restricted)[0]
        res = optimize.minimize(nll, th0, args=(restricted,), jac=True, method="L-BFGS-B", bounds=bounds,
                                options={"maxiter": 500})
        return (res.x, res.fun) if np.isfinite(res.fun) and res.fun <= f0 else (th0, f0)

    # several starts: in log-variances a component started near zero barely moves (its gradient is
    # proportional to it), and the pose error and the per-channel cluster effect can trade places; the
    # best likelihood wins.  A "moderate" start puts a tenth of each channel's variance into the component.
    jq = np.mean(Jcs ** 2, axis=(0, 1)) if n_q else np.zeros(0)
    q_mod = 0.1 / np.maximum(jq, 1e-300)
    starts = [(np.full(n_q, 1e-4), np.full(n_p, 0.05)), (q_mod, np.full(n_p, 1e-3)),
              (np.full(n_q, 1e-6), np.full(n_p, 0.1)), (q_mod, np.full(n_p, 0.1))]
    if not n_q or not n_p:
        starts = starts[:2]
    starts = [np.clip(np.log(np.concatenate([v0, q0, p0])), lo, hi) for q0, p0 in starts]
    if Xc is not None and k * m >= STAGED_VALUES_PER_PARAMETER * Xc.shape[2]:
        # the starts' optima on the plain likelihood, each distinct one refined under REML
        found = sorted((descend(th0, False) for th0 in starts), key=lambda r: r[1])
        starts = []
        for th, _ in found:
            if not any(np.max(np.abs(th - s)) < 1e-3 for s in starts):
                starts.append(th)
    best = None
    for th0 in starts:
        th, f = descend(th0, True)
        if best is None or f < best[1]:
            best = (th, f)
    th = best[0]
    v, q, p = unpack(th)
    comps = NoiseComponents(channels=list(channels) if channels is not None else [f"c{i}" for i in range(m)],
                            sigma=np.sqrt(v) * scale,
                            sigma_cluster=np.sqrt(p) * scale if n_p else np.zeros(m),
                            sigma_pose_deg=np.sqrt(q) if n_q else None, n_rows=n, n_clusters=k,
                            rows_per_cluster_max=int(n_c.max()) if k else 0,
                            method="REML" if Xc is not None else "ML")
    if not multi:
        comps.notes.append("one row per pose: a drift shared by a pose's readings cannot be told from the "
                           "sensor noise; both are in sigma")
    return comps


class ClusterWhitener:
    """Whitening of residuals (n, m) under per-row noise S (m, m, common to
    every row) and a per-cluster effect C_c (k, m, m): a cluster's rows give
    their deviations from its mean whitened by S, and its mean whitened by
    (S + n_c C_c)/n_c -- exactly r^T V^-1 r for the block covariance
    V_c = I (x) S + 1 1^T (x) C_c.  With one row per cluster this is each row
    whitened by S + C_c."""

    def __init__(self, S, C, labels, means_only: bool = False):
        """means_only: apply, apply_rows and apply_jac give the clusters'
        whitened means alone (what a fit whose regressors are the readings
        takes from a cluster at one pose: see component_whitener)."""
        self.means_only = bool(means_only)
        self.lab, self.k = _relabel(labels)
        self.n_c = np.bincount(self.lab, minlength=self.k).astype(float)
        S = np.asarray(S, float)
        C = np.asarray(C, float)
        self.m = S.shape[-1]
        self.single = bool(np.all(self.n_c == 1))
        self.LS = np.linalg.inv(np.linalg.cholesky(S))  # (m, m)
        Mc = S[None] / self.n_c[:, None, None] + C
        self.LM = np.linalg.inv(np.linalg.cholesky(Mc))  # (k, m, m): the mean's whitener
        # a row's marginal covariance S + C_c (for outlier tests)
        self.Lrow = np.linalg.inv(np.linalg.cholesky(S[None] + C))

    def _means(self, A):
        """Cluster means of A (n, m, ...) -> (k, m, ...)."""
        out = np.zeros((self.k,) + A.shape[1:])
        np.add.at(out, self.lab, A)
        return out / self.n_c.reshape((-1,) + (1,) * (A.ndim - 1))

    def apply(self, r) -> np.ndarray:
        r = np.asarray(r, float)
        if self.single:
            return np.einsum("nij,nj->ni", self.LM[self.lab], r).ravel()
        mean = self._means(r)
        mw = np.einsum("cij,cj->ci", self.LM, mean)
        if self.means_only:
            return mw.ravel()
        dev = (r - mean[self.lab]) @ self.LS.T
        return np.concatenate([dev.ravel(), mw.ravel()])

    def starts(self) -> np.ndarray:
        """The rows at which a cluster starts (0 first), when each cluster's
        rows are consecutive (labels from cluster_labels: runs of rows);
        else [0] (one part: the whole)."""
        if np.any(np.diff(self.lab) < 0) or np.any(np.diff(self.lab) > 1):
            return np.zeros(1, int)
        return np.flatnonzero(np.diff(self.lab, prepend=-1))

    def apply_rows(self, A, rows: slice) -> np.ndarray:
        """`apply` (A: residuals (n, m)) or `apply_jac` (A: a Jacobian (n,
        m, p)) of the rows in `rows` alone, a slice that starts and ends at
        cluster starts (see `starts`): the values those give for these
        clusters, the deviations first then the means, so that a fit can
        whiten its residuals a part of the run at a time."""
        A = np.asarray(A, float)
        tail = A.shape[2:]
        lab = self.lab[rows]
        if self.single:
            return np.einsum("nij,nj...->ni...", self.LM[lab], A).reshape((-1,) + tail)
        c0 = int(lab[0])
        first = np.flatnonzero(np.diff(lab, prepend=c0 - 1))  # the rows at which each cluster starts
        k = len(first)
        mean = np.add.reduceat(A, first, axis=0) / self.n_c[c0:c0 + k].reshape((-1,) + (1,) * (A.ndim - 1))
        mw = np.einsum("cij,cj...->ci...", self.LM[c0:c0 + k], mean)
        if self.means_only:
            return mw.reshape((-1,) + tail)
        dev = np.einsum("ij,nj...->ni...", self.LS, A - np.repeat(mean, np.diff(np.append(first, len(lab))), 0))
        return np.concatenate([dev.reshape((-1,) + tail), mw.reshape((-1,) + tail)])

    def part(self, rows: slice) -> "WhitenerPart":
        """The whitener of the rows in `rows` alone (apply_rows)."""
        return WhitenerPart(self, rows)

    def apply_jac(self, J) -> np.ndarray:
        """J: (n, m, p) -> the whitened Jacobian, rows as `apply`'s."""
        J = np.asarray(J, float)
        p = J.shape[2]
        if self.single:
            return np.einsum("nij,njk->nik", self.LM[self.lab], J).reshape(-1, p)
        mean = self._means(J)
        mw = np.einsum("cij,cjk->cik", self.LM, mean)
        if self.means_only:
            return mw.reshape(-1, p)
        dev = np.einsum("ij,njk->nik", self.LS, J - mean[self.lab])
        return np.concatenate([dev.reshape(-1, p), mw.reshape(-1, p)])

    def row_d2(self, r) -> np.ndarray:
        """Each row's whitened squared norm under its marginal covariance S + C_c."""
        w = np.einsum("nij,nj->ni", self.Lrow[self.lab], np.asarray(r, float))
        return (w ** 2).sum(-1)


class WhitenerPart:
    """A ClusterWhitener restricted to whole clusters (rows: a slice from
    one cluster start to another): apply / apply_jac of those rows."""

    def __init__(self, w: ClusterWhitener, rows: slice):
        self.w, self.rows = w, rows

    def apply(self, r) -> np.ndarray:
        return self.w.apply_rows(r, self.rows)

    def apply_jac(self, J) -> np.ndarray:
        return self.w.apply_rows(J, self.rows)


def block_diag2(A, B) -> np.ndarray:
    return linalg.block_diag(np.asarray(A, float), np.asarray(B, float))


CHANNELS_6 = ["acc_x_g", "acc_y_g", "acc_z_g", "mag_x_nT", "mag_y_nT", "mag_z_nT"]  # both triads' channels


def component_whitener(comps: "NoiseComponents", Ma, Mm, Jp, labels, means_only: bool = False) -> ClusterWhitener:
    """The whitener of both triads' residuals in corrected units under noise
    components fitted in raw units: per-row noise B diag(sigma^2) B^T (B the
    triads' M's), and per cluster the cluster effect plus the pose error
    (Jp (n, 6, 3) the residuals' pose Jacobian, deg), averaged over the
    cluster's rows.

    means_only: the clusters' means alone, for a fit whose regressors are
    the readings (r = M raw - c - f(pose)).  Within a cluster the pose, and
    so f, is one: a row's deviation from its cluster's mean is the readings'
    noise alone, and fitted it says M (noise) = 0, which pulls M towards
    zero (errors in the regressors).  Weighed by the per-row noise, as the
    block covariance weighs them, those deviations biased the magnetometer's
    scale by -5e-4 (about one standard error) on holds of 20-50 rows with a
    100 nT offset each (tools/independent_check, cluster_poses); the
    readings' own scatter over the whole run is far larger than their noise,
    so the same pull through the means is 1e-5 of it."""
    B = block_diag2(Ma, Mm)
    S = B @ np.diag(comps.sigma ** 2) @ B.T
    Crow = B @ np.diag(comps.sigma_cluster ** 2) @ B.T
    if comps.sigma_pose_deg is not None:
        Crow = Crow + np.einsum("nik,k,njk->nij", Jp, comps.sigma_pose_deg ** 2, Jp)
    else:
        Crow = np.broadcast_to(Crow, (len(labels), 6, 6))
    lab, k = _relabel(labels)
    C = np.zeros((k, 6, 6))
    np.add.at(C, lab, Crow)
    C /= np.bincount(lab, minlength=k)[:, None, None]
    return ClusterWhitener(S, C, lab, means_only=means_only)
