"""`joint`: our method, the default.

Both triads at once, a full 3x3 and a bias each (the firmware's model
corrected = M (raw - b)), by maximum likelihood under the emulator's noise
model, robust to outlier readings, with a covariance for every parameter.

* With the turntable's poses (inc_deg, azi_deg, tf_deg): every row gives six
  equations, corrected acc = C(pose) [0, 0, G] and corrected mag =
  C(pose) f(F, dip, dec).  The unknowns are M_a, M_a b_a, M_m, M_m b_m (the
  residual is linear in them) and the dip (F is fixed: it only sets the unit,
  and is not separable from the scale of M_m).  Each row's 6x6 covariance is
  the sensor noise through M (sigma_acc^2 M_a M_a^T, sigma_mag^2 M_m M_m^T)
  plus the turntable readout error sigma_pose (deg, on each of I, A, T)
  through the pose Jacobian -- correlated between the two triads, since both
  see the same pose error.  The residuals are whitened with it (generalised
  least squares, the maximum-likelihood estimate to first order).
* Without poses (field recalibration, no turntable): the invariants
  |g| = G, |b| = F and the dip (g.b / |g||b| = sin dip, one unknown dip)
  constrain everything but one common rotation of both triads, which cannot
  be observed without a reference; it is fixed by taking M_a symmetric (the
  body frame is the accelerometer's own axes).  Started from an algebraic
  ellipsoid fit of each triad.

Scale nonlinearity (with poses, default when the poses determine it): the
model becomes corrected = M (raw + q raw^2 / S - b) per axis (S = G or F),
q fitted as nuisance parameters; the calibration returned is the linear one
that best represents the fitted probe over the working range (inclination
0-90 deg, every azimuth and toolface), since the firmware holds only M, b.

Robustness: a first pass with the soft-L1 loss on the whitened residuals;
rows whose whitened squared norm exceeds the chi-square 99.9 % point are
dropped as outliers; a final Gauss-Newton pass on the kept rows gives the
estimate and the covariance s^2 (J^T J)^-1 (s^2 = chi^2/dof, reported).
"""
from __future__ import annotations

import numpy as np
from scipy import optimize, stats

from inclino.engines import reference as ref
from inclino.formats.dataset import RawDataset
from inclino.errors import CalibrationError, DataError

from . import common, triad
from .common import SIGMA_ACC, SIGMA_MAG  # noqa: F401 (the nominal noise; callers import it from here)
from .triad import robust_threshold  # noqa: F401 (the outlier threshold of every fit; callers import it from here)
from .ellipsoid import ellipsoid_start  # noqa: F401 (callers import it from here too)

SIGMA_POSE_DEG = 0.05  # turntable readout
MIN_ROWS_POSES = 8
MIN_ROWS_INVARIANTS = 30
NONLINEAR_MAX_SIGMA_RATIO = 1.5  # auto: fit the nonlinearity unless it inflates the predicted azimuth 1-sigma more


# --------------------------------------------------------------------------
# with poses

PARAM_NAMES_POSE = ([f"acc M[{i}{j}]" for i in range(3) for j in range(3)] + [f"acc offset {a}" for a in "xyz"]
                    + [f"mag M[{i}{j}]" for i in range(3) for j in range(3)] + [f"mag offset {a}" for a in "xyz"]
                    + [f"acc nonlinearity {a}" for a in "xyz"] + [f"mag nonlinearity {a}" for a in "xyz"])
SINGULAR_COND = 1e14  # of the column-equilibrated normal matrix: below it every parameter is determined


class SingularFit(CalibrationError):
    """The poses (or orientations) do not determine a parameter: `param`
    names the one the null direction loads most on."""

    def __init__(self, msg, param=None):
        super().__init__(msg)
        self.param = param


def undetermined(J, names=None):
    """(condition number, name of the least-determined parameter) of a
    Jacobian J, after scaling every column to unit norm: a rank test that
    depends only on the geometry of the poses, not on the size of the
    residuals (a large unmodelled effect inflates the residuals, never the
    condition of J)."""
    n = np.sqrt((J ** 2).sum(0))
    if not np.all(np.isfinite(J)) or np.any(n == 0):
        k = int(np.argmin(n)) if np.all(np.isfinite(n)) else 0
        return np.inf, (names[k] if names and k < len(names) else f"parameter {k}")
    _, sv, Vt = np.linalg.svd(J / n, full_matrices=False)
    cond = float((sv[0] / sv[-1]) ** 2) if sv[-1] > 0 else np.inf
    k = int(np.argmax(np.abs(Vt[-1])))
    return cond, (names[k] if names and k < len(names) else f"parameter {k}")


def _covariance(res, what: str, names=None):
    """(chi2, dof, s2, cond, covariance) of a least-squares result
    (chunked_lm's: R with R^T R = J^T J), the residuals scaled to unit
    variance; SingularFit (a CalibrationError) when `what` do not determine
    all parameters, naming the parameter the null direction loads most on
    (J's scaled singular values and vectors are R's: J = Q R)."""
    R = res.R
    dof = max(1, res.m - R.shape[1])
    chi2 = 2.0 * res.cost
    s2 = chi2 / dof
    JtJ = R.T @ R
    cond, worst = undetermined(R, names)
    if not np.isfinite(cond) or cond > SINGULAR_COND:
        raise SingularFit(f"joint: the {what} do not determine all parameters ({worst} is undetermined; "
                          f"singular fit)", worst)
    return chi2, dof, s2, cond, s2 * np.linalg.pinv(JtJ)


def _pose_jacobian(inc, azi, tf, F, dip, dec, G, h=1e-3):
    """d[g; f]/d(I, A, T) per row, (n, 6, 3), per degree."""
    base = np.concatenate(ref.body_vectors(inc, azi, tf, F, dip, dec, G), -1)
    cols = []
    for k in range(3):
        p = [np.asarray(inc, float).copy(), np.asarray(azi, float).copy(), np.asarray(tf, float).copy()]
        p[k] = p[k] + h
        cols.append((np.concatenate(ref.body_vectors(*p, F, dip, dec, G), -1) - base) / h)
    return np.stack(cols, -1)


def _whiteners(Ma, Mm, Jp, sa, sm, sp):
    n = Jp.shape[0]
    S = np.zeros((n, 6, 6))
    S[:, :3, :3] = sa * sa * (Ma @ Ma.T)
    S[:, 3:, 3:] = sm * sm * (Mm @ Mm.T)
    S += (sp * sp) * Jp @ np.swapaxes(Jp, -1, -2)
    L = np.linalg.cholesky(S)
    return np.linalg.inv(L)  # (n, 6, 6): whitened r = Linv @ r


