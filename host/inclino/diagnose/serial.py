"""Serially correlated rows in a posed diagnosis' F-test.

The F-test of a candidate treats the whitened rows as independent.  A log
read while the probe moves (BROAD's hand-turned IMU under an optical
reference: the reference's own error, the hand's acceleration and a
timing offset all change slowly from row to row), or many readings held at
one pose with one pose error, breaks that: neighbouring rows share part of
their error, and a smooth regressor -- a scale nonlinearity along a slow
sweep, a field that follows a rig axis -- gains a large F from slow error
alone.  On BROAD's trial 05 the magnetometer's residuals keep a lag-1
correlation of 0.16-0.36 after the fit, still 0.1-0.3 at lag 5.

For the estimate b = sum(x e) / sum(x x) of one regressor x (with the
model's other columns projected out) under errors e with autocorrelation
rho_e(k), the variance is the independent rows' times

    f = 1 + 2 sum_k rho_e(k) rho_x(k)        (Bartlett 1946)

with rho_x the regressor's own autocorrelation, taken here per whitened
channel and summed over the channels by their weight in x.  `factor` gives
f for the candidate's fitted signature (its columns combined by their fitted
coefficients, the model's columns projected out) against the residual of
the model *with* the candidate (its own signal is not noise), in time
order, to SERIAL_MAX_LAG lags under a Bartlett taper, and never below 1.
The F statistic is divided by it, and its denominator degrees of freedom
too (as core.Design.ftest does with a scalar inflation), and a kept
effect's standard error is multiplied by its square root.

The correction is used only where the residual is seen to be serially
correlated: a Ljung-Box test of the first LJUNG_BOX_LAGS lags on each
channel, at GATE_P (Bonferroni over the channels).  On independent rows
(the emulator's plans, with one turntable error per reading) the estimated
f would only add its own sampling noise (about 2 sqrt(L / 3n) for a smooth
regressor) to every test.
"""
from __future__ import annotations

import numpy as np
from scipy import stats

LJUNG_BOX_LAGS = 10
GATE_P = 1e-3
SERIAL_MAX_LAG = 200  # the Bartlett window: sqrt(n) lags, at most this many


