"""One triad by itself: the fits that see only that triad's readings.

* `fit_poses(raw, truth, sigma)`: with the reference vectors (the poses'
  gravity or field in body axes), the 12-parameter linear model
  corrected = M (raw - b), least squares, robust to outliers, with the
  covariance scaled by this triad's own residual variance.
* `fit_sphere(raw, R, sigma)`: without poses, the ellipsoid fit: an
  algebraic quadric fit, then a geometric refinement of the centre b and a
  symmetric M with |M (raw - b)| = R (the rotation of the triad is not
  observable from |g| or |b| alone: M symmetric fixes it to the sensor's
  own axes).

Both report the triad's noise from its own residuals (never pooled with the
other triad's), the rows left out, and misfits that come in contiguous
blocks as segments (rows from-to, with what varies over them) rather than as
scattered outliers (`segments`).
"""
from __future__ import annotations

import numpy as np
from scipy import optimize, stats

from inclino.errors import CalibrationError, DataError, UndeterminedError

MIN_ROWS_REJECT = 27       # outliers are looked for with at least 3 rows a parameter (ellipsoid: 9)
SEGMENT_MIN_ROWS = 5       # a run of misfitting rows this long (and SEGMENT_MIN_FRACTION of the run) is a segment
SEGMENT_MIN_FRACTION = 0.01
SEGMENT_GAP = 2            # misfitting rows at most this far apart belong to one run ...
SEGMENT_MIN_DENSITY = 0.8  # ... and a segment is a run where most rows misfit
# An ellipsoid fit without poses whose corrected readings point within a plane (the least eigenvalue of their
# directions' second moment below this; 1/3 for readings spread evenly over the sphere, 0 for one plane) has run
# away: orientations near one circle (a great or a small one) leave the ellipsoid free across it (a cylinder, a
# flat disc or a far centre fits the circle as well as the sphere), and the motion's acceleration or the noise
# picks one of them.
# The report's verdict already fails below 0.02 (calib.report THRESHOLDS["coverage_min_eig"]); this far below it
# the coefficients are not a calibration at all (offsets of hundreds of g on a hand-turned log: RepoIMU's T-stick).
SPHERE_RUNAWAY_EIG = 0.005
RUNAWAY_REFIT_SPREAD = 0.1  # a fit that ran away is fitted again by the readings' distance from the ellipsoid only
                            # where the readings as logged span 3-D this much (0.14-0.23 on holds to one side of the
                            # sphere; a wand swung about one axis, near one circle, 0.03: refused as before)
SPHERE_SPANNED_EIG = 0.05  # the logged readings' direction spread above which they are not read as one plane: a
                           # turn about one axis wobbling by 5 deg (1 sigma) reads 0.008, by 18 deg 0.09; a lean
                           # it cannot see (a hemisphere reads 1/3, as the whole sphere)


def direction_spread(v) -> float:
    """The least eigenvalue of the second moment of the readings' directions
    (0: all in one plane through the origin; 1/3: evenly over the sphere)."""
    v = np.asarray(v, float)
    u = v / np.maximum(np.linalg.norm(v, axis=1, keepdims=True), 1e-300)
    return float(np.linalg.eigvalsh(u.T @ u / max(len(u), 1)).min())


def direction_cond(v) -> float:
    """The scale-free condition number of a sphere fit's normal matrix at
    the unit sphere, on the readings' directions: how well their
    orientations alone, without noise or motion, determine an ellipsoid
    (2.5 evenly over the sphere, 15 with a cap of 60 degrees missing, 3e2 over a hemisphere, 2e4 over a
    cap of 60 degrees, unbounded within one plane)."""
    v = np.asarray(v, float)
    u = v / np.maximum(np.linalg.norm(v, axis=1, keepdims=True), 1e-300)
    x = np.concatenate([np.eye(3)[np.triu_indices(3)], np.zeros(3)])
    J = _sphere_jac(x, u, 1.0)
    JtJ = J.T @ J
    cn = np.sqrt(np.diag(JtJ))
    if not np.all(cn > 0):
        return float("inf")
    return float(np.linalg.cond(JtJ / np.outer(cn, cn)))


def _sym(v):
    a, b, c, d, e, f = v
    return np.array([[a, b, c], [b, d, e], [c, e, f]])


def robust_threshold(d2, dof):
    """Outlier threshold on the rows' whitened squared norms d2 (dof
    components each): the chi-square 99.9 % point scaled by a robust
    estimate of the residual variance (the median of d2 over the
    chi-square median), never below the nominal noise.  A large effect
    the model lacks inflates every row alike and must not make the rows
    outliers; a few spiked rows do not move the median.  Every fit's
    (calib.joint takes it from here).  Returns (threshold, scale)."""
    scale = max(1.0, float(np.median(d2)) / stats.chi2.ppf(0.5, dof))
    return scale * stats.chi2.ppf(0.999, dof), scale


def segments(bad, ds=None, rows=None) -> tuple[list, list]:
    """Split misfitting rows (boolean over the fitted rows, in file order)
    into contiguous segments and scattered outliers.  `rows` maps fitted
    rows to the dataset's rows; `ds` (the dataset) names what varies over
    each segment.  Returns (segments, outlier row indices)."""
    idx = np.flatnonzero(bad)
    n = len(bad)
    rows = np.arange(n) if rows is None else np.asarray(rows)
    if idx.size == 0:
        return [], []
    runs, start, prev = [], idx[0], idx[0]
    for i in idx[1:]:
        if i - prev > SEGMENT_GAP + 1:
            runs.append((start, prev))
            start = i
        prev = i
    runs.append((start, prev))
    segs, scattered = [], []
    min_len = max(SEGMENT_MIN_ROWS, int(np.ceil(SEGMENT_MIN_FRACTION * n)))
    for a, b in runs:
        members = idx[(idx >= a) & (idx <= b)]
        if len(members) >= min_len and len(members) >= SEGMENT_MIN_DENSITY * (b - a + 1):
            seg = {"from_row": int(rows[a]), "to_row": int(rows[b]), "rows": int(len(members)),
                   "fraction": float(len(members) / n)}
            if ds is not None:
                seg["varies"] = _what_varies(ds, rows[a:b + 1])
            segs.append(seg)
        else:
            scattered += [int(rows[i]) for i in members]
    return segs, scattered