def _unpack_pose(x):
    """x = [M_a (9), c_a = M_a b_a (3), M_m (9), c_m (3), (q_a (3), q_m (3)), dip]:
    25 entries for the linear model, 31 with the scale nonlinearity."""
    Ma, ca = x[0:9].reshape(3, 3), x[9:12]
    Mm, cm = x[12:21].reshape(3, 3), x[21:24]
    if len(x) == 31:
        return Ma, ca, Mm, cm, x[30], x[24:27], x[27:30]
    return Ma, ca, Mm, cm, x[24], np.zeros(3), np.zeros(3)


def _linearised(raw, q, S):
    """u = raw + q raw^2 / S per axis: the nonlinearity-corrected reading
    (q dimensionless, S = G or F)."""
    return raw + q * raw * raw / S


def _whiten(Linv, r):
    """r (n, 6) or a Jacobian (n, 6, p) whitened by per-row whiteners Linv
    (n, 6, 6), or by a covariance.ClusterWhitener (rows at one pose as one
    cluster)."""
    if hasattr(Linv, "apply"):
        return Linv.apply(r) if r.ndim == 2 else Linv.apply_jac(r)
    if r.ndim == 2:
        return np.einsum("nij,nj->ni", Linv, r).ravel()
    return np.einsum("nij,njk->nik", Linv, r).reshape(-1, r.shape[2])


def _raw_pose_residuals(x, acc, mag, poses, F, dec, G):
    Ma, ca, Mm, cm, dip, qa, qm = _unpack_pose(x)
    g, f = ref.body_vectors(*poses, F, dip, dec, G)
    return np.concatenate([_linearised(acc, qa, G) @ Ma.T - ca - g, _linearised(mag, qm, F) @ Mm.T - cm - f], -1)


def _pose_residuals(x, acc, mag, poses, F, dec, G, Linv):
    return _whiten(Linv, _raw_pose_residuals(x, acc, mag, poses, F, dec, G))


def _pose_jacobian_params(x, acc, mag, poses, F, dec, G, Linv):
    """Analytic Jacobian of _pose_residuals, (6n, 25) or (6n, 31)."""
    n, p = len(acc), len(x)
    Ma, _, Mm, _, dip, qa, qm = _unpack_pose(x)
    ua, um = _linearised(acc, qa, G), _linearised(mag, qm, F)
    Jr = np.zeros((n, 6, p))
    for i in range(3):
        Jr[:, i, 3 * i:3 * i + 3] = ua
        Jr[:, i, 9 + i] = -1.0
        Jr[:, 3 + i, 12 + 3 * i:12 + 3 * i + 3] = um
        Jr[:, 3 + i, 21 + i] = -1.0
    if p == 31:
        for j in range(3):
            Jr[:, :3, 24 + j] = Ma[:, j][None, :] * (acc[:, j] ** 2 / G)[:, None]
            Jr[:, 3:, 27 + j] = Mm[:, j][None, :] * (mag[:, j] ** 2 / F)[:, None]
    h = 1e-4
    _, f1 = ref.body_vectors(*poses, F, dip + h, dec, G)
    _, f0 = ref.body_vectors(*poses, F, dip - h, dec, G)
    Jr[:, 3:, p - 1] = -(f1 - f0) / (2 * h)
    return Jr if Linv is None else _whiten(Linv, Jr)


# --------------------------------------------------------------------------
# the firmware-representable calibration of a nonlinear probe
WORKING_INC_DEG = (0.0, 90.0)


def working_range(inc_deg=WORKING_INC_DEG, step_inc=10.0, step_azi=45.0, step_tf=45.0):
    """The orientations a best linear calibration is chosen for: inclination
    inc_deg[0]..inc_deg[1] every step_inc, every azimuth and toolface (every
    step_azi, step_tf) -- the borehole probe's working range, vertical to
    horizontal.  Not the acceptance grid's points (those are what it is
    checked on)."""
    I, A, T = np.meshgrid(np.arange(inc_deg[0], inc_deg[1] + 1e-9, step_inc), np.arange(0.0, 360.0, step_azi),
                          np.arange(0.0, 360.0, step_tf), indexing="ij")
    return I.ravel(), A.ravel(), T.ravel()


_WR_CACHE = {}


def _body_vectors(poses, F, dip, dec, G):
    """ref.body_vectors with the pose matrices cached (the working range is
    evaluated many times for the Jacobian)."""
    key = tuple(np.asarray(p, float).tobytes() for p in poses)
    C = _WR_CACHE.get(key)
    if C is None:
        if len(_WR_CACHE) > 8:
            _WR_CACHE.clear()
        C = _WR_CACHE[key] = ref.pose_matrix(*poses)
    return C @ ref.gravity_ned(G), C @ ref.field_ned(F, dip, dec)


def nonlinear_readings(x, poses, F, dec, G):
    """Noise-free raw readings of the probe described by the nonlinear model
    x (31-layout) at `poses`: solves M (raw + q raw^2 / S) - c = true per
    axis (the root near raw = u)."""
    Ma, ca, Mm, cm, dip, qa, qm = _unpack_pose(x)
    g, f = _body_vectors(poses, F, dip, dec, G)
    out = []
    for M, c, q, S, v in ((Ma, ca, qa, G, g), (Mm, cm, qm, F, f)):
        u = np.linalg.solve(M, (v + c).T).T
        d = np.sqrt(np.maximum(1.0 + 4.0 * q * u / S, 0.0))
        out.append(2.0 * u / (1.0 + d))  # the small root of q/S raw^2 + raw - u = 0
    return out[0], out[1]


def best_linear(x, F, dec, G, poses=None):
    """The linear calibration (the firmware's corrected = M (raw - b)) that
    best represents the nonlinear model x over the working range: per triad,
    least squares of M raw - M b against the true vector at the working
    range's orientations, with the probe's readings predicted by x.
    Returns the 24-vector (M_a, b_a, M_m, b_m)."""
    poses = working_range() if poses is None else poses
    Ma, ca, Mm, cm, dip, qa, qm = _unpack_pose(x)
    g, f = _body_vectors(poses, F, dip, dec, G)
    acc, mag = nonlinear_readings(x, poses, F, dec, G)
    out = []
    for raw, true in ((acc, g), (mag, f)):
        X = np.column_stack([raw, -np.ones(len(raw))])
        sol, *_ = np.linalg.lstsq(X, true, rcond=None)
        M = sol[:3].T
        out += [M.ravel(), np.linalg.solve(M, sol[3])]
    return np.concatenate(out)


