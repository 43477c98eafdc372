"""`joint` without poses, triad by triad: each triad keeps its own quality.

1. The accelerometer alone: the ellipsoid fit |M_a (a - b_a)| = G
   (calib.triad.fit_sphere, M_a symmetric: the body frame is the
   accelerometer's axes).  Nothing the magnetometer does can move it.
2. The magnetometer alone: the ellipsoid fit |S_m (m - b_m)| = F.
3. The magnetometer's rotation against the accelerometer, Q, and the dip,
   from the dip constraint g.b = |g||b| sin(dip) with the corrected gravity of
   step 1 held fixed; then M_m = Q S_m and b_m refined on the magnetometer's
   own residuals (|b| - F and the dip), each kind weighted by its own
   robust scale.  Robust: a soft-L1 pass, rows beyond the robust threshold
   left out, a least-squares pass.

A magnetometer disturbed by the rig (a field that moves with the gimbal's
axes, a steel clamp) misfits in steps 2-3 and is left out there; the
accelerometer's calibration is the accelerometer-only fit whatever the
magnetometer reads.  The noise of each triad is its own residual scale (no
single s^2 for both).

Returns the layout calib.joint's invariants fit returns: (M_a, b_a, M_m,
b_m, dip), the 25x25 covariance (24 coefficients, dip; the magnetometer's
block is its own fit's plus the accelerometer's error carried through the
dip residuals, with the cross terms: propagate_acc), info.
"""
from __future__ import annotations

import numpy as np
from scipy import optimize
from scipy.spatial.transform import Rotation

from inclino.errors import CalibrationError, DataError

from . import triad
from .ellipsoid import signed_permutations

MIN_ROWS = 12


def _dip_res(ug, ub):
    return np.degrees(np.arcsin(np.clip((ug * ub).sum(1), -1.0, 1.0)))


def _robust_std(x):
    return float(1.4826 * np.median(np.abs(x - np.median(x))))


def _mag_residuals(x, mag, g_unit, F, sm, sd):
    Mm = x[0:9].reshape(3, 3)
    bm = x[9:12]
    dip = x[12]
    b = (mag - bm) @ Mm.T
    nb = np.linalg.norm(b, axis=1)
    sdip = (g_unit * b).sum(1) / np.maximum(nb, 1e-300)
    return np.concatenate([(nb - F) / sm, (np.degrees(np.arcsin(np.clip(sdip, -1, 1))) - dip) / sd])


def _row_d2(x, acc, mag, Ma, ba, r, sm, sd):
    """Each row's squared norm of its |b| and dip residuals (r (2, n), over
    sm and sd) under their covariance from each raw axis's own noise
    (triad.row_noise_d2): |b| through the magnetometer's axes (gradient
    u_b M_m), the dip through both triads' (gradients (u_b - s u_g) M_a / |g|
    and (u_g - s u_b) M_m / |b| over cos dip, in degrees; s = u_g.u_b).
    Rows along a noisier axis scatter more; judged all by the median row
    they were set aside as outliers."""
    Mm, bm = x[0:9].reshape(3, 3), x[9:12]
    g = (acc - ba) @ Ma.T
    b = (mag - bm) @ Mm.T
    ng = np.maximum(np.linalg.norm(g, axis=1, keepdims=True), 1e-300)
    nb = np.maximum(np.linalg.norm(b, axis=1, keepdims=True), 1e-300)
    ug, ub = g / ng, b / nb
    s = (ug * ub).sum(1, keepdims=True)
    c = np.degrees(1.0) / np.maximum(np.sqrt(np.clip(1.0 - s * s, 0.0, 1.0)), 1e-12) / sd
    Gb = np.hstack([np.zeros_like(ug), (ub @ Mm) / sm])
    Gd = np.hstack([((ub - s * ug) / ng) @ Ma, ((ug - s * ub) / nb) @ Mm]) * c
    return triad.row_noise_d2(np.stack([Gb, Gd]), r)


def cluster_covariance(J, r, labels, keep):
    """Covariance of a least-squares fit whose rows come in clusters that
    share an error (the rows of one static hold): J (2 m, k) and r (2 m,)
    the whitened Jacobian and residuals of the m kept rows, |b| kind first,
    then the dip kind; labels (n,) each row's cluster (-1: a row of its
    own); keep (n,) the rows fitted.  triad.cluster_covariance with the two
    kinds (a within-cluster variance each, a 2 x 2 between-cluster
    covariance).  None when fewer than 12 clusters hold more than one
    row."""
    m = int(keep.sum())
    lab = np.asarray(labels)[keep]
    lab = np.where(lab >= 0, lab, -1 - np.arange(m))  # a moving row is its own cluster
    _, c = np.unique(lab, return_inverse=True)
    if np.sum(np.bincount(c) > 1) < 12:
        return None
    return triad.cluster_covariance(J, r, c, kinds=2)