def _what_varies(ds, sel) -> dict:
    """Per column that the dataset has (poses, time, temperature): the
    range over the segment, and over the run."""
    out = {}
    for c in ("inc_deg", "azi_deg", "tf_deg", "t_s", "temp_c"):
        if c in ds.columns:
            v = ds.columns[c]
            out[c] = {"segment": [float(v[sel].min()), float(v[sel].max())], "run": [float(v.min()), float(v.max())]}
    return out


def segment_text(seg) -> str:
    t = f"rows {seg['from_row']}-{seg['to_row']} ({seg['rows']} rows, {100 * seg['fraction']:.0f} %)"
    v = seg.get("varies") or {}
    parts = [f"{c.split('_')[0]} {r['segment'][0]:.4g}..{r['segment'][1]:.4g}" for c, r in v.items()]
    return t + (": " + ", ".join(parts) if parts else "")


# --------------------------------------------------------------------------
def _mc_to_mb(M, b):
    """The Jacobian (12 x 12) from (M row-major, c = M b) to (M row-major,
    b = M^-1 c): the covariance of a fit in c carried to b."""
    Minv = np.linalg.inv(M)
    T = np.eye(12)
    for i in range(3):
        for j in range(3):
            E = np.zeros((3, 3))
            E[i, j] = 1.0
            T[9:12, 3 * i + j] = -Minv @ (E @ b)
    T[9:12, 9:12] = Minv
    return T


def fit_poses(raw, truth, sigma: float, min_rows: int = 4):
    """corrected = M (raw - b) against the reference `truth` (n, 3).
    Returns (M, b, cov (12: M row-major, b), info)."""
    raw = np.asarray(raw, float)
    truth = np.asarray(truth, float)
    n = len(raw)
    if n < min_rows:
        raise DataError(f"a fit of one triad with poses needs >= {min_rows} readings; the data have {n}")
    X = np.column_stack([raw, -np.ones(n)])
    keep = np.ones(n, bool)
    for _ in range(3):  # fit, drop what misfits beyond the robust threshold, refit
        sol, *_ = np.linalg.lstsq(X[keep], truth[keep], rcond=None)
        r = X @ sol - truth
        d2 = (r ** 2).sum(1) / sigma ** 2
        thr, _ = robust_threshold(d2[keep], 3)
        new = d2 <= thr
        if new.sum() < min_rows:
            raise CalibrationError("too many readings misfit the poses to fit the triad")
        if np.array_equal(new, keep):
            break
        keep = new
    Xk = X[keep]
    sol, *_ = np.linalg.lstsq(Xk, truth[keep], rcond=None)
    r = Xk @ sol - truth[keep]
    dof = max(1, 3 * int(keep.sum()) - 12)
    s2 = float((r ** 2).sum() / sigma ** 2 / dof)
    if np.linalg.matrix_rank(Xk) < 4:
        raise CalibrationError("the poses do not determine the triad's 12 parameters (too few distinct "
                               "orientations)")
    poses_span(truth[keep])
    # each output axis i: truth_i = X @ [M_i; c_i]; cov of each row's 4 numbers = s2 sigma^2 (X^T X)^-1
    XtXi = np.linalg.inv(Xk.T @ Xk) * s2 * sigma ** 2
    M = sol[:3].T
    c = sol[3]
    cov_mc = np.zeros((12, 12))  # (M row-major 9, c 3)
    for i in range(3):
        ids = [3 * i, 3 * i + 1, 3 * i + 2, 9 + i]
        cov_mc[np.ix_(ids, ids)] = XtXi
    b = np.linalg.solve(M, c)
    T = _mc_to_mb(M, b)
    cov = T @ cov_mc @ T.T
    res = np.linalg.norm(X @ sol - truth, axis=1)
    return M, b, cov, {"s2": s2, "dof": dof, "keep": keep, "residual": res,
                       "noise": float(np.sqrt(s2) * sigma), "mode": "poses"}


def poses_span(truth, what: str = "the triad's 12 parameters") -> None:
    """Refuse poses whose reference vectors (n, 3) lie on one plane: the
    readings' noise makes [raw, 1] of full rank, but the fit takes each
    axis's offset and scale from how the reference changes, and across
    such a plane nothing changes (a six-face session split in two, faces
    -x, +y, +z in one half: its offsets came out 1e15 g and the refusal
    blamed the unit)."""
    u = np.unique(np.round(truth / max(float(np.abs(truth).max()), 1e-300), 6), axis=0)
    if len(u) >= 4:
        _, sv, Vt = np.linalg.svd(np.column_stack([u, np.ones(len(u))]))
        if sv[-1] > 1e-6 * sv[0]:
            return
        normal = Vt[-1, :3] / max(float(np.linalg.norm(Vt[-1, :3])), 1e-300)
    else:
        normal = np.cross(u[1] - u[0], u[-1] - u[0]) if len(u) == 3 else np.zeros(3)
        normal = normal / max(float(np.linalg.norm(normal)), 1e-300)
    k = int(np.argmax(np.abs(normal)))
    n_text = f"({normal[0]:+.2f}, {normal[1]:+.2f}, {normal[2]:+.2f})"
    across = (f" (normal to its {'xyz'[k]} axis: the {'xyz'[k]} offset and the gain on {'xyz'[k]} are undetermined)"
              if abs(normal[k]) > 0.985 else
              f" (normal {n_text} in its axes: each axis's offset and its gain along that normal are undetermined)")
    if len(u) < 3:
        raise CalibrationError(
            f"the poses do not determine {what}: their {len(u)} distinct reference direction{'s' * (len(u) > 1)} "
            f"leave the offsets not told from the gains across {'them' if len(u) > 1 else 'it'} (4 off one plane "
            f"are needed); add poses with the reference along other axes (in a six-face session, each axis pointing "
            f"both up and down)")
    # the faces of a six-face session off that plane, named (three faces -x, +y, +z: +x, -y and -z), where the
    # plane has a normal; the reference is what the triad reads (gravity's direction, an axis down reading +1 g)
    c = float(np.mean(u @ normal))
    faces = [f"{'+-'[j]}{'xyz'[i]}" for i in range(3) for j in range(2) if abs((1 - 2 * j) * normal[i] - c) > 0.1]
    off = (f": the reference along {', '.join(faces[:-1]) + ' or ' + faces[-1] if len(faces) > 1 else faces[0]}"
           if faces else "")
    raise CalibrationError(
        f"the poses do not determine {what}: their {len(u)} distinct reference directions lie on one "
        f"plane{across}, across which an offset is not told from the scale and axes; add poses off that plane"
        f"{off} (in a six-face session, each axis pointing both up and down)")