def nonlinear_block(x, cov_nl, lin, F, dip, dec, G) -> dict:
    """info["nonlinear"] of a fit of the nonlinear model: x in joint's layout
    (31: M_a, M_a b_a, M_m, M_m b_m, q_a, q_m, dip, as _unpack_pose reads it),
    cov_nl the covariance of (M, b, q[, dip]) in that order (b, not M b),
    lin the best linear calibration (best_linear).  With what the linear
    model costs on this probe, noise-free, over the working range."""
    Ma, ca, Mm, cm, _, qa, qm = _unpack_pose(x)
    ba, bm = np.linalg.solve(Ma, ca), np.linalg.solve(Mm, cm)
    wr = working_range()
    acc_w, mag_w = nonlinear_readings(x, wr, F, dec, G)
    gw, fw = ref.body_vectors(*wr, F, dip, dec, G)
    La = lin[0:9].reshape(3, 3)
    Lm = lin[12:21].reshape(3, 3)
    att = ref.attitude((acc_w - lin[9:12]) @ La.T, (mag_w - lin[21:24]) @ Lm.T)
    tru = ref.attitude(gw, fw)
    da = ref.angle_diff(att["azi"], tru["azi"])[wr[0] >= 2.0]  # both magnetic (wr[1] is true)
    return {
        "model": "corrected = M (raw + q*raw^2/S - b), S = G (g) or F (nT); the CAL.json "
                 "coefficients are the linear calibration that best represents it over the working range",
        "working_range": f"inclination {WORKING_INC_DEG[0]:g}-{WORKING_INC_DEG[1]:g} deg every 10, "
                         "azimuth and toolface every 45 deg",
        "acc_q_per_g": (qa / G).tolist(), "mag_q_per_nT": (qm / F).tolist(),
        "acc_q_sigma_per_g": (np.sqrt(np.diag(cov_nl)[24:27]) / G).tolist(),
        "mag_q_sigma_per_nT": (np.sqrt(np.diag(cov_nl)[27:30]) / F).tolist(),
        "model_acc_m": Ma.tolist(), "model_acc_b": ba.tolist(), "model_mag_m": Mm.tolist(),
        "model_mag_b": bm.tolist(),
        "linear_representation_azi_rms_deg": float(np.sqrt(np.mean(da ** 2))),
        "linear_representation_inc_rms_deg": float(np.sqrt(np.mean((att["inc"] - tru["inc"]) ** 2))),
        "covariance": cov_nl}


def best_linear_jacobian(x, F, dec, G, poses=None):
    """d best_linear / d x (24 x 31) by central differences."""
    poses = working_range() if poses is None else poses
    steps = np.full(len(x), 1e-7)
    steps[9:12] = 1e-7  # g
    steps[21:24] = 1e-3  # nT
    steps[24:30] = 1e-6  # q, dimensionless
    steps[30] = 1e-5  # dip, deg
    J = np.zeros((24, len(x)))
    for k in range(len(x)):
        xp, xm = x.copy(), x.copy()
        xp[k] += steps[k]
        xm[k] -= steps[k]
        J[:, k] = (best_linear(xp, F, dec, G, poses) - best_linear(xm, F, dec, G, poses)) / (2 * steps[k])
    return J


def _linear_start(acc, mag, g, f):
    out = []
    for raw, true in ((acc, g), (mag, f)):
        X = np.column_stack([raw, -np.ones(len(raw))])
        sol, *_ = np.linalg.lstsq(X, true, rcond=None)
        out += [sol[:3].T.ravel(), sol[3]]
    return np.concatenate(out)


def _least_squares(fun, jac, x, acc, mag, poses, FdG, whiten):
    """The least-squares fit of fun (jac) from x over the rows, whitened by
    per-row whiteners (n, 6, 6) or a covariance.ClusterWhitener, by
    chunked_lm: the rows a chunk at a time (whole clusters), so that the
    6n x P Jacobian is never held (least_squares' lm held it four times,
    and whitening it by clusters made as many copies again: the peak of a
    long run's calibration).  Returns chunked_lm's result (x, cost, m, R)."""
    from . import chunked_lm

    n = len(acc)
    if hasattr(whiten, "part"):
        chunks = chunked_lm.row_chunks(n, 6, whiten.starts())
        part = whiten.part
    else:
        chunks = chunked_lm.row_chunks(n, 6)
        part = whiten.__getitem__

    def args(c):
        return (acc[c], mag[c], tuple(p[c] for p in poses), *FdG, part(c))

    return chunked_lm.solve(lambda xx, c: fun(xx, *args(c)), chunks, x, jac=lambda xx, c: jac(xx, *args(c)))


def _larger_covariance(C, B, names):
    """The rows' covariance C of a fit raised, triad by triad, to what the
    blocks' covariance B shows: each group of coefficients (names: "acc
    ...", "mag ...", the rest, e.g. the dip) scaled by the mean of B's
    variance ratios to C over its directions (tr(C_g^-1 B_g) / p_g: scale
    free, the units differ, g and nT) where that exceeds 1.  A mean, not
    direction by direction: with a few dozen blocks for 25-31 coefficients
    B's own eigenvalues spread widely, and the largest ratio of a run's
    white rows (142 poses of an emulated turntable run in 36 blocks of 4)
    read 3.0.  Returns (covariance, {group: ratio})."""
    groups = {}
    for i, nm in enumerate(names[:len(C)]):
        groups.setdefault(nm.split()[0] if nm.split()[0] in ("acc", "mag") else "other", []).append(i)
    d = np.ones(len(C))
    ratios = {}
    for g, idx in groups.items():
        Cg, Bg = C[np.ix_(idx, idx)], B[np.ix_(idx, idx)]
        r = float(np.trace(np.linalg.solve(Cg, Bg)) / len(idx))
        ratios[g] = r
        d[idx] = np.sqrt(max(r, 1.0))
    return C * np.outer(d, d), ratios


