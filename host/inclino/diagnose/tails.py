"""Heavy-tailed noise in a posed diagnosis' F-test.

The F-test of a candidate refers its statistic to the F distribution: exact
for Gaussian noise, and close to it for any noise when the candidate's
signature is spread over many rows (a sum of many independent terms).  A
signature that rests on a few rows -- a scale nonlinearity or a temperature
scale on Ren 2014's poses, where only a handful of readings load the axis
at the far end of its range and of the temperature cycle -- is a sum of a
few terms, and under heavy-tailed noise it has heavy tails itself: one large
error at such a row is read as the effect.  On the bench's nulls with
Student-t noise (3 degrees of freedom) the smallest of the candidates'
p-values fell below the Bonferroni point at 3-5 times the rate it should on
that plan, with the true noise variances (not estimates) used for the
whitening.

The sandwich test below is robust to that: the variance of the candidate's
estimate is taken from the residuals themselves, row by row (each row's six
whitened values one cluster: their errors may share a pose error, and a
row's channels are whitened together), instead of from the pooled residual
variance:

    V = A^-1 (sum_r u_r u_r^T) A^-1,   u_r = x_r^T e_r

with x the candidate's whitened columns once the model's others are
projected out, A = x^T x, and e_r the row's residual of the model with the
candidate, scaled by (I - H_rr)^-1/2 (H the hat matrix: Bell and McCaffrey
2002's bias-reduced CR2; without it the variance of a signature that rests
on a few rows, whose residuals the fit pulls towards zero, is under-stated).
The Wald statistic b^T V^-1 b is referred to Hotelling's T^2 with nu
degrees of freedom, nu = (sum_r s_r)^2 / sum_r s_r^2 with s_r the squared
norm of the fitted signature on row r (Satterthwaite: how many rows the
variance estimate rests on; the number of rows for a signature spread
evenly, one for a signature on one row).  One large error at a row the
candidate rests on inflates that row's share of V as much as it inflates the
estimate, so the statistic stays bounded.

It is used where the whitened residual is seen to be heavy-tailed: a
kurtosis test (Anscombe and Glynn 1983, one-sided: heavier than Gaussian)
on each whitened channel at GATE_P (Bonferroni over the channels); then a
test's p-value is the larger of the F-test's and the sandwich test's.
Gaussian noise (the emulator's, and the sensors' of most logs) seldom passes
the gate, and there the F-test alone is exact and more powerful.
"""
from __future__ import annotations

import numpy as np
from scipy import stats

GATE_P = 1e-3
MIN_ROWS = 20  # the kurtosis test needs this many
RANK_RTOL = 1e-9  # a direction of the tested columns that the model's others span: A's eigenvalue below this share


def gate(des, S) -> dict:
    """The kurtosis test of the whitened residual of the model S (rows
    fitted): {"p" (the smallest over the channels), "gated", "kurtosis"
    (excess, per whitened channel)}."""
    S = list(S)
    beta, _ = des.fit(S)
    rows = np.flatnonzero(des.rows)
    if len(rows) < MIN_ROWS:
        return {"p": 1.0, "gated": False, "kurtosis": [0.0] * des.yw.shape[1]}
    e = np.empty((len(rows), des.yw.shape[1]))
    for lo in range(0, len(rows), des.ROW_CHUNK):
        ix = rows[lo:lo + des.ROW_CHUNK]
        e[lo:lo + len(ix)] = des.yw[ix] - np.einsum("nip,p->ni", des.whitened(S, ix), beta)
    with np.errstate(all="ignore"):
        ps = [float(stats.kurtosistest(e[:, j], alternative="greater").pvalue) for j in range(e.shape[1])]
        kurt = [float(stats.kurtosis(e[:, j])) for j in range(e.shape[1])]
    ps = [p if np.isfinite(p) else 1.0 for p in ps]
    m = len(ps)
    return {"p": min(ps), "gated": bool(min(ps) < GATE_P / m), "kurtosis": kurt}