def pose_mean_covariance(gm, tm, M, b, radial_var, tangential_var=None):
    """The covariance (12: M row-major, b) of fit_poses on poses' mean
    readings gm (n, 3) against their truth tm, under the error a pose's
    placement makes: a small rotation of the truth, which moves a mean
    reading across its direction and not along it (to first order), beside
    the readings' own noise.  Each mean's error covariance is
    s_t^2 (I - u u^T) + s_r^2 u u^T, u the truth's direction: s_r^2 per
    pose (radial_var, (n,), the variance of the mean along u, e.g. the rows'
    scatter over their count), raised to the radial residuals' own level
    where they have the degrees of freedom to show it; across u the
    readings' own noise (tangential_var, (n,), per axis across u: the rows'
    scatter across it over their count; none given: 0) plus s_t^2, the
    placement: what the residuals across the directions show beyond that
    noise, over their expected share (the residual projector's trace).  The
    noise is the floor: the means' residuals across gravity have few
    degrees of freedom (~3 on six faces) and can show nothing by chance,
    and with s_t^2 alone the covariance then held no error across gravity.  The covariance is the least squares
    estimator's under that error (a sandwich: fit_poses is unweighted).
    Returns (cov, {"placement_deg", "radial", "tangential_dof",
    "radial_dof"})."""
    gm, tm = np.asarray(gm, float), np.asarray(tm, float)
    n = len(gm)
    u = tm / np.linalg.norm(tm, axis=1, keepdims=True)
    X = np.column_stack([gm, -np.ones(n)])
    # the 3n x 12 design of all axes (rows: pose k, axis i; columns: M row-major, c)
    J = np.zeros((n, 3, 12))
    for i in range(3):
        J[:, i, 3 * i:3 * i + 3] = gm
        J[:, i, 9 + i] = -1.0
    J = J.reshape(3 * n, 12)
    sol = np.concatenate([(M @ np.eye(3)).ravel(), M @ b])
    r = (J @ sol - tm.ravel())
    U = np.zeros((3 * n, 3 * n))
    for k in range(n):
        U[3 * k:3 * k + 3, 3 * k:3 * k + 3] = np.outer(u[k], u[k])
    P = np.eye(3 * n) - U
    JtJi = np.linalg.inv(J.T @ J)
    Q = np.eye(3 * n) - J @ JtJi @ J.T  # the residual maker
    QPQ, QUQ = Q @ P @ Q, Q @ U @ Q
    dof_t, dof_r = float(np.trace(P @ QPQ)), float(np.trace(U @ QUQ))
    Dr = np.zeros((3 * n, 3 * n))
    for k in range(n):
        Dr[3 * k:3 * k + 3, 3 * k:3 * k + 3] = radial_var[k] * np.outer(u[k], u[k])
    rr, rt = float(r @ U @ r), float(r @ P @ r)
    radial = 1.0
    if dof_r >= 3.0:  # the radial residuals against the readings' own noise, where they can show it
        radial = max(1.0, rr / max(float(np.trace(U @ Q @ Dr @ Q)), 1e-300))
    Dr = Dr * radial
    Dt = np.zeros((3 * n, 3 * n))
    if tangential_var is not None:
        for k in range(n):
            Dt[3 * k:3 * k + 3, 3 * k:3 * k + 3] = tangential_var[k] * (np.eye(3) - np.outer(u[k], u[k]))
    st2 = max(rt - float(np.trace(P @ Q @ (Dr + Dt) @ Q)), 0.0) / max(dof_t, 1e-300)
    Sigma = st2 * P + Dt + Dr
    cov_mc = JtJi @ J.T @ Sigma @ J @ JtJi
    T = _mc_to_mb(M, b)
    g = float(np.median(np.linalg.norm(tm, axis=1)))
    return T @ cov_mc @ T.T, {"placement_deg": float(np.degrees(np.sqrt(st2) / g)), "radial": radial,
                              "tangential_dof": dof_t, "radial_dof": dof_r}


def ellipsoid_algebraic(raw, R, what: str = "the triad"):
    """Algebraic quadric fit: (M symmetric, b) with |M (raw - b)| ~ R."""
    from .ellipsoid import ellipsoid_start

    return ellipsoid_start(raw, R, what)


def _sphere_residual(x, raw, R):
    M = _sym(x[:6])
    g = (raw - x[6:9]) @ M.T
    return np.linalg.norm(g, axis=1) - R


def _sphere_jac(x, raw, R):
    M = _sym(x[:6])
    d = raw - x[6:9]
    g = d @ M.T
    n = np.maximum(np.linalg.norm(g, axis=1), 1e-300)
    u = g / n[:, None]
    J = np.zeros((len(raw), 9))
    # d|g|/dM_ij = u_i d_j (+ u_j d_i off the diagonal: M symmetric)
    pairs = [(0, 0), (0, 1), (0, 2), (1, 1), (1, 2), (2, 2)]
    for k, (i, j) in enumerate(pairs):
        J[:, k] = u[:, i] * d[:, j] + (u[:, j] * d[:, i] if i != j else 0.0)
    J[:, 6:9] = -u @ M
    return J