def _time_blocks_covariance(res, W, fun, jac, acc, mag, poses, FdG, ds, keep):
    """A log read while moving, each row its own pose (a sensor turned by
    hand under a motion-capture reference): the hand's acceleration and the
    reference's slow errors err alike on neighbouring rows, which the noise
    model (independent rows, calib/covariance.py) does not hold.  The
    blocks' covariance (triad.time_blocks, block_covariance) of the fit as
    whitened, its rows' scores summed over blocks of consecutive rows as
    long as the whitened residual's own correlation: (covariance, {"rows",
    "count"}), or None where a pose holds several rows (the clusters
    count those), the rows are not in time order, or the residual is close
    to white.  (BROAD's trial 02, 2 577 rows at 286 Hz: its two halves, in
    alternate blocks of 100 rows, differed by 1.1-2.0 of the rows'
    standard errors, RMS per group of coefficients.)"""
    from . import chunked_lm

    if not getattr(W, "single", False):
        return None
    t = ds.columns.get("t_s")
    if t is not None and np.any(np.diff(np.asarray(t, float)[keep]) < 0):
        return None
    n, chunks = len(acc), chunked_lm.row_chunks(len(acc), 6, W.starts())
    scores, resid = np.zeros((n, len(res.x))), np.zeros((n, 6))
    for c in chunks:
        a = (acc[c], mag[c], tuple(p[c] for p in poses), *FdG, W.part(c))
        r, J = fun(res.x, *a), jac(res.x, *a)
        resid[c] = r.reshape(-1, 6)
        scores[c] = (J * r[:, None]).reshape(-1, 6, J.shape[1]).sum(1)
    lab = triad.time_blocks(resid)
    if lab is None:
        return None
    cov = triad.block_covariance(None, scores, lab, A=res.jtj)
    return None if cov is None else (cov, {"rows": int(np.bincount(lab).max()), "count": int(lab.max()) + 1})


def _refit_with_components(comps, x, fun, jac, acc, mag, poses, FdG, fix_dip, dip0, labels):
    """The final Gauss-Newton pass whitened by fitted noise components
    (calib/covariance.py): (result, whitener)."""
    from . import covariance

    xx = np.concatenate([x, [dip0]]) if fix_dip else x
    Ma, _, Mm, _, dip, _, _ = _unpack_pose(xx)
    Jp = _pose_jacobian(*poses, *FdG[:1], dip, *FdG[1:])
    # the clusters' means alone: a row's deviation from its pose's mean is the readings' noise, which as a
    # regressor pulls M towards zero (covariance.component_whitener)
    W = covariance.component_whitener(comps, Ma, Mm, Jp, labels, means_only=True)
    del Jp
    return _least_squares(fun, jac, x, acc, mag, poses, FdG, W), W


def _refit_fitted_noise(x, fun, jac, ds, keep, poses, FdG, fix_dip, dip0, names, cov_lin, noise_info):
    """Fit the run's own noise (per channel, the pose error per turntable
    axis, and a cluster effect where several rows share a pose: REML,
    calib/covariance.py), refit whitened by it, and take the covariance
    from that fit.  Returns (x, covariance, info): on a failure the nominal
    fit stands, with a note."""
    from . import covariance

    F, dec, G = FdG
    acc, mag = ds.acc[keep], ds.mag[keep]
    pk = tuple(p[keep] for p in poses)
    labels = covariance.cluster_labels(ds)[keep]
    try:
        for _ in range(2):  # the components from the current fit's residuals, then the fit whitened by them
            xx = np.concatenate([x, [dip0]]) if fix_dip else x
            Ma, _, Mm, _, dip, _, _ = _unpack_pose(xx)
            Bi = np.linalg.inv(covariance.block_diag2(Ma, Mm))
            r = _raw_pose_residuals(xx, acc, mag, pk, F, dec, G)
            Jp = _pose_jacobian(*pk, F, dip, dec, G)
            X = _pose_jacobian_params(xx, acc, mag, pk, F, dec, G, None)
            X = X[:, :, :-1] if fix_dip else X
            X = np.einsum("ij,njk->nik", Bi, X)  # (the Jacobian through Bi replaces it: n x 6 x P each)
            comps = covariance.fit_components(r @ Bi.T, labels, Jpose=np.einsum("ij,njk->nik", Bi, Jp),
                                              X=X,
                                              channels=covariance.CHANNELS_6)
            res, W = _refit_with_components(comps, x, fun, jac, acc, mag, pk, FdG, fix_dip, dip0, labels)
            x = res.x
        cov = np.linalg.pinv(res.jtj)
        if not np.all(np.isfinite(cov)):
            raise np.linalg.LinAlgError("covariance not finite")
        blk = _time_blocks_covariance(res, W, fun, jac, acc, mag, pk, FdG, ds, keep)
        blocks = None
        if blk is not None:
            cov, ratios = _larger_covariance(cov, blk[0], names)
            if max(r for g, r in ratios.items() if g != "other") > 1.0:
                blocks = {**blk[1], "var_ratio": {g: r for g, r in ratios.items() if g != "other"}}
    except (np.linalg.LinAlgError, ValueError) as e:
        noise_info["noise_note"] = f"the run's own noise could not be fitted ({e}); nominal noise scaled by s^2"
        return x, cov_lin, noise_info
    chi2 = 2.0 * res.cost
    noise_info = {**{k: v for k, v in noise_info.items() if k != "blocks"}, "noise": comps.to_dict(),
                  **({"blocks": blocks} if blocks else {}), "noise_components": comps,
                  "chi2_fitted_noise": chi2}
    return x, cov, noise_info


def _outliers_under_fitted_noise(x, ds, poses, FdG, fix_dip, dip0, noise_info):
    """The rows kept by the outlier test under the fitted noise components
    (each row's marginal covariance: sensor noise, cluster effect, pose
    error through the row's own pose Jacobian): its whitened squared norm
    within robust_threshold's point (6 degrees of freedom).  None when the
    noise was not fitted."""
    from . import covariance

    comps = noise_info.get("noise_components")
    if comps is None:
        return None
    F, dec, G = FdG
    xx = np.concatenate([x, [dip0]]) if fix_dip else x
    Ma, _, Mm, _, dip, _, _ = _unpack_pose(xx)
    r = _raw_pose_residuals(xx, ds.acc, ds.mag, poses, F, dec, G)
    Jp = _pose_jacobian(*poses, F, dip, dec, G)
    W = covariance.component_whitener(comps, Ma, Mm, Jp, covariance.cluster_labels(ds))
    d2 = W.row_d2(r)
    return d2 <= robust_threshold(d2, 6)[0]