def sandwich(des, S, extra) -> dict:
    """The row-clustered, bias-reduced sandwich test of the columns `extra`
    against the model S: {"p", "wald", "nu"}."""
    S, extra = list(S), list(extra)
    S1 = S + extra
    k, q = len(S), len(extra)
    beta1, _ = des.fit(S1)
    G = des.G
    C = des._solve(G[np.ix_(S, S)], G[np.ix_(S, extra)]) if S else np.zeros((0, q))
    A = G[np.ix_(extra, extra)] - (G[np.ix_(extra, S)] @ C if S else 0.0)
    Gi = np.linalg.pinv(G[np.ix_(S1, S1)])
    b = beta1[k:]
    rows = np.flatnonzero(des.rows)
    B = np.zeros((q, q))
    sr = np.empty(len(rows))
    eye = np.eye(des.yw.shape[1])
    for lo in range(0, len(rows), des.ROW_CHUNK):
        ix = rows[lo:lo + des.ROW_CHUNK]
        Xw = des.whitened(S1, ix)  # (c, 6, p), scaled columns
        e = des.yw[ix] - np.einsum("nip,p->ni", Xw, beta1)
        M = eye[None] - (Xw @ Gi) @ np.swapaxes(Xw, 1, 2)
        w, V = np.linalg.eigh((M + np.swapaxes(M, 1, 2)) / 2)
        w = np.maximum(w, 1e-6)
        e = np.einsum("nij,nj->ni", (V / np.sqrt(w)[:, None, :]) @ np.swapaxes(V, 1, 2), e)
        xt = Xw[:, :, k:] - (Xw[:, :, :k] @ C if k else 0.0)
        u = np.einsum("niq,ni->nq", xt, e)
        B += u.T @ u
        sr[lo:lo + len(ix)] = (np.einsum("niq,q->ni", xt, b) ** 2).sum(1)
    # the test in the directions of `extra` that S does not span: along one that S spans (a rig field's
    # part that a kept field of another axis also is, analysis._rig_identify) the estimate is free and A
    # has no weight, and its pseudo-inverse there only amplifies rounding (a Wald statistic of -4e8 on a
    # field worth 1e5 in F, read as p = 1)
    wA, UA = np.linalg.eigh((A + A.T) / 2)
    keep = wA > RANK_RTOL * max(float(wA.max()), 1e-300)
    T = UA[:, keep] / wA[keep]  # A^-1 on the kept directions, as (q, r) factor: A^-1 = T UA_k^T
    bk = UA[:, keep].T @ b
    Vb = T.T @ B @ T  # the kept directions' covariance
    qe = int(keep.sum())
    wald = float(bk @ np.linalg.pinv(Vb) @ bk) if qe else 0.0
    nu = float(sr.sum() ** 2 / max(float((sr ** 2).sum()), 1e-300)) if sr.sum() > 0 else 0.0
    d2 = nu - qe + 1.0
    if not np.isfinite(wald) or qe == 0 or d2 < 1.0:
        return {"p": 1.0, "wald": wald, "nu": nu, "rank": qe}
    F = max(wald, 0.0) / qe * d2 / nu
    return {"p": float(stats.f.sf(F, qe, d2)), "wald": wald, "nu": nu, "rank": qe}


def summary(des, S) -> dict:
    """The gate on the residual of the model S, for the report."""
    g = gate(des, S)
    return {"kurtosis_excess": g["kurtosis"], "kurtosis_p": g["p"], "heavy_tailed": g["gated"],
            "what": ("a kurtosis test (one-sided, Anscombe-Glynn) of each whitened channel of the residual; where "
                     f"it finds tails heavier than Gaussian (p < {GATE_P:g} over the channels) each F-test's p-value is "
                     "the larger of the F-test's and a row-clustered, bias-reduced sandwich test's (its variance "
                     "from the residuals row by row, Satterthwaite's degrees of freedom): a signature that rests on "
                     "a few rows is not named for one large error there")}