def _geometric_residual(x, raw, R):
    """|M (raw - b)| - R in the readings' own units: over |M^T u|, the
    residual's gradient along the reading (u its corrected direction), to
    first order the reading's distance from the fitted ellipsoid."""
    M = _sym(x[:6])
    g = (raw - x[6:9]) @ M.T
    n = np.maximum(np.linalg.norm(g, axis=1), 1e-300)
    grad = np.maximum(np.linalg.norm((g / n[:, None]) @ M, axis=1), 1e-300)
    return (n - R) / grad


def _geometric_refit(raw, R, sigma, M0, b0, robust, axis_noise: bool = True):
    """(x, keep, res) of the ellipsoid fitted by the readings' distance from
    it, from the algebraic start, where the fit of |M (raw - b)| - R ran
    away; None if this one runs away too.  That residual is in corrected
    units: a smaller M shrinks it, and on holds to one side of the sphere
    an ellipsoid through a plane, M a tenth of the start's and b 60 g off,
    leaves 0.15 mg of it where the start leaves 6 mg, though the readings
    lie 9.6 mg from that ellipsoid and 5.9 mg from the start's (the first
    6 000 rows of mikoff's MPU-9150: 61 holds, every x at -0.27 g or more;
    fitted so, M and b come within 0.005 and 4 mg of the whole log's fit)."""
    try:
        out = _robust_fit(np.concatenate([M0[np.triu_indices(3)], b0]), raw,
                          lambda p, a: _geometric_residual(p, a, R) / sigma, robust, geometric=True,
                          axis_noise=axis_noise)
    except (ValueError, np.linalg.LinAlgError):
        return None
    if out is None or not np.all(np.isfinite(out[0])):
        return None
    return out


def _robust_fit(x, raw, resid, robust, jac=None, geometric: bool = False, axis_noise: bool = True):
    """(x, keep, res) of the least-squares fit of resid(p, rows) (in units
    of the noise) from x: where robust, a soft-L1 pass (its scale 3x the
    residuals' own robust size, not the nominal sigma), the rows beyond the
    robust threshold dropped (each row's squared residual over the variance
    its direction carries, axis_noise_factor, where axis_noise; geometric:
    resid is the readings' distance from the ellipsoid), then a plain pass
    on the rest;
    None when fewer than 10 rows (the 9 parameters) are left."""
    keep = np.ones(len(raw), bool)
    res = None
    for loss in (("soft_l1", "linear") if robust else ("linear",)):
        f_scale = 3.0 * max(1.0, 1.4826 * float(np.median(np.abs(resid(x, raw))))) if loss == "soft_l1" else 1.0
        res = optimize.least_squares(resid, x, jac=jac if jac is not None else "2-point", args=(raw[keep],),
                                     loss=loss, f_scale=f_scale, x_scale="jac",
                                     method="trf" if loss != "linear" else "lm")
        x = res.x
        if loss == "soft_l1":
            r2 = resid(x, raw) ** 2
            d2 = r2 / axis_noise_factor(x, raw, r2, geometric) if axis_noise else r2
            thr, _ = robust_threshold(d2, 1)
            keep = d2 <= thr
            if keep.sum() < 10:
                return None
    return x, keep, res


# The outlier test of an ellipsoid fit weighs each row's residual by the noise its direction carries: a row's
# residual |M (raw - b)| - R takes each raw axis's noise through the gradient M u (u its corrected direction), so
# where the axes' noises differ the rows along the noisier axis scatter more.  Judged all by the median row, clean
# rows along it were set aside: per-axis noise of 1, 1 and 3 (any unit) over 600 random orientations lost 7.2 rows
# a fit (40 seeds, magnetometer or accelerometer alone; 19 with both triads), the 99.9 % point's 0.6 expected;
# weighed by their direction 0.68-0.78, and spikes and a disturbed block found as before.
AXIS_NOISE_MIN_ROWS = 60   # the three axes' noise variances are fitted from at least this many rows (20 each) ...
AXIS_NOISE_MIN_SV = 0.05   # ... whose directions tell the axes apart (the least singular value of their squared
                           # gradients, columns scaled, over the largest; all near one axis: not told apart)
AXIS_NOISE_MAX_RATIO = 10.0  # an axis's noise taken as at least 1/10 of the noisiest's (no row is judged by ~0)


def axis_noise_factor(x, raw, r2, geometric: bool = False):
    """Per row, the variance of its ellipsoid residual (r2: the squared
    residuals at the fit x) relative to the median row's, from each raw
    axis's own noise variance (row_noise_factor): the residual's gradient
    in the raw reading is M u (u the row's corrected direction), over
    |M u| for the geometric residual (the readings' distance from the
    ellipsoid)."""
    M = _sym(x[:6])
    g = (raw - x[6:9]) @ M.T
    G = (g / np.maximum(np.linalg.norm(g, axis=1, keepdims=True), 1e-300)) @ M
    if geometric:
        G = G / np.maximum(np.linalg.norm(G, axis=1, keepdims=True), 1e-300)
    return row_noise_factor(G, r2)