def _fit_poses(ds, w, sa, sm, sp, fix_dip, nonlinear=False, noise="fit"):
    poses = tuple(ds.columns[c] for c in ("inc_deg", "azi_deg", "tf_deg"))
    F, dec, G = w["field_nT"], w["declination_deg"], w["gravity_g"]
    dip0 = w["dip_deg"] if w["dip_deg"] is not None else None
    if dip0 is None:
        # a coarse search: the dip that best fits a linear calibration
        best = None
        for d in np.arange(-85.0, 86.0, 5.0):
            g, f = ref.body_vectors(*poses, F, d, dec, G)
            x = _linear_start(ds.acc, ds.mag, g, f)
            Mm, cm = x[12:21].reshape(3, 3), x[21:24]
            cost = np.sum((ds.mag @ Mm.T - cm - f) ** 2)
            if best is None or cost < best[0]:
                best = (cost, d)
        dip0 = best[1]
    g, f = ref.body_vectors(*poses, F, dip0, dec, G)
    try:
        triad.poses_span(g, "the accelerometer's 12 parameters")
        triad.poses_span(f, "the magnetometer's 12 parameters")
    except CalibrationError as e:
        raise SingularFit(str(e)) from e
    x0 = np.concatenate([_linear_start(ds.acc, ds.mag, g, f), np.zeros(6 if nonlinear else 0), [dip0]])
    P = len(x0)
    keep = np.ones(len(ds), bool)
    def fun(xf, *args):
        xx = np.concatenate([xf, [dip0]]) if fix_dip else xf
        return _pose_residuals(xx, *args)

    def jac(xf, *args):
        xx = np.concatenate([xf, [dip0]]) if fix_dip else xf
        J = _pose_jacobian_params(xx, *args)
        return J[:, :P - 1] if fix_dip else J
    x = x0[:P - 1] if fix_dip else x0
    for loss in ("soft_l1", "linear"):
        xx = np.concatenate([x, [dip0]]) if fix_dip else x
        Ma, _, Mm, _, dip_now, _, _ = _unpack_pose(xx)
        Jp = _pose_jacobian(*poses, F, dip_now, dec, G)
        Linv = _whiteners(Ma, Mm, Jp, sa, sm, sp)
        args = (ds.acc[keep], ds.mag[keep], tuple(p[keep] for p in poses), F, dec, G, Linv[keep])
        if loss == "soft_l1":
            # the soft-L1 scale follows the residuals' own robust size, so
            # that a large effect the model lacks is not read as every row
            # being an outlier
            r0 = fun(x, *args).reshape(-1, 6)
            f_scale = 3.0 * np.sqrt(robust_threshold((r0 ** 2).sum(-1), 6)[1])
        else:
            f_scale = 3.0
        if loss == "linear":
            res = _least_squares(fun, jac, x, *args[:3], args[3:6], args[6])
        else:
            res = optimize.least_squares(fun, x, jac=jac, args=args, loss=loss, f_scale=f_scale, method="trf",
                                         x_scale="jac")
        x = res.x
        if loss == "soft_l1":
            rall = fun(x, ds.acc, ds.mag, poses, F, dec, G, Linv)
            d2 = (rall.reshape(-1, 6) ** 2).sum(-1)
            keep = d2 <= robust_threshold(d2, 6)[0]
            if keep.sum() < MIN_ROWS_POSES:
                raise CalibrationError("joint: too many readings rejected as outliers to fit")
    names = PARAM_NAMES_POSE[:24] + (PARAM_NAMES_POSE[24:] if nonlinear else []) + ([] if fix_dip else ["dip"])
    chi2, dof, s2, cond, cov_lin = _covariance(res, "poses", names)
    noise_info = {"sigmas": {"acc_g": sa, "mag_nT": sm, "pose_deg": sp}}
    if noise == "fit":
        # then the outlier rows again, under the run's own noise, and the noise refitted where they change: the
        # test above whitened by the nominal noise, whose ratios (0.15 mg, 5 nT, 0.05 deg) a run need not share; a
        # row's pose error then weighs differently from row to row, and clean rows fell beyond the chi-square
        # point (4-8 % of a Gaussian run at 1 mg, 60 nT, 0.02 deg)
        def refit(rows):
            return _refit_fitted_noise(x, fun, jac, ds, rows, poses, (F, dec, G), fix_dip, dip0, names, cov_lin,
                                       noise_info)
        fitted = refit(keep)
        keep2 = _outliers_under_fitted_noise(fitted[0], ds, poses, (F, dec, G), fix_dip, dip0, fitted[2])
        if keep2 is not None and not np.array_equal(keep2, keep) and keep2.sum() >= MIN_ROWS_POSES:
            keep = keep2
            fitted = refit(keep)
        x, cov_lin, noise_info = fitted
    x = np.concatenate([x, [dip0]]) if fix_dip else x
    Ma, ca, Mm, cm, dip, qa, qm = _unpack_pose(x)
    ba = np.linalg.solve(Ma, ca)
    bm = np.linalg.solve(Mm, cm)
    # covariance of (M, b) from that of (M, c = M b): b = M^-1 c
    T = np.eye(len(x) - (1 if fix_dip else 0))
    common.fill_bias_jacobian(x, T)
    cov = T @ cov_lin @ T.T
    outliers = np.flatnonzero(~keep)
    extra = {}
    if nonlinear:
        # the firmware can only hold a linear calibration: the one that best
        # represents the fitted (nonlinear) probe over the working range,
        # with its covariance through that map (dip known when fixed)
        Jb = best_linear_jacobian(x, F, dec, G)
        Jb = Jb[:, :P - 1] if fix_dip else Jb
        lin = best_linear(x, F, dec, G)
        cov_nl, cov = cov, Jb @ cov_lin @ Jb.T
        if not fix_dip:  # keep the dip's variance and covariances in the 25th row/column
            Jx = np.zeros((25, P))
            Jx[:24] = Jb
            Jx[24, P - 1] = 1.0
            cov = Jx @ cov_lin @ Jx.T
        extra = {"nonlinear": nonlinear_block(x, cov_nl, lin, F, dip, dec, G)}
        Ma, ba = lin[0:9].reshape(3, 3), lin[9:12]
        Mm, bm = lin[12:21].reshape(3, 3), lin[21:24]
    return (Ma, ba, Mm, bm, float(dip)), cov, {**extra,
        "mode": "poses", "s2": s2, "chi2": chi2, "dof": dof, "outliers": outliers.tolist(),
        "normal_matrix_cond": cond, "dip_fitted": not fix_dip,
        "dip_sigma_deg": None if fix_dip else float(np.sqrt(cov[24, 24])), **noise_info}