def propagate_acc(cov, K, cov_mag_own=None):
    """The covariance with the accelerometer's error carried into the
    magnetometer's block: x_m's own covariance (the magnetometer's fit with
    the accelerometer held; cov_mag_own, else the block as it stands) plus
    K C_a K^T, and the cross terms K C_a (C_a: cov[0:12, 0:12])."""
    k = K.shape[0]
    out = cov.copy()
    Ca = cov[0:12, 0:12]
    own = cov[12:12 + k, 12:12 + k] if cov_mag_own is None else cov_mag_own
    out[12:12 + k, 12:12 + k] = own + K @ Ca @ K.T
    out[12:12 + k, 0:12] = K @ Ca
    out[0:12, 12:12 + k] = (K @ Ca).T
    return out


def fit(ds, w, sa, sm, fix_dip=False, mag_start=None, labels=None):
    """The staged fit (module docstring).  mag_start: a signed permutation
    (3x3) that the checks found to align the magnetometer's axes with the
    accelerometer's, a start for Q.  labels: each row's static hold (-1:
    none) when the log is step-and-hold: the magnetometer's covariance then
    counts each hold's shared error once (cluster_covariance).  Without
    labels, rows whose accelerometer residuals are correlated from row to
    row (a log read while moving: the hand's acceleration, which the dip
    residuals carry too) are counted in blocks of consecutive rows by both
    triads' covariances (triad.time_blocks; info["blocks"])."""
    G, F = w["gravity_g"], w["field_nT"]
    n = len(ds)
    if n < MIN_ROWS:
        raise DataError(f"joint without poses needs >= {MIN_ROWS} readings in varied orientations; the data have {n}")
    acc, mag = ds.acc, ds.mag
    # rows in static holds share each hold's error: the outlier tests judge them by the median row, not by a noise
    # per axis that a hold's error would be read as (triad.fit_sphere's axis_noise)
    held = labels is not None
    # 1. the accelerometer alone
    Ma, ba, cov_a, ia = triad.fit_sphere(acc, G, sa, min_rows=MIN_ROWS, what="the accelerometer",
                                         blocks=labels is None, refits=triad.REFITS, axis_noise=not held)
    timed = labels is None  # no holds: any blocks are of consecutive rows, sized by the residuals' correlation
    if ia["blocks"] is not None:
        labels = triad.time_blocks(ia["residual"])  # the magnetometer's dip residuals share those blocks
    # 2. the magnetometer alone
    Sm, bm, cov_s, im = triad.fit_sphere(mag, F, sm, min_rows=MIN_ROWS, what="the magnetometer",
                                         refits=triad.REFITS, axis_noise=not held)
    g = (acc - ba) @ Ma.T
    ug = g / np.maximum(np.linalg.norm(g, axis=1, keepdims=True), 1e-300)
    bs = (mag - bm) @ Sm.T
    ubs = bs / np.maximum(np.linalg.norm(bs, axis=1, keepdims=True), 1e-300)
    use = ia["keep"] & im["keep"]
    # 3. the rotation: the best of the 24 axis-aligned starts, then refined
    starts = signed_permutations(proper=True)
    if mag_start is not None:
        starts = [np.asarray(mag_start, float)] + starts
    best = None
    for Q0 in starts:
        if np.linalg.det(Q0) < 0:
            continue
        d = _dip_res(ug[use], ubs[use] @ Q0.T)
        s = _robust_std(d)
        if best is None or s < best[0]:
            best = (s, Q0)
    Q = best[1]

    def rot_res(r):
        R = Rotation.from_rotvec(r[:3]).as_matrix() @ Q
        return _dip_res(ug[use], ubs[use] @ R.T) - r[3]

    d0 = _dip_res(ug[use], ubs[use] @ Q.T)
    r0 = np.array([0.0, 0.0, 0.0, float(np.median(d0))])
    sd0 = max(_robust_std(d0), 1e-3)
    res = optimize.least_squares(rot_res, r0, loss="soft_l1", f_scale=3.0 * sd0)
    Q = Rotation.from_rotvec(res.x[:3]).as_matrix() @ Q
    dip0 = float(w["dip_deg"]) if (fix_dip and w["dip_deg"] is not None) else float(res.x[3])
    dres = _dip_res(ug, ubs @ Q.T) - dip0
    sd = max(_robust_std(dres[use]), 1e-4)
    if ia["blocks"] is not None:
        # the dip residuals carry the hand's acceleration, alike on neighbouring rows: weighted as the
        # independent rows they are worth (the residual's integrated autocorrelation time), they no longer pull
        # the magnetometer's own ellipsoid off its |b| residuals (held-out |b| of emulated hand tumbles
        # 3.2x the noise, pooled)
        sd *= np.sqrt(triad.integrated_time(dres[use]))
    sm_hat = max(im["noise"], 1e-6)
    # 4. the magnetometer refined on its own residuals, the accelerometer held
    x = np.concatenate([(Q @ Sm).ravel(), bm, [dip0]])
    keep = use.copy()

    def fun(xf, *args):
        return _mag_residuals(np.concatenate([xf, [dip0]]) if fix_dip else xf, *args)

    if fix_dip:
        x = x[:12]
    out = None
    for loss in ("soft_l1", "linear"):
        out = optimize.least_squares(fun, x, args=(mag[keep], ug[keep], F, sm_hat, sd), loss=loss, f_scale=3.0,
                                     x_scale="jac")
        x = out.x
        if loss == "soft_l1" and n >= triad.MIN_ROWS_REJECT:
            r = fun(x, mag, ug, F, sm_hat, sd).reshape(2, n)
            d2 = (r ** 2).sum(0) if held else _row_d2(x, acc, mag, Ma, ba, r, sm_hat, sd)
            thr, _ = triad.robust_threshold(d2[use], 2)
            # the rows the magnetometer's own ellipsoid fit set aside are judged again here, by |b| and the dip
            # together: set aside by both tests, clean rows were lost at three times the rate of one test (1.9 of
            # 600 with both triads, 0.6-0.7 with one; 0.8 now; 40 seeds)
            keep = ia["keep"] & (d2 <= thr)
            if keep.sum() < 8:  # 13 parameters, two residuals a row
                raise CalibrationError("joint: too many readings rejected as outliers to fit the magnetometer")
    if fix_dip:
        x = np.concatenate([x, [dip0]])
    J = out.jac
    dof = max(1, J.shape[0] - J.shape[1])
    s2m = float((out.fun ** 2).sum() / dof)
    JtJ = J.T @ J
    cn = np.sqrt(np.abs(np.diag(JtJ)))
    if not np.all(np.isfinite(JtJ)) or not np.all(cn > 0) or np.linalg.cond(JtJ / np.outer(cn, cn)) > 1e12:
        raise CalibrationError("joint: the orientations do not determine the magnetometer's calibration "
                               "(they cover too little of the sphere; singular fit)")
    cov_m = s2m * np.linalg.inv(JtJ)
    cov_source = "rows"
    mag_blocks = None
    if timed:
        # the magnetometer's own residuals have their own correlation time: a hand tumble's |b| misfit (a
        # disturbance, a soft-iron error that the linear model leaves, met while the hand sweeps slowly) stays
        # alike over hundreds of rows where the hand's acceleration in the dip stays alike over a few (CK-Explorer's
        # log: |b| 95 rows, the accelerometer's 3); blocks sized by the accelerometer's alone counted the |b|
        # residuals as 30 times the independent errors they are (split halves' mag_b 4.4 sigma apart, RMS)
        rm = _mag_residuals(x, mag, ug, F, sm_hat, sd).reshape(2, n)
        taus = [triad.integrated_time(rm[0][keep]), triad.integrated_time(rm[1][keep])]
        if ia["blocks"] is not None:
            taus.append(triad.integrated_time(ia["residual"]))
        lm = triad.blocks_of(n, max(taus))
        if lm is not None:
            labels = lm
            mag_blocks = {"rows": int(np.bincount(lm).max()), "count": int(lm.max()) + 1}
    if labels is not None:
        # the rows of one hold (or block) share its error: the |b| and the dip residuals alike (an
        # accelerometer's hold error is in the dip alone, so no factor from the magnetometer's ellipsoid can
        # stand for it)
        cc = cluster_covariance(J, out.fun, labels, keep)
        if cc is not None and np.all(np.isfinite(cc)):
            cov_source = {"dip_var_ratio": float(cc[-1, -1] / cov_m[-1, -1])}
            if mag_blocks is not None:
                mag_blocks["var_ratio"] = float(np.trace(cc[:12, :12]) / np.trace(cov_m[:12, :12]))
            cov_m = cc
    if not isinstance(cov_source, dict):
        mag_blocks = None
    blocks = ia["blocks"]
    if mag_blocks is not None:  # the magnetometer's blocks (with the dip's), beside the accelerometer's own
        blocks = {**(blocks or {}), **{"mag_" + k: v for k, v in mag_blocks.items()}}
    if im["refits"] is not None:
        # the magnetometer's ellipsoid curves in the noise (its orientations bunched to one side): what its refits
        # scatter beyond its linearised covariance, carried into M_m = Q S_m and b_m
        L = np.eye(12)
        L[:9, :9] = np.kron(Q, np.eye(3))  # row-major M_m = Q S_m
        w_, V_ = np.linalg.eigh(cov_s - im["cov_before_refits"])
        cov_m = cov_m.copy()
        cov_m[:12, :12] += L @ ((V_ * np.clip(w_, 0.0, None)) @ V_.T) @ L.T
    # the accelerometer's calibration is held fixed in the magnetometer's fit, but its error moves the corrected
    # gravity the dip residuals see: the magnetometer's parameters follow it (an error that tilts gravity is
    # partly taken up by Q), d x_m / d x_a = -(J^T J)^-1 J^T d r / d x_a, over the 12 numbers of (M_a, b_a)
    xm = x[:12] if fix_dip else x[:13]
    Jra = np.zeros((J.shape[0], 12))
    for j in range(12):
        h = 1e-6 * (1.0 if j < 9 else G)
        rr = []
        for sgn in (1.0, -1.0):
            Mp, bp = Ma.copy(), ba.copy()
            if j < 9:
                Mp[j // 3, j % 3] += sgn * h
            else:
                bp[j - 9] += sgn * h
            gp = (acc[keep] - bp) @ Mp.T
            rr.append(fun(xm, mag[keep], gp / np.maximum(np.linalg.norm(gp, axis=1, keepdims=True), 1e-300), F,
                          sm_hat, sd))
        Jra[:, j] = (rr[0] - rr[1]) / (2.0 * h)
    K = -np.linalg.solve(JtJ, J.T @ Jra)
    Mm, bm, dip = x[0:9].reshape(3, 3), x[9:12], float(x[12])
    cov = np.zeros((25, 25))
    cov[0:12, 0:12] = cov_a
    k = cov_m.shape[0]
    cov[12:12 + k, 12:12 + k] = cov_m
    cov = propagate_acc(cov, K)
    # the noise of each triad from its own residuals
    rb = np.linalg.norm((mag - bm) @ Mm.T, axis=1) - F
    dd = _dip_res(ug, ((mag - bm) @ Mm.T) / np.maximum(np.linalg.norm((mag - bm) @ Mm.T, axis=1, keepdims=True),
                                                      1e-300)) - dip
    noise = {"acc_g": ia["noise"], "mag_nT": float(np.sqrt(np.mean(rb[keep] ** 2))),
             "dip_deg": float(np.sqrt(np.mean(dd[keep] ** 2)))}
    acc_bad = ~ia["keep"]
    mag_bad = ~keep & ia["keep"]
    info = {"mode": "invariants", "staged": True, "noise": noise,
            "s2": float((ia["s2"] * ia["dof"] + s2m * dof) / (ia["dof"] + dof)),
            "s2_by_triad": {"acc": ia["s2"], "mag": s2m}, "chi2": float(ia["s2"] * ia["dof"] + s2m * dof),
            "dof": int(ia["dof"] + dof), "keep_acc": ia["keep"], "keep_mag": keep,
            "acc_misfit": acc_bad, "mag_misfit": mag_bad,
            "normal_matrix_cond": float(np.linalg.cond(JtJ)), "dip_fitted": not fix_dip,
            "dip_sigma_deg": None if fix_dip else float(np.sqrt(cov[24, 24])), "mag_covariance": cov_source,
            "acc_to_mag": K, "cov_mag_own": cov_m, "blocks": blocks,
            "refits": {t: i["refits"] for t, i in (("acc", ia), ("mag", im)) if i["refits"] is not None}}
    return (Ma, ba, Mm, bm, dip), cov, info
