"""Levenberg-Marquardt for a least-squares fit whose Jacobian is never held
whole: the residuals and their finite-difference Jacobian are computed a
chunk of rows at a time and reduced to a P x P triangular factor.

Why: scipy's least_squares (method "lm", MINPACK) holds the whole m x P
Jacobian several times at once (the array the Jacobian function returns,
MINPACK's working copy, the one recomputed at the solution and MINPACK's
returned factor).  For the temperature fit of a 40 000-row chamber run
(m = 240 000 whitened residuals, P = 55) that is four 105 MB arrays, the
peak of `inclino calibrate --temperature-terms` on a long run.  Here the
memory of a step is one chunk of the Jacobian (CHUNK_ROWS rows, about 11 MB
at P = 55) and the P x P factor, whatever m is.

How: for each chunk c, the residuals f_c and their Jacobian J_c (the same
"2-point" differences as least_squares' default, `jacobian_2point`) are
folded into the triangular factor of the whole problem by a QR of
[R z; J_c f_c] (R^T R = J^T J and R^T z = J^T f, without forming J^T J:
the conditioning is that of J, as in MINPACK's own QR).  The step solves
min ||R p + z||^2 + lam ||D p||^2 (D: the running maximum of J's column
norms, MINPACK's scaling; least_squares' x_scale="jac"), with Nielsen's
damping update.  It stops as MINPACK does with least_squares' defaults:
the actual and predicted relative reductions of the sum of squares both
<= ftol, or the scaled step <= xtol times the scaled x, or the scaled
gradient <= gtol.  The minimum is the one least_squares finds (the same
residuals and Jacobian); the iterates differ.
"""
from __future__ import annotations

from dataclasses import dataclass

import numpy as np
from scipy import linalg

# Jacobian rows (residual values) per chunk: 24 576 x 55 doubles is 11 MB
CHUNK_ROWS = 24_576


def jacobian_2point(fun, x, layout="F", f0=None):
    """least_squares' default "2-point" finite differences of fun at x (step
    sqrt(eps) max(1, |x_i|) with x_i's sign, divided by the step as
    represented, from f0 = fun(x)), written one column at a time into one
    array ("F" order; "C" to view the rows as (n, 6, P))."""
    x = np.asarray(x, float)
    f0 = fun(x) if f0 is None else f0
    h = np.sqrt(np.finfo(float).eps) * np.where(x >= 0, 1.0, -1.0) * np.maximum(1.0, np.abs(x))
    J = np.empty((f0.size, x.size), order=layout)
    for i in range(x.size):
        xi = x.copy()
        xi[i] = x[i] + h[i]
        J[:, i] = (fun(xi) - f0) / (xi[i] - x[i])
    return J


@dataclass
class Result:
    """x, cost (half the sum of squares at x), m (the number of
    residuals), R (P x P upper triangular with R^T R = J^T J at x), status (1: reductions <= ftol, 2: step <=
    xtol, 3: gradient <= gtol, 0: max_iter reached), iterations, Jacobians
    computed (njev) and residual evaluations (nfev)."""
    x: np.ndarray
    cost: float
    m: int
    R: np.ndarray
    status: int
    iterations: int
    njev: int
    nfev: int

    @property
    def jtj(self) -> np.ndarray:
        return self.R.T @ self.R


def _fold(Rz, Jc, fc):
    """[R z] of [Rz; Jc fc] (QR, R only): the factor of the rows so far and this chunk's."""
    A = np.column_stack([Jc, fc]) if Rz is None else np.vstack([Rz, np.column_stack([Jc, fc])])
    return np.linalg.qr(A, mode="r")  # (min(rows, P + 1), P + 1)


def factor(fun, chunks, x, jac=None):
    """(R, z, cost, m) at x: R upper triangular P x P, z = Q^T f (R^T z =
    J^T f), cost = ||f||^2 / 2, m residuals, from each chunk's residuals
    fun(x, c) and their Jacobian jac(x, c) (None: 2-point differences), one
    chunk at a time."""
    P = len(x)
    Rz = None
    ss = 0.0
    m = 0
    for c in chunks:
        fc = fun(x, c)
        Jc = jacobian_2point(lambda xx: fun(xx, c), x, f0=fc) if jac is None else jac(x, c)
        ss += float(fc @ fc)
        m += len(fc)
        Rz = _fold(Rz, Jc, fc)
        del Jc
    Rz = np.vstack([Rz, np.zeros((max(0, P + 1 - Rz.shape[0]), P + 1))])  # fewer rows than P: padded
    return np.triu(Rz[:P, :P]), Rz[:P, P].copy(), 0.5 * ss, m