def fisher_covariance(cal, dip, F, dec, G, poses, sa=SIGMA_ACC, sm=SIGMA_MAG, sp=SIGMA_POSE_DEG):
    """Cramer-Rao bound of the 24 coefficients (M_a, b_a, M_m, b_m; dip
    known) for a turntable run at `poses` (tuple of inc, azi, tf arrays),
    under the joint model's noise (sensor white noise, turntable readout
    error): the inverse Fisher information at the true coefficients `cal`."""
    Ma, ba = np.asarray(cal.acc_m), np.asarray(cal.acc_b)
    Mm, bm = np.asarray(cal.mag_m), np.asarray(cal.mag_b)
    g, f = ref.body_vectors(*poses, F, dip, dec, G)
    acc = g @ np.linalg.inv(Ma).T + ba  # noise-free readings of the true probe
    mag = f @ np.linalg.inv(Mm).T + bm
    Jp = _pose_jacobian(*poses, F, dip, dec, G)
    Linv = _whiteners(Ma, Mm, Jp, sa, sm, sp)
    # residual r = [Ma (acc - ba) - g; Mm (mag - bm) - f] in terms of (M, b)
    n = len(acc)
    J = np.zeros((n, 6, 24))
    for off, raw, M, b, sl in ((0, acc, Ma, ba, slice(0, 3)), (12, mag, Mm, bm, slice(3, 6))):
        d = raw - b
        for i in range(3):
            for j in range(3):
                J[:, sl.start + i, off + 3 * i + j] = d[:, j]
        J[:, sl, off + 9:off + 12] = -M
    Jw = np.einsum("nij,njk->nik", Linv, J).reshape(-1, 24)
    return np.linalg.inv(Jw.T @ Jw)


# --------------------------------------------------------------------------
# without poses
def _sym(v):
    a, b, c, d, e, f = v
    return np.array([[a, b, c], [b, d, e], [c, e, f]])


def _inv_residuals(x, acc, mag, G, F, sa, sm, R0):
    Ma = _sym(x[0:6]) @ R0
    ba = x[6:9]
    Mm = x[9:18].reshape(3, 3)
    bm = x[18:21]
    dip = x[21]
    g = (acc - ba) @ Ma.T
    b = (mag - bm) @ Mm.T
    ng = np.linalg.norm(g, axis=1)
    nb = np.linalg.norm(b, axis=1)
    sdip = (g * b).sum(1) / (ng * nb)
    sd = np.cos(np.radians(dip)) * np.hypot(sa / G, sm / F)
    return np.concatenate([(ng - G) / sa, (nb - F) / sm, (sdip - np.sin(np.radians(dip))) / sd])


def _polar_rotation(M):
    U, _, Vt = np.linalg.svd(np.asarray(M, float))
    R = U @ Vt
    return R if np.linalg.det(R) > 0 else U @ np.diag([1, 1, -1]) @ Vt