def row_noise_d2(G, r):
    """Each row's squared norm of m residuals under their own covariance
    from each raw axis's noise: G (m, n, k) the residuals' gradients in the
    k raw axes they read, r (m, n) the residuals; row i's covariance
    C_i = sum_k s_k^2 G_:ik G_:ik^T (two residuals that read the same axis
    are correlated through it: |b| and the dip where the magnetometer's
    axes differ), the s_k^2 fitted by non-negative least squares on the
    products r_j r_l (each weighed by the rows' variance), the rows beyond
    the robust threshold (m degrees of freedom) left out, three passes.
    The plain sum of squares (every row alike, the residuals whitened
    already) with fewer than AXIS_NOISE_MIN_ROWS rows or gradients that do
    not tell the axes apart."""
    G, r = np.asarray(G, float), np.asarray(r, float)
    m, n, k = G.shape
    plain = (r ** 2).sum(0)
    if n < AXIS_NOISE_MIN_ROWS or not np.all(np.isfinite(G)) or not np.all(np.isfinite(r)):
        return plain
    pairs = [(j, l) for j in range(m) for l in range(j, m)]
    W = np.stack([G[j] * G[l] for j, l in pairs])  # (pairs, n, k)
    y = np.stack([r[j] * r[l] for j, l in pairs])  # (pairs, n)
    cn = np.linalg.norm(W.reshape(-1, k), axis=0)
    if not np.all(cn > 0):
        return plain
    sv = np.linalg.svd(W.reshape(-1, k) / cn, compute_uv=False)
    if not sv[-1] >= AXIS_NOISE_MIN_SV * sv[0]:
        return plain
    d2, C = plain, None
    for _ in range(3):
        ok = d2 <= robust_threshold(d2, m)[0]
        if C is None:
            w = np.ones((len(pairs), n))
        else:
            w = 1.0 / np.sqrt(np.stack([np.abs(C[:, j, j] * C[:, l, l]) for j, l in pairs]) + 1e-300)
        A = (W * w[..., None])[:, ok].reshape(-1, k)
        s2, _ = optimize.nnls(A, (y * w)[:, ok].ravel())
        if not s2.max() > 0:
            return plain
        s2 = np.maximum(s2, s2.max() / AXIS_NOISE_MAX_RATIO ** 2)
        C = np.einsum("jnk,lnk,k->njl", G, G, s2)
        try:
            d2 = np.einsum("jn,njl,ln->n", r, np.linalg.inv(C), r)
        except np.linalg.LinAlgError:
            return plain
        if not np.all(np.isfinite(d2)):
            return plain
    return d2


def row_noise_factor(G, r2):
    """Per row, the variance of a residual relative to the median row's,
    from each raw axis's own noise variance: G (n, k) the residual's
    gradient in the k raw axes it reads, r2 (n,) its squares; E r2 =
    sum_k G_k^2 s_k^2, the s_k^2 fitted by non-negative least squares
    weighted by each row's variance, the rows beyond the robust threshold
    left out, three passes.  Ones (every row alike) with fewer than
    AXIS_NOISE_MIN_ROWS rows or gradients that do not tell the axes apart
    (AXIS_NOISE_MIN_SV)."""
    n = len(r2)
    one = np.ones(n)
    if n < AXIS_NOISE_MIN_ROWS:
        return one
    W = np.asarray(G, float) ** 2
    cn = np.linalg.norm(W, axis=0)
    if not np.all(np.isfinite(W)) or not np.all(cn > 0) or not np.all(np.isfinite(r2)):
        return one
    sv = np.linalg.svd(W / cn, compute_uv=False)
    if not sv[-1] >= AXIS_NOISE_MIN_SV * sv[0]:
        return one
    f = one
    for _ in range(3):
        d2 = r2 / f
        ok = d2 <= robust_threshold(d2, 1)[0]
        s2, _ = optimize.nnls(W[ok] / f[ok, None], r2[ok] / f[ok])
        if not s2.max() > 0:
            return one
        s2 = np.maximum(s2, s2.max() / AXIS_NOISE_MAX_RATIO ** 2)
        v = W @ s2
        f = v / float(np.median(v))
    return f