def max_lag(n: int) -> int:
    return int(min(SERIAL_MAX_LAG, max(LJUNG_BOX_LAGS, np.ceil(np.sqrt(n))), max(n // 4, 1)))


def _lagged_sums(des, S1, w_x, w_e, L):
    """Per channel, sum_n z[n] z[n+k] for k = 0..L of the signature
    x = Xw[S1] w_x and of the residual e = yw - Xw[S1] w_e (_series).
    Returns (gx, ge), each (L + 1, m)."""
    x, e = _series(des, S1, w_x, w_e)
    return _autocov(x, L), _autocov(e, L)


def _series(des, S1, w_x, w_e):
    """The signature x = Xw[S1] w_x and the residual e = yw - Xw[S1] w_e
    (whitened, (n, m), rows in time order: the design's, or its
    `serial_order`).  The columns are combined before they are whitened
    (whitening is linear: one n x 6 x 6 product instead of one per
    column)."""
    n, m = des.yw.shape
    p = des.Xraw.shape[-1]
    S1 = np.asarray(S1, int)
    W = np.zeros((p, 2))
    W[S1, 0] = np.asarray(w_x, float) / des.colscale[S1]
    W[S1, 1] = np.asarray(w_e, float) / des.colscale[S1]
    XW = (des.Xraw.reshape(-1, p) @ W).reshape(n, m, 2)
    x = np.einsum("nij,nj->ni", des.Linv, XW[:, :, 0])
    e = des.yw - np.einsum("nij,nj->ni", des.Linv, XW[:, :, 1])
    order = getattr(des, "serial_order", None)
    if order is not None:
        x, e = x[order], e[order]
    return x, e


def _autocov(z, L):
    """(L + 1, m): sum_n z[n] z[n+k] per column, k = 0..L (zero-padded FFT)."""
    n = len(z)
    nfft = 1 << int(np.ceil(np.log2(max(2 * n, 2))))
    F = np.fft.rfft(z, nfft, axis=0)
    return np.fft.irfft(F * np.conj(F), nfft, axis=0)[:L + 1]


def ljung_box_q(rho, n) -> tuple:
    """(p, Q) of the Ljung-Box test of the autocorrelations rho (lags
    1..h) of n values: Q = n (n + 2) sum_k rho_k^2 / (n - k), chi-square
    with h degrees of freedom."""
    h = len(rho)
    Q = n * (n + 2) * float(np.sum(np.asarray(rho) ** 2 / np.maximum(n - np.arange(1, h + 1), 1)))
    return float(stats.chi2.sf(Q, h)), Q


def highpass(r, frac: float = 0.02):
    """r (n, k) minus its running mean over about frac of the rows (at
    least 5): what varies from one row to the next, without the slow part."""
    n = len(r)
    w = max(5, int(frac * n)) | 1
    if n < 3 * w:
        return r - r.mean(0)
    k = np.ones(w) / w
    sm = np.column_stack([np.convolve(np.pad(r[:, j], w // 2, mode="edge"), k, mode="valid") for j in range(r.shape[1])])
    return r - sm


def row_correlated(y, channels: int) -> bool:
    """Whether a residual (time order) correlates from row to row once its
    slow part is taken off (highpass): a Ljung-Box test of LJUNG_BOX_LAGS
    lags at GATE_P, Bonferroni over the channels.  Slow structure alone (a
    drift, a temperature the model lacks) leaves the high-passed residual
    white, and the tests that read it exact."""
    if len(y) < 5 * LJUNG_BOX_LAGS:
        return False
    z = highpass(np.asarray(y, float)[:, None])[:, 0]
    z = z - z.mean()
    den = float(z @ z)
    if den <= 0:
        return False
    rho = np.array([float(z[k:] @ z[:-k]) / den for k in range(1, LJUNG_BOX_LAGS + 1)])
    p, _ = ljung_box_q(rho, len(z))
    return bool(p < GATE_P / max(channels, 1))


def ljung_box_p(ge, n) -> float:
    """The smallest Ljung-Box p-value over the channels of the lags in ge."""
    m = min(LJUNG_BOX_LAGS, ge.shape[0] - 1)
    with np.errstate(all="ignore"):
        rho = ge[1:m + 1] / np.maximum(ge[0], 1e-300)
    return min(ljung_box_q(rho[:, j], n)[0] for j in range(rho.shape[1]))


def factor(des, S, extra, w=None) -> dict:
    """The variance inflation of the candidate `extra` tested against the
    model S: {"f", "lb_p", "gated", "lag1"}; f = 1 unless the residual of
    S + extra fails the Ljung-Box test.  w: the combination of the
    candidate's (scaled) columns to weigh, default its fitted one (a
    signature of known shape, on data that do not hold it)."""
    S, extra = list(S), list(extra)
    S1 = S + extra
    n = int(des.rows.sum())
    beta1, _ = des.fit(S1)
    # the candidate's signature with the model's other columns projected out: w on S1 =
    # (-G_SS^-1 G_Se b_e, b_e)
    be = beta1[len(S):] if w is None else np.asarray(w, float)
    proj = des._solve(des.G[np.ix_(S, S)], des.G[np.ix_(S, extra)] @ be) if S else np.zeros(0)
    w_x = np.concatenate([-proj, be])
    L = max_lag(n)
    x, e = _series(des, S1, w_x, beta1)
    gx, ge = _autocov(x, L), _autocov(e, L)
    lb = ljung_box_p(ge, n)
    m = ge.shape[1]
    with np.errstate(all="ignore"):
        rho_e = ge / np.maximum(ge[0], 1e-300)
    lag1 = [float(v) for v in rho_e[1]]
    if lb >= GATE_P / m or gx[0].sum() <= 0:
        return {"f": 1.0, "lb_p": lb, "gated": False, "lag1": lag1}
    taper = 1.0 - np.arange(1, L + 1) / (L + 1.0)
    num = gx[0].sum() + 2.0 * np.sum(taper[:, None] * gx[1:] * rho_e[1:])
    f = float(max(1.0, num / gx[0].sum(), _ar_factor(x, e)))
    return {"f": f, "lb_p": lb, "gated": True, "lag1": lag1}


def _ar_factor(x, e) -> float:
    """The Bartlett factor of the signature x against the residual e (both
    (n, m), time order) with each channel's rho_e from an AR(p) model of its
    residual (ar_fit), summed over every lag: the window of max_lag lags
    under its taper cuts a long correlation short (AR(1) errors, phi 0.95,
    a slow sweep: 23 where the error model gives 37)."""
    n, m = x.shape
    if n < 8:
        return 1.0
    gx = _autocov(x, n - 1)
    if gx[0].sum() <= 0:
        return 1.0
    num = gx[0].sum()
    for j in range(m):
        phi, _ = ar_fit(e[:, j])
        if len(phi):
            num += 2.0 * float(np.sum(gx[1:, j] * ar_autocorr(phi, n - 1)[1:]))
    return float(num / gx[0].sum())


def scale_cov(des, S, cov, groups) -> list:
    """The covariance `cov` of the columns S (in that order), each group's
    rows and columns scaled by the square root of its serial inflation
    (its test against the rest of S): a kept effect's standard error under
    the rows' correlation.  groups: the column indices of each effect.
    Scales cov in place; returns the factors, in the groups' order."""
    S = list(S)
    fs = []
    for cols in groups:
        f = max(des.serial_factor([i for i in S if i not in cols], cols), des.inflation)
        pos = [S.index(i) for i in cols]
        s = np.ones(len(S))
        s[pos] = np.sqrt(f)
        cov *= np.outer(s, s)
        fs.append(float(f))
    return fs


def summary(des, S) -> dict:
    """The residual of the model S in time order: each channel's lag-1
    correlation and the Ljung-Box p-value (the smallest over the channels),
    and whether the F-tests are corrected (the test's gate)."""
    S = list(S)
    n = int(des.rows.sum())
    beta, _ = des.fit(S)
    L = min(LJUNG_BOX_LAGS, max_lag(n))
    _, ge = _lagged_sums(des, S, np.zeros(len(S)), beta, L)
    lb = ljung_box_p(ge, n)
    with np.errstate(all="ignore"):
        lag1 = ge[1] / np.maximum(ge[0], 1e-300)
    return {"lag1": [float(v) for v in lag1], "ljung_box_p": lb, "lags": L,
            "correlated": bool(lb < GATE_P / ge.shape[1]), "max_lag": max_lag(n),
            "what": ("neighbouring rows' residuals (time order) share their error: each F-test is deflated by the "
                     "Bartlett factor 1 + 2 sum_k rho_e(k) rho_x(k) of its candidate's signature x against the "
                     "residual e of the model with it, and a named effect's standard error grows by its square root, "
                     f"where a Ljung-Box test of {LJUNG_BOX_LAGS} lags finds the rows correlated (p < {GATE_P:g} over "
                     "the channels)")}


def columns_factor(Z, e, L=None) -> float:
    """The Bartlett factor of an F-test of the columns Z (n, q; rows in
    time order, the test's other columns already projected out) against
    the residual e (n,) of the model with them: f = 1 + 2 sum_k rho_e(k)
    rho_Z(k), rho_Z the autocorrelation of Z's span (the lagged sums of an
    orthonormal basis added over its columns, so that it does not depend
    on the basis: the mean of the q directions' factors, which is what the
    F statistic's numerator, a sum over them, is inflated by).  rho_e is
    taken two ways and the larger f kept: the residual's own lagged sums to
    L lags (default max_lag) under the Bartlett taper, which follow any
    correlation within the window but cut a long one short (AR(1) errors,
    phi 0.95, a regressor of 3-5 cycles over 2000 rows: 23 where the error
    model gives 37), and an AR(p) model fitted to the residual (ar_fit),
    its autocorrelation summed over every lag.  Never below 1."""
    Z = np.asarray(Z, float).reshape(len(Z), -1)
    e = np.asarray(e, float)
    n = len(e)
    if n < 4 or not np.any(Z):
        return 1.0
    Q, R = np.linalg.qr(Z)
    d = np.abs(np.diag(R))
    Q = Q[:, d > 1e-10 * max(d.max(), 1e-300)]
    if Q.shape[1] == 0:
        return 1.0
    L = max_lag(n) if L is None else int(L)
    gx = _autocov(Q, n - 1).sum(1)
    ge = _autocov(e[:, None], L)[:, 0]
    if gx[0] <= 0 or ge[0] <= 0:
        return 1.0
    rho_x = gx / gx[0]
    taper = 1.0 - np.arange(1, L + 1) / (L + 1.0)
    f = 1.0 + 2.0 * float(np.sum(taper * rho_x[1:L + 1] * (ge[1:] / ge[0])))
    phi, _ = ar_fit(e)
    if len(phi):
        f = max(f, 1.0 + 2.0 * float(np.sum(ar_autocorr(phi, n - 1)[1:] * rho_x[1:])))
    return max(1.0, f)


AR_MAX_ORDER = 5  # the noise model a serially correlated residual is allowed: AR(p), p <= this, by AIC
AR_MAX_ROOT = 0.995  # an AR fit whose largest root's modulus passes this is pulled back to it (a near unit root)


def ar_fit(e, lags: int = LJUNG_BOX_LAGS) -> tuple:
    """(phi, innovations) of an AR(p) model of e (time order, its mean taken
    off), p = 1 .. AR_MAX_ORDER by AIC, least squares; ([], e) where the
    series is too short (under 4 (p + lags) values)."""
    e = np.asarray(e, float) - np.mean(e)
    n = len(e)
    best = None
    for p in range(1, AR_MAX_ORDER + 1):
        if n <= 4 * (p + lags):
            break
        X = np.column_stack([e[p - j - 1:n - j - 1] for j in range(p)])
        y = e[p:]
        c = np.linalg.lstsq(X, y, rcond=None)[0]
        u = y - X @ c
        s2 = float(u @ u) / len(u)
        if s2 <= 0:
            break
        aic = len(u) * np.log(s2) + 2 * p
        if best is None or aic < best[0]:
            best = (aic, c, u)
    if best is None:
        return np.zeros(0), e
    return best[1], best[2]


def ar_autocorr(phi, L: int) -> np.ndarray:
    """(L + 1,): the autocorrelation of the AR process x[n] = sum_j phi_j
    x[n - j] + u[n] at lags 0..L, from its spectrum (roots beyond
    AR_MAX_ROOT pulled back to it)."""
    phi = np.asarray(phi, float)
    roots = np.roots(np.concatenate([[1.0], -phi]))
    mod = np.abs(roots)
    if np.any(mod > AR_MAX_ROOT):
        roots = np.where(mod > AR_MAX_ROOT, roots / np.maximum(mod, 1e-300) * AR_MAX_ROOT, roots)
        phi = -np.real(np.poly(roots))[1:]
    nfft = 1 << int(np.ceil(np.log2(max(8 * (L + 1), 1024))))
    a = np.zeros(nfft)
    a[0], a[1:len(phi) + 1] = 1.0, -phi
    S = 1.0 / np.maximum(np.abs(np.fft.rfft(a)) ** 2, 1e-300)
    g = np.fft.irfft(S, nfft)
    return g[:L + 1] / g[0]


def prewhitened_ljung_box(e, lags: int = LJUNG_BOX_LAGS) -> tuple:
    """(p, order) of the Ljung-Box test of e (time order) once an AR(p)
    noise model (ar_fit) is taken off: whether the residual is more than
    noise correlated between neighbouring rows (a sensor's own low-pass
    filter, the probe's motion).  lags + p lags, lags degrees of freedom."""
    phi, u = ar_fit(e, lags)
    p = len(phi)
    if p == 0:
        return 1.0, 0
    u = u - u.mean()
    den = float(u @ u)
    if den <= 0:
        return 1.0, p
    rho = np.array([float(u[k:] @ u[:-k]) / den for k in range(1, lags + p + 1)])
    m = len(u)
    Q = m * (m + 2) * float(np.sum(rho ** 2 / (m - np.arange(1, len(rho) + 1))))
    return float(stats.chi2.sf(Q, lags)), p