def _fit_invariants(ds, w, sa, sm, fix_dip, prior=None, mount_tolerance_deg=None, mag_start=None):
    """Without poses: triad by triad (calib.pose_free): the accelerometer's
    ellipsoid fit alone, the magnetometer's, then its rotation against the
    accelerometer and the dip from the dip constraint, each with its own
    noise.  Then the gauge: the common rotation from the prior, or the
    accelerometer's axes with the mounting tolerance in the covariance."""
    from . import field, pose_free

    if len(ds) < pose_free.MIN_ROWS:
        raise DataError(f"joint without poses needs >= {pose_free.MIN_ROWS} readings in varied orientations; "
                        f"the data have {len(ds)}")
    from inclino import holds

    from . import common, triad

    # a step-and-hold log whose holds determine both ellipsoids: the holds are fitted, the rows read while
    # turning between them left out (their acceleration is the motion's), each hold counted once in the
    # covariance (calib.single does the same for one triad)
    from . import motion

    hs = holds.determining(ds)
    moved = None
    if hs is None:
        # a log read mostly while moving whose holds determine both ellipsoids and whose moving rows carry the
        # hand's acceleration (calib.motion): the holds alone, as for a step-and-hold log
        mh = motion.holds_fit(ds, ("acc", "mag"), w["gravity_g"], sa)
        if mh is not None:
            hs, moved = mh[:2], mh[2]
    fitted = np.arange(len(ds)) if hs is None else np.flatnonzero(hs[0] >= 0)
    dsf = ds if hs is None else common.subset(ds, fitted)
    # holds that do not determine the ellipsoids: every row fitted, but each hold's rows share its error
    hl = hs[0] if hs is not None else (holds.correlated(ds) or (None,))[0]
    try:
        (Ma, ba, Mm, bm, dip), cov, st = pose_free.fit(dsf, w, sa, sm, fix_dip, mag_start=mag_start,
                                                       labels=None if hl is None else hl[fitted])
    except (DataError, CalibrationError) as e:
        # the accelerometer's ellipsoid of a log read mostly while moving, though its orientations span the sphere,
        # or holds that leave a triad's ellipsoid free
        cause = motion.refusal(ds, e, hs, None if hl is None else (hl, int(hl.max()) + 1))
        if cause is None:
            raise
        raise type(e)(cause) from e
    if fix_dip:
        cov = cov[:24, :24]
    keep = st["keep_acc"] & st["keep_mag"]

    def full(mask):
        out = np.zeros(len(ds), bool)
        out[fitted] = mask
        return out
    info = {"mode": "invariants", "s2": st["s2"], "chi2": st["chi2"], "dof": st["dof"],
            "outliers": fitted[~keep].tolist(), "normal_matrix_cond": st["normal_matrix_cond"],
            "dip_fitted": not fix_dip, "dip_sigma_deg": st["dip_sigma_deg"],
            "sigmas": {"acc_g": sa, "mag_nT": sm}, "unobservable": field.UNOBSERVABLE,
            "triad_noise": st["noise"], "s2_by_triad": st["s2_by_triad"], "acc_misfit": full(st["acc_misfit"]),
            "mag_misfit": full(st["mag_misfit"]),
            "fit": "triad by triad: each triad's ellipsoid alone, then the magnetometer's rotation and the dip"}
    if hs is not None:
        info["moving"] = np.flatnonzero(hs[0] < 0).tolist()
        info["holds"] = hs[1]
    if st["refits"]:
        info["refits"] = st["refits"]  # ellipsoid fits that curve in the noise: their covariance from refits
    if st["blocks"] is not None:
        # no hold, and rows whose errors neighbouring rows share (a log read while moving): counted in blocks
        mc = st.get("mag_covariance")
        info["blocks"] = {**st["blocks"], "dip_var_ratio": mc["dip_var_ratio"] if isinstance(mc, dict) else None}
    if moved is not None:
        info["moving_log"] = moved
    else:
        info["motion"] = motion.figures(ds)  # a log read mostly while moving, fitted on every row (or None)
    if hl is not None:
        # each triad's block scaled by how much more the holds' means scatter than the rows' independence
        # claims: the hold-level ellipsoid fit's covariance against the row-level one, on the same rows
        lab = hl[fitted]
        scale = []
        for t, R, sig, kt in (("acc", w["gravity_g"], sa, st["keep_acc"]), ("mag", w["field_nT"], sm, keep)):
            if t == "mag" and isinstance(st.get("mag_covariance"), dict):
                scale.append(None)  # the magnetometer's block (and the dip) already counts each hold once
                continue
            raw = getattr(dsf, t)
            try:
                _, _, c_rows, _ = triad.fit_sphere(raw[kt], R, sig, min_rows=12)
            except (DataError, CalibrationError):
                scale.append(1.0)
                continue
            hc = triad.hold_covariance(raw, lab, kt, R, sig)
            scale.append(max(1.0, float(np.trace(hc[0]) / np.trace(c_rows))) if hc is not None else 1.0)
        # the magnetometer's own block scaled (unless it counts the holds itself), then the accelerometer's
        # scaled error carried into it again
        own = st["cov_mag_own"][:cov.shape[0] - 12, :cov.shape[0] - 12] * (scale[1] or 1.0)
        cov = cov.copy()
        cov[0:12, 0:12] *= scale[0]
        cov = pose_free.propagate_acc(cov, st["acc_to_mag"], own)
        info["hold_scale"] = {"acc": scale[0], "mag": scale[1]}
        if scale[1] is None:
            info["hold_dip_var_ratio"] = st["mag_covariance"]["dip_var_ratio"]
    if not fix_dip:  # the dip is the magnetometer block's: its sigma as the covariance has it
        info["dip_sigma_deg"] = float(np.sqrt(cov[24, 24]))
    if prior is not None:
        Q = field.align_to_prior(Ma, Mm, prior)
        Ma, Mm = Q @ Ma, Q @ Mm
        Tq = np.eye(cov.shape[0])
        Tq[0:9, 0:9] = Tq[12:21, 12:21] = np.kron(Q, np.eye(3))
        cov = Tq @ cov @ Tq.T
        sig_rot, src = field.prior_rotation_sigma_rad(prior)
        info["gauge"] = ("no poses: the common rotation is the prior calibration's (of the calibrations the "
                         "invariants allow, the one closest to the prior)")
        info["prior_rotation_change_deg"] = float(np.degrees(np.arccos(np.clip((np.trace(Q) - 1) / 2, -1, 1))))
    else:
        tol = field.DEFAULT_MOUNT_TOLERANCE_DEG if mount_tolerance_deg is None else float(mount_tolerance_deg)
        sig_rot, src = np.full(3, np.radians(tol)), f"the stated mounting tolerance {tol:g} deg (1 sigma per axis)"
        info["gauge"] = "no poses, no prior: the body frame is the accelerometer's axes (M_a symmetric)"
        info["mount_tolerance_deg"] = tol
    info["fit_covariance"] = cov[:24, :24].copy()  # without the unobservable rotation
    cov = cov.copy()
    cov[:24, :24] += field.rotation_cov(Ma, Mm, sig_rot)
    info["rotation_sigma_deg"] = np.degrees(sig_rot).tolist()
    info["rotation_sigma_source"] = src
    return (Ma, ba, Mm, bm, dip), cov, info