def fit_sphere(raw, R: float, sigma: float, min_rows: int = 10, start=None, what: str = "the triad",
               blocks: bool = False, refits: int = 0, axis_noise: bool = True):
    """Ellipsoid fit of one triad: (M symmetric, b) with |M (raw - b)| = R,
    robust (soft-L1 pass, rows beyond the robust threshold dropped, a final
    least-squares pass).  Returns (M, b, cov (12: M row-major, b; the
    symmetric M's 6 free numbers mapped onto its 9 entries), info).
    blocks (the raw rows consecutive, in time order, no hold structure
    known): when the residuals are correlated from row to row (a hand's
    acceleration on a log read while moving), the covariance counts blocks
    of consecutive rows (time_blocks, block_covariance), not rows, if that
    is the larger; info["blocks"] says so.
    refits: that many refits of readings simulated from the fit
    (sphere_refits), whose scatter about the fit and mean shift from it
    are the covariance when they are the larger: the linearised covariance
    holds only where the fit is nearly linear in the noise, and orientations
    bunched in one hemisphere (a hand tumble) make it curve; info["refits"]
    says so.
    axis_noise: the outlier test weighs each row by the noise its direction
    carries (axis_noise_factor); off for rows in static holds, whose
    residuals carry each hold's own error, not the axes' noise (fitted so,
    a hold's error reads as an axis's noise and its rows stay in).
    CalibrationError when the orientations do not determine the ellipsoid:
    a singular normal matrix, a fit that runs away (its corrected readings
    point within a plane: SPHERE_RUNAWAY_EIG), or (refits) a fit its refits
    do not come back to."""
    raw = np.asarray(raw, float)
    n = len(raw)
    if n < min_rows:
        raise DataError(f"a fit of one triad without poses needs >= {min_rows} readings in varied orientations; "
                        f"the data have {n}")
    if start is None:
        M0, b0 = ellipsoid_algebraic(raw, R, what)
    else:
        M0, b0 = start
    robust = n >= MIN_ROWS_REJECT  # fewer rows cannot tell an outlier from the model's misfit: least squares alone
    fitted = _robust_fit(np.concatenate([M0[np.triu_indices(3)], b0]), raw,
                         lambda p, a: _sphere_residual(p, a, R) / sigma, robust,
                         jac=lambda p, a: _sphere_jac(p, a, R) / sigma, axis_noise=axis_noise)
    if fitted is None:
        raise CalibrationError("too many readings rejected as outliers to fit the triad")
    x, keep, res = fitted
    r = res.fun
    dof = max(1, int(keep.sum()) - 9)
    s2 = float((r ** 2).sum() / dof)
    J = res.jac
    JtJ = J.T @ J
    cn = np.sqrt(np.diag(JtJ))
    if not np.all(cn > 0) or np.linalg.cond(JtJ / np.outer(cn, cn)) > 1e12:  # scale-free: the geometry alone
        raise CalibrationError(f"the orientations do not determine {what}'s ellipsoid (they cover too little "
                               "of the sphere)")
    spread = direction_spread((raw[keep] - x[6:9]) @ _sym(x[:6]).T)
    geo = None
    if spread < SPHERE_RUNAWAY_EIG and direction_spread(raw) >= RUNAWAY_REFIT_SPREAD:
        geo = _geometric_refit(raw, R, sigma, M0, b0, robust, axis_noise)
        if geo is not None:
            x, keep, res = geo
            r = _sphere_residual(x, raw[keep], R) / sigma
            dof = max(1, int(keep.sum()) - 9)
            s2 = float((r ** 2).sum() / dof)
            J = _sphere_jac(x, raw[keep], R) / sigma
            JtJ = J.T @ J
            spread = direction_spread((raw[keep] - x[6:9]) @ _sym(x[:6]).T)
    if spread < SPHERE_RUNAWAY_EIG:
        swamp = "the motion's acceleration" if "accelerometer" in what else "the noise or a disturbance"
        logged = direction_spread(raw[keep])
        head = (f"the orientations do not determine {what}'s ellipsoid: the fit runs away (its corrected readings "
                f"point within one plane: spread {spread:.2g} < {SPHERE_RUNAWAY_EIG:g}; the readings as logged "
                f"{logged:.2g}, 1/3 for every direction): ")
        if logged >= SPHERE_SPANNED_EIG:
            # the logged readings are not planar: the turn was not about one axis, the orientations lean to one
            # side of the sphere and the noise or the motion bends the fit off the far side it never saw
            u = raw[keep] / np.maximum(np.linalg.norm(raw[keep], axis=1, keepdims=True), 1e-300)
            lean = float(np.linalg.norm(u.mean(0)))
            raise CalibrationError(
                head + f"the readings lean to one side of the sphere (their directions' mean resultant {lean:.2f}; "
                f"0 for every direction, 1 for one) and {swamp} bends the fit off the side they never reached; "
                f"turn the sensor through more of the sphere, each axis pointing both up and down (or give poses)")
        raise CalibrationError(
            head + f"the sensor was turned about one axis, or {swamp} swamps the turn out of that plane; "
            f"log it turned about more than one axis (or give poses)")
    cov9 = s2 * np.linalg.inv(JtJ)
    blk = None
    if blocks:
        lab = time_blocks(_sphere_residual(x, raw, R))
        if lab is not None:
            cb = block_covariance(J, r, lab[keep])
            if cb is not None and np.trace(cb) > np.trace(cov9):
                blk = {"rows": int(np.bincount(lab).max()), "count": int(lab.max()) + 1,
                       "var_ratio": float(np.trace(cb) / np.trace(cov9))}
                cov9 = cb
    boot, cov9_lin = None, None
    if refits:
        cr = sphere_refits(x, raw[keep], R, sigma, s2, refits, geometric=geo is not None)
        if cr is None:
            c = (raw[keep] - x[6:9]) @ _sym(x[:6]).T
            lean = float(np.linalg.norm((c / np.maximum(np.linalg.norm(c, axis=1, keepdims=True), 1e-300)).mean(0)))
            raise UndeterminedError(
                f"the orientations do not determine {what}'s ellipsoid: refitted to readings simulated from its own "
                f"fit (the same orientations, its own noise), it does not come back (a refit runs away): the "
                f"readings lean to one side of the sphere (their directions' mean resultant "
                f"{lean:.2f}; 0 for every direction, 1 for one); turn the sensor through more of the sphere")
        if np.trace(cr) > REFIT_RATIO * np.trace(cov9):
            boot = {"refits": refits, "var_ratio": float(np.trace(cr) / np.trace(cov9))}
            cov9_lin, cov9 = cov9, cr
    T = _SYM_TO_FULL
    cov = T @ cov9 @ T.T
    cov_lin = None if cov9_lin is None else T @ cov9_lin @ T.T
    M, b = _sym(x[:6]), x[6:9]
    resid = _sphere_residual(x, raw, R)
    return M, b, cov, {"s2": s2, "dof": dof, "keep": keep, "residual": resid,
                       "noise": float(np.sqrt(s2) * sigma), "mode": "invariants", "cov9": cov9, "blocks": blk,
                       "refits": boot, "cov_before_refits": cov_lin}


REFIT_SEED = 20160210
REFITS = 30         # refits of a pose-free ellipsoid fit (30 x ~10 ms on 6 000 rows)
REFIT_MAX_NFEV = 100  # a refit starts at the fit: it converges in a few evaluations, or runs away
REFIT_RATIO = 1.5   # ... whose covariance replaces the linearised one when its trace is this much larger (below,
                    # 30 refits' own scatter: the linearised one holds)