def cost_at(fun, chunks, x) -> float:
    return 0.5 * sum(float(np.dot(f, f)) for f in (fun(x, c) for c in chunks))


def solve(fun, chunks, x0, jac=None, ftol=1e-8, xtol=1e-8, gtol=1e-8, max_iter=200,
          factor_at_x=True) -> Result:
    """Minimise 0.5 sum_c ||fun(x, c)||^2 from x0 (fun(x, c): the residual
    vector of chunk c at x, each chunk's residuals depending on that chunk's
    data only; jac(x, c): its Jacobian, None for 2-point differences).  The first step is Gauss-Newton's (no damping), as
    MINPACK's first step when it fits its trust region; damping starts at
    1e-3 (in units of D^2) after a step that does not reduce the sum of
    squares.  factor_at_x False: the result's R is the one of the last
    Jacobian computed (one step before x), not computed again at x."""
    x = np.asarray(x0, float).copy()
    R, z, cost, m = factor(fun, chunks, x, jac)
    njev, nfev = 1, 1
    D = np.linalg.norm(R, axis=0)
    D[D == 0] = 1.0
    lam, nu = 0.0, 2.0
    status = 0
    it = 0
    stale = False
    while it < max_iter:
        it += 1
        g = R.T @ z  # J^T f
        fn = np.sqrt(2.0 * cost)
        cols = np.linalg.norm(R, axis=0)
        if fn == 0.0 or np.max(np.abs(g) / np.where(cols > 0, cols, np.inf)) <= gtol * fn:
            status = 3
            break
        A = np.vstack([R, np.diag(np.sqrt(lam) * D)])
        p = -linalg.lstsq(A, np.concatenate([z, np.zeros(len(x))]), check_finite=False)[0]
        x_new = x + p
        cost_new = cost_at(fun, chunks, x_new)
        nfev += 1
        Rp = R @ p + z
        pred = 0.5 * (float(z @ z) - float(Rp @ Rp))  # the linear model's reduction
        act = cost - cost_new if np.isfinite(cost_new) else -np.inf
        small_step = np.linalg.norm(D * p) <= xtol * (np.linalg.norm(D * x) + xtol)
        if pred > 0 and act > 1e-4 * pred:
            small_red = act <= ftol * cost and pred <= ftol * cost
            x, cost = x_new, cost_new
            rho = act / pred
            lam *= max(1.0 / 3.0, 1.0 - (2.0 * rho - 1.0) ** 3)
            lam = 0.0 if lam < 1e-6 else lam
            nu = 2.0
            if small_red or small_step:
                status = 1 if small_red else 2
                stale = True
                break
            R, z, cost, m = factor(fun, chunks, x, jac)
            njev += 1
            nfev += 1
            D = np.maximum(D, np.linalg.norm(R, axis=0))
        else:
            if small_step or pred <= 0 and abs(pred) <= ftol * cost:
                status = 2  # no step left that reduces the sum: at the minimum to rounding
                break
            lam = 1e-3 if lam == 0.0 else lam * nu
            nu *= 2.0
    if stale and factor_at_x:
        R, z, cost, m = factor(fun, chunks, x, jac)
        njev += 1
        nfev += 1
    return Result(x, cost, m, R, status, it, njev, nfev)


def row_chunks(n_rows: int, per_row: int, bounds=None):
    """Slices of 0..n_rows covering it in order, each at most CHUNK_ROWS
    Jacobian rows (per_row residuals a row); bounds: the only row indices a
    chunk may start at (e.g. where a cluster starts), sorted, 0 first."""
    step = max(1, CHUNK_ROWS // max(per_row, 1))
    if bounds is None:
        return [slice(lo, min(n_rows, lo + step)) for lo in range(0, n_rows, step)]
    bounds = np.asarray(bounds)
    out, lo = [], 0
    while lo < n_rows:
        if lo + step >= n_rows:
            out.append(slice(lo, n_rows))
            break
        i = int(np.searchsorted(bounds, lo + step, side="right")) - 1
        hi = int(bounds[i]) if i >= 0 and bounds[i] > lo else None
        if hi is None:  # one group larger than a chunk: taken whole
            j = int(np.searchsorted(bounds, lo, side="right"))
            hi = int(bounds[j]) if j < len(bounds) else n_rows
        out.append(slice(lo, hi))
        lo = hi
    return out