def fit(ds: RawDataset, use_poses: bool | None = None, sigma_acc: float | None = None,
        sigma_mag: float | None = None, sigma_pose_deg: float = SIGMA_POSE_DEG, fix_dip: bool = False,
        prior=None, nonlinear: bool | None = None, mount_tolerance_deg: float | None = None,
        accept_mount_tolerance: bool = False, mag_start=None, noise: str = "fit", **_):
    """prior: a Calibration whose body frame (accelerometer rotation) a
    fit without poses keeps; without it the accelerometer's axes are the
    body frame.  nonlinear (default: with poses): also fit each axis'
    second-order scale term as a nuisance parameter, then return the linear
    calibration that best represents the fitted probe over the working
    range (info["nonlinear"] holds the model); False: the linear model.
    Without poses and without a prior the covariance includes the
    unobservable common rotation with mount_tolerance_deg (1 sigma per axis,
    default field.DEFAULT_MOUNT_TOLERANCE_DEG); accept_mount_tolerance
    records that the user accepts it (the verdict then judges the fit's own
    uncertainty; see calib/field.py and report._verdict).
    noise (with poses): "fit" (default) fits the run's own noise -- per
    channel, the pose error per turntable axis, a cluster effect where rows
    share a pose (calib/covariance.py) -- after the fit with the nominal
    sigmas, refits whitened by it and takes the covariance from that fit
    (info["noise"]); "nominal": the sigmas given, scaled by s^2.
    sigma_acc, sigma_mag: the noise of one reading assumed; default:
    without poses the one the dataset header declares (each triad is fitted
    alone, its covariance scaled by its s^2 against it: the declared noise
    changes what s^2 is against, not the figures), else the nominal
    SIGMA_ACC, SIGMA_MAG; with poses the nominal (they weigh the triads
    against each other in the first pass, whose outliers the run's own
    noise is then fitted without; common.assumed_noise); info["assumed_noise"].
    The temperature terms (--temperature-terms) are added by calib.fit
    (inclino.calib.thermal)."""
    w = common.world_of(ds)
    if use_poses is None:
        use_poses = ds.has_pose
    an = common.assumed_noise(ds, sigma_acc, sigma_mag, declared=not use_poses)
    sigma_acc, sigma_mag = an["acc_g"], an["mag_nT"]
    if use_poses:
        common.need_poses(ds, "joint with poses")
        if len(ds) < MIN_ROWS_POSES:
            raise DataError(f"joint needs >= {MIN_ROWS_POSES} readings; the data have {len(ds)}")
        if fix_dip and w["dip_deg"] is None:
            raise DataError("joint --fix-dip needs a '# dip_deg=...' header line")
        if noise not in ("fit", "nominal"):
            raise DataError(f"joint: noise must be 'fit' or 'nominal', not {noise!r}")
        args = (ds, w, sigma_acc, sigma_mag, sigma_pose_deg, fix_dip)
        if nonlinear is None:
            # the second-order terms only when the poses determine them: a run
            # that leaves them poorly determined (e.g. Guo's two rotations at one
            # azimuth) would trade a small bias for a large variance
            from .sensitivity import predicted_attitude_rms
            fits, errors = {}, []
            for nl in (True, False):
                try:
                    r = _fit_poses(*args, nl, noise)
                except CalibrationError as e:
                    errors.append(e)
                    continue
                (Ma, ba, Mm, bm, dip), cov, _ = r
                c = common.make_cal(Ma, ba, Mm, bm, "joint", ds)
                fits[nl] = (r, predicted_attitude_rms(c, cov[:24, :24], w, dip)[0])
            if not fits:
                raise errors[-1]  # the linear model's reason (singular: it names the parameter)
            use_nl = True in fits and (False not in fits or fits[True][1] <= NONLINEAR_MAX_SIGMA_RATIO
                                       * fits[False][1])
            (Ma, ba, Mm, bm, dip), cov, info = fits[use_nl][0]
            if not use_nl and True in fits:
                info["notes_nonlinear"] = (f"scale nonlinearity not fitted: with it the predicted azimuth 1-sigma "
                                           f"would be {fits[True][1]:.3g} deg against {fits[False][1]:.3g} "
                                           f"(the poses do not determine it)")
        else:
            (Ma, ba, Mm, bm, dip), cov, info = _fit_poses(*args, bool(nonlinear), noise)
    else:
        if nonlinear:
            raise DataError("joint: the scale nonlinearity is fitted only with turntable poses")
        (Ma, ba, Mm, bm, dip), cov, info = _fit_invariants(ds, w, sigma_acc, sigma_mag, fix_dip, prior,
                                                           mount_tolerance_deg, mag_start)
        info["prior"] = prior is not None
        info["prior_calibration"] = prior  # for the report's prediction (not written anywhere)
        info["accept_mount_tolerance"] = bool(accept_mount_tolerance)
    prior_notes = []
    if prior is not None and use_poses:
        prior_notes.append("the prior calibration was not used: the poses determine every coefficient")
    if prior is not None and prior.probe_serial and ds.meta.get("probe_serial") and \
            str(prior.probe_serial) != str(ds.meta.get("probe_serial")):
        prior_notes.append(f"the prior is of probe {prior.probe_serial}, the data of probe {ds.meta.get('probe_serial')}")
    cal = common.make_cal(Ma, ba, Mm, bm, "joint", ds)
    info["world"] = w
    info["assumed_noise"] = an
    info.update({"rows_used": np.setdiff1d(np.arange(len(ds)), info["outliers"] + info.get("moving", [])),
                 "covariance": cov[:24, :24],
                 "dip_deg": dip})
    # with the run's own noise fitted (REML: info["noise"]) s^2 is the first pass's, under the nominal noise, and
    # the covariance is not scaled by it: a sensor noisier than the nominal (0.3 mg, 25 nT against 0.15 mg, 5 nT,
    # the model exact) was told "an effect the 12-parameter model lacks ... the covariance is scaled by s^2"
    own = info.get("noise") is not None and info.get("sigmas")
    info["notes"] = [f"mode {info['mode']}; s^2 = {info['s2']:.3g} (chi^2/dof"
                     + (" under the nominal noise, before the run's own was fitted)" if own else
                        "; 1 when the noise model is right)")]
    if info["s2"] > 2.0 and info["s2"] > 1.0 + 5.0 * np.sqrt(2.0 / max(info["dof"], 1)):
        if own:
            sg = info["sigmas"]
            info["notes"].append(
                f"the residuals are {np.sqrt(info['s2']):.2g}x what the nominal noise expects ({1e3 * sg['acc_g']:.3g} "
                f"mg, {sg['mag_nT']:.3g} nT, pose {sg['pose_deg']:.3g} deg): the covariance and the predictions use "
                f"the run's own noise instead ({info['noise']['method']}, the uncertainty line's figures); noisier "
                f"sensors than the nominal, or an effect the 12-parameter model lacks (a turntable offset, drift, "
                f"temperature), which `inclino diagnose` names")
        else:
            info["notes"].append(f"the residuals are {np.sqrt(info['s2']):.2g}x what the noise model expects: an "
                                 "effect the 12-parameter model lacks (a turntable offset, drift, temperature) or "
                                 "noisier sensors; the covariance is scaled by s^2; `inclino diagnose` names the "
                                 "effect")
    if info.get("moving") is not None:
        mv = len(info["moving"])
        hs_ = info["hold_scale"]
        from .motion import note

        info["notes"].append((note(info["moving_log"], mv) if info.get("moving_log") else
                              f"holds: a step-and-hold log: {info['holds']} static holds found in the readings were "
                              f"fitted" + (f", the {mv} rows read while moving between them left out" if mv else ""))
                             + f"; the covariance counts each hold once (x{hs_['acc']:.3g} accelerometer"
                             + (f", x{hs_['mag']:.3g} magnetometer on the rows' own)" if hs_["mag"] is not None else
                                f" on the rows' own; the magnetometer's and the dip's from the holds' shared errors "
                                f"in the |b| and dip residuals, x{info['hold_dip_var_ratio']:.3g} the dip's "
                                f"variance)"))
    if "notes_nonlinear" in info:
        info["notes"].append(info.pop("notes_nonlinear"))
    info["notes"] += prior_notes
    if "nonlinear" in info:
        nlm = info["nonlinear"]
        info["notes"].append("scale nonlinearity fitted as nuisance: q_acc = "
                             + ", ".join(f"{v:.3g}" for v in nlm["acc_q_per_g"]) + " /g, q_mag = "
                             + ", ".join(f"{v:.3g}" for v in nlm["mag_q_per_nT"]) + " /nT; the linear "
                             f"calibration written leaves {nlm['linear_representation_azi_rms_deg']:.4f} deg "
                             "azimuth RMS of it over the working range (I >= 2 deg)")
    return cal, info
