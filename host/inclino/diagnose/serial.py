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
    x = Xw[S1] w_x and of the residual e = yw - Xw[S1] w_e (whitened, rows in
    time order: the design's, or its `serial_order`).  The columns are
    combined before they are whitened (whitening is linear: one n x 6 x 6
    product instead of one per column), and the lagged sums are taken by
    FFT.  Returns (gx, ge), each (L + 1, m)."""
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
    return _autocov(x, L), _autocov(e, L)


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
    gx, ge = _lagged_sums(des, S1, w_x, beta1, L)
    lb = ljung_box_p(ge, n)
    m = ge.shape[1]
    with np.errstate(all="ignore"):
        rho_e = ge / np.maximum(ge[0], 1e-300)
    lag1 = [float(v) for v in rho_e[1]]
    if lb >= GATE_P / m or gx[0].sum() <= 0:
        return {"f": 1.0, "lb_p": lb, "gated": False, "lag1": lag1}
    taper = 1.0 - np.arange(1, L + 1) / (L + 1.0)
    num = gx[0].sum() + 2.0 * np.sum(taper[:, None] * gx[1:] * rho_e[1:])
    f = float(max(1.0, num / gx[0].sum()))
    return {"f": f, "lb_p": lb, "gated": True, "lag1": lag1}


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