def sphere_refits(x, raw, R, sigma, s2, n, geometric: bool = False):
    """The ellipsoid fit's covariance from n refits (a parametric
    bootstrap): each fitted row projected onto the fitted ellipsoid, white
    noise of the fit's own residual size added (isotropic, in the readings'
    units), refitted by least squares from the fit; the refits' covariance
    about their mean plus the square of their mean's shift from the fit (the
    fit's own bias from the noise); None as soon as a refit runs away (does
    not converge in REFIT_MAX_NFEV evaluations, or leaves the corrected
    readings within one plane): a fit its refits do not come back to is not
    determined by its orientations.  Seeded: the same readings give the
    same figures.  geometric: the fit was of the readings' distance from
    the ellipsoid (_geometric_refit), and so is each refit."""
    M, b = _sym(x[:6]), x[6:9]
    c = (raw - b) @ M.T
    u = c / np.maximum(np.linalg.norm(c, axis=1, keepdims=True), 1e-300)
    clean = b + (R * u) @ np.linalg.inv(M).T
    sd = float(np.sqrt(s2) * sigma / np.mean(np.linalg.svd(M, compute_uv=False)))
    rng = np.random.default_rng(REFIT_SEED)
    xs = []
    for _ in range(n):
        sim = clean + rng.normal(0.0, sd, clean.shape)
        try:
            if geometric:
                res = optimize.least_squares(lambda p: _geometric_residual(p, sim, R) / sigma, x, method="lm",
                                             x_scale="jac", max_nfev=REFIT_MAX_NFEV * 10)
            else:
                res = optimize.least_squares(lambda p: _sphere_residual(p, sim, R) / sigma, x,
                                             jac=lambda p: _sphere_jac(p, sim, R) / sigma, method="lm",
                                             x_scale="jac", max_nfev=REFIT_MAX_NFEV)
            ok = res.success and np.all(np.isfinite(res.x)) and \
                direction_spread((sim - res.x[6:9]) @ _sym(res.x[:6]).T) >= SPHERE_RUNAWAY_EIG
        except (ValueError, np.linalg.LinAlgError):
            ok = False
        if not ok:
            return None  # one is enough: the fit is not determined (and a runaway costs its every evaluation)
        xs.append(res.x)
    xs = np.array(xs)
    d = xs.mean(0) - x
    return np.cov(xs.T) + np.outer(d, d)


# A fit of every row of a log read while moving: the hand's acceleration errs alike on neighbouring rows (its
# spectrum is a few Hz, the rows tens to hundreds a second), so the rows are not independent measurements and a
# covariance that counts them as such understates the error several times (z RMS 4-5 on emulated hand tumbles,
# tools/independent_check case moving_acc).  The blocks' covariance counts blocks of consecutive rows instead.
BLOCK_TAU_K = 5.0   # a block spans this many integrated autocorrelation times of the residual ...
BLOCK_MIN = 30      # ... and the rows make at least this many blocks (shorter blocks when they would not)
BLOCK_ACF_END = 0.05  # the autocorrelation is summed up to the first lag where it falls below this
BLOCK_MIN_TAU = 1.5   # residuals this close to white (integrated time in rows) keep the rows' own covariance


def time_blocks(resid) -> np.ndarray | None:
    """Block labels (0, 1, ...) of consecutive rows for the blocks'
    covariance, from the residual's own autocorrelation: its integrated
    time tau = 1 + 2 sum rho_k (k = 1 ... the first lag where rho_k <
    BLOCK_ACF_END; resid (n,), or (n, m) channels: the longest of theirs), a
    block BLOCK_TAU_K tau rows long, shortened to leave at least BLOCK_MIN
    blocks.  None when the residual is close to white (tau <
    BLOCK_MIN_TAU) or too few rows make BLOCK_MIN blocks of 2 rows.  The
    residual is clipped at 3 robust sigma first (an outlier row is no
    correlation)."""
    n = len(resid)
    if n < 2 * BLOCK_MIN:
        return None
    r = np.asarray(resid, float)
    return blocks_of(n, max(integrated_time(c) for c in r.reshape(n, -1).T))


def blocks_of(n: int, tau: float) -> np.ndarray | None:
    """Block labels of n consecutive rows for residuals of integrated
    autocorrelation time tau (rows): blocks BLOCK_TAU_K tau rows long,
    shortened to leave at least BLOCK_MIN; None when tau < BLOCK_MIN_TAU or
    the rows make fewer than BLOCK_MIN blocks of 2 rows (time_blocks)."""
    if n < 2 * BLOCK_MIN or tau < BLOCK_MIN_TAU:
        return None
    L = max(2, min(int(np.ceil(BLOCK_TAU_K * tau)), n // BLOCK_MIN))
    return np.arange(n) // L


def integrated_time(resid) -> float:
    """A residual's integrated autocorrelation time in rows, 1 + 2 sum
    rho_k over k = 1 ... the first lag where rho_k < BLOCK_ACF_END (at most
    n / BLOCK_MIN): 1 for white rows; the residual clipped at 3 robust sigma
    first (an outlier row is no correlation)."""
    r = np.asarray(resid, float)
    n = len(r)
    r = r - np.median(r)
    s = 1.4826 * float(np.median(np.abs(r)))
    if s <= 0 or n < 2 * BLOCK_MIN:
        return 1.0
    r = np.clip(r, -3 * s, 3 * s)
    r -= r.mean()
    c0 = float(r @ r)
    tau = 1.0
    for k in range(1, n // BLOCK_MIN):
        rho = float(r[:-k] @ r[k:]) / c0
        if rho < BLOCK_ACF_END:
            break
        tau += 2.0 * rho
    return tau


def block_covariance(J, r, labels, A=None):
    """The sandwich covariance of a least-squares fit whose rows come in
    blocks that share their errors: A^-1 (sum_c s_c s_c^T) A^-1 B / (B - 1),
    A = J^T J, s_c = J_c^T r_c the block's score (J, r whitened, the rows
    fitted; labels each row's block; J None and r the rows' scores J_i^T r_i
    (n, p) with A given: a fit whose Jacobian is not held whole).  None with
    fewer than BLOCK_MIN blocks."""
    lab = np.asarray(labels)
    _, c = np.unique(lab, return_inverse=True)
    B = int(c.max()) + 1
    if B < BLOCK_MIN:
        return None
    scores = np.asarray(r, float) if J is None else J * r[:, None]
    S = np.zeros((B, scores.shape[1]))
    np.add.at(S, c, scores)
    Ai = np.linalg.inv(J.T @ J if A is None else A)
    return B / (B - 1.0) * Ai @ (S.T @ S) @ Ai


def hold_covariance(raw, labels, keep, R, sigma, fit=None):
    """The covariance of a fit whose rows come in static holds that each
    share an error, counting each hold once -- and neighbouring holds within
    holds.HOLD_MERGE_DEG of each other once together, when that leaves at
    least 12 (the larger covariance of the two).  (covariance, the holds or
    clusters it counts, the holds found); None when too few holds keep a
    row.

    * The holds alone fitted (every kept row held): the row fit's own
      covariance with each hold's rows sharing an error (cluster_covariance;
      fit: the row fit's (M, b) on raw[keep], refitted when not given).  A
      fit to the holds' mean readings is another estimator: the row fit
      weighs a hold by its rows (the MPU-6050 session's first hold, 36.5 s
      still, is half its rows), and that fit of 15 orientations, equal
      weights and 6 degrees of freedom, stated the offsets' sigma up to 3.5
      times what holds left out of the fit showed (tests/data/real/
      mpu6050_tedaldi, a jackknife over its 54 holds).
    * Rows read while moving fitted too (the holds alone leave the
      ellipsoid nearly free): the fit to the holds' mean readings, scaled by
      their scatter, what the holds alone determine: the moving rows' part
      of the fit errs with the turn's own acceleration (one way, in a turn),
      which their residuals do not show."""
    from inclino import holds

    lab = np.where(keep, labels, -1)
    used = np.unique(lab[lab >= 0])
    if len(used) < 12:
        return None
    idx = np.full(int(labels.max()) + 1, -1)
    idx[used] = np.arange(len(used))
    lab = np.where(lab >= 0, idx[np.maximum(lab, 0)], -1)
    rows_fit = bool(np.all(lab[keep] >= 0))
    if rows_fit:
        if fit is None:
            try:
                M, b, _, _ = fit_sphere(raw[keep], R, sigma, min_rows=12)
            except (DataError, CalibrationError):
                return None
        else:
            M, b = fit
        x = np.concatenate([np.asarray(M, float)[np.triu_indices(3)], np.asarray(b, float)])
        J = _sphere_jac(x, raw[keep], R) / sigma
        r = _sphere_residual(x, raw[keep], R) / sigma
    best = None
    for lab_k, k in ((lab, len(used)), holds.merge_neighbours([raw], lab, len(used))):
        if k < 12 or (best is not None and k == best[1]):
            continue
        if rows_fit:
            c9 = cluster_covariance(J, r, lab_k[keep])
            if c9 is None:
                continue
            covh = _SYM_TO_FULL @ c9 @ _SYM_TO_FULL.T
        else:
            try:
                _, _, covh, _ = fit_sphere(holds.means(raw, lab_k, k), R, sigma, min_rows=12)
            except (DataError, CalibrationError):
                continue
        if best is None or np.trace(covh) > np.trace(best[0]):
            best = (covh, k, len(used))
    return best


def cluster_covariance(J, r, labels, kinds: int = 1):
    """Covariance of a least-squares fit (J, r whitened, the rows fitted)
    whose rows come in clusters that share an error (labels: each row's
    cluster, 0 ...; with kinds > 1, J and r stack that many kinds of
    residual for the same rows, kind after kind, e.g. the |b| and the dip
    residuals of calib.pose_free).  Each kind's residual is split into a
    within-cluster variance and a between-cluster (kinds x kinds)
    covariance, method of moments with each kind's share of the k fitted
    parameters (its part of the hat matrix's trace: k for one kind) taken
    out, and the fit's covariance is A^-1 (sum_c J_c^T V_c J_c) A^-1, A =
    J^T J (the row fit is not the clusters' GLS: its own weights, the
    clusters' noise): a model of the errors that holds with a dozen
    clusters, where the scores' own sandwich does not.  None with k + 1
    clusters or fewer."""
    k = J.shape[1]
    m = len(labels)
    _, c = np.unique(np.asarray(labels), return_inverse=True)
    H = int(c.max()) + 1
    if H <= k + 1:
        return None
    R = np.asarray(r, float).reshape(kinds, m).T
    Jk = [J[q * m:(q + 1) * m] for q in range(kinds)]
    cnt = np.bincount(c, minlength=H).astype(float)
    mean = np.zeros((H, kinds))
    np.add.at(mean, c, R)
    mean /= cnt[:, None]
    v_w = ((R - mean[c]) ** 2).sum(0) / max(m - H, 1)  # each kind's within-cluster variance of one row
    Ai = np.linalg.inv(J.T @ J)
    # between clusters: the means' scatter less the rows' own share, inflated for what the fitted parameters
    # absorb of it
    lev = np.array([np.sum(Ai * (Jq.T @ Jq)) for Jq in Jk])
    f = np.sqrt(H / np.maximum(H - lev, 1.0))
    B = ((mean.T @ mean) / H - np.diag(v_w * np.mean(1.0 / cnt))) * np.outer(f, f)
    wv, V = np.linalg.eigh(B)
    B = (V * np.clip(wv, 0.0, None)) @ V.T
    S = []
    for Jq in Jk:
        Sq = np.zeros((H, k))
        np.add.at(Sq, c, Jq)
        S.append(Sq)
    meat = sum(Jq.T @ Jq * v_w[q] for q, Jq in enumerate(Jk))
    meat += sum(S[p].T @ S[q] * B[p, q] for p in range(kinds) for q in range(kinds))
    return Ai @ meat @ Ai


# the 9 numbers of a symmetric M (upper triangle, row-major) and b onto the 12 of (M row-major, b)
_SYM_TO_FULL = np.zeros((12, 9))
for _k, (_i, _j) in enumerate(zip(*np.triu_indices(3))):
    _SYM_TO_FULL[3 * _i + _j, _k] = _SYM_TO_FULL[3 * _j + _i, _k] = 1.0
_SYM_TO_FULL[9:12, 6:9] = np.eye(3)
