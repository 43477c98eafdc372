"""The diagnosis' noise model: per-channel white sensor noise plus the
turntable's pose readout error through the pose Jacobian, fitted to the
residual products (method of moments, or maximum likelihood).

Its own module so that core.py (the stepwise fit) and robust.py (outlier
rejection, which refits the noise) both import it and not each other.
"""
from __future__ import annotations

from dataclasses import dataclass

import numpy as np
from scipy import optimize


@dataclass
class Noise:
    sigma: np.ndarray  # (6,) per channel, raw units
    sigma_pose: np.ndarray  # (3,) deg on inc, azi, tf

    def row_cov(self, J) -> np.ndarray:
        S = np.einsum("nik,k,njk->nij", J, self.sigma_pose ** 2, J)
        S[:, range(6), range(6)] += self.sigma ** 2
        return S

    def whitener(self, J) -> np.ndarray:
        """Per row W with W S W^T = I (S = row_cov(J)): whitened r = W r."""
        return whitener_of(self.row_cov(J))

    def sensor_part(self, R, J, axes=(0, 1, 2)) -> np.ndarray:
        """R minus each row's turntable readout error, estimated from R by
        its conditional mean given the noise model (P J^T Sigma^-1 r): the
        error the probe makes against the pose it really sat at.  axes: the
        turntable axes (0 inc, 1 azi, 2 tf) whose readout error is taken
        out (the others' stays in R)."""
        S = self.row_cov(J)
        u = np.linalg.solve(S, R[..., None])[..., 0]
        delta = np.einsum("k,nik,ni->nk", self.sigma_pose ** 2, J, u)
        ax = list(axes)
        return R - np.einsum("nik,nk->ni", J[:, :, ax], delta[:, ax])

    def to_dict(self):
        return {"acc_g": self.sigma[:3].tolist(), "mag_nT": self.sigma[3:].tolist(),
                "pose_deg": {"inc": float(self.sigma_pose[0]), "azi": float(self.sigma_pose[1]),
                             "tf": float(self.sigma_pose[2])}}


def whitener_of(S) -> np.ndarray:
    """Per row W (n, 6, 6) with W S W^T = I, for covariances S (n, 6, 6).

    The inverse Cholesky factor, where S factors.  S mixes g and nT (12
    decades apart) and, where a pose Jacobian is large, a rank-3 pose part
    many decades above the sensor noise, so Cholesky can fail on a matrix
    that is positive definite in exact arithmetic.  Then the rows are
    whitened on the correlation matrix D^-1 S D^-1 (D: the channels' sd) by
    eigenvalues, a direction whose eigenvalue is below 1e-12 of the largest
    (numerically null) counted at that floor: W = Lambda^-1/2 V^T D^-1."""
    try:
        return np.linalg.inv(np.linalg.cholesky(S))
    except np.linalg.LinAlgError:
        pass
    sd = np.sqrt(np.diagonal(S, axis1=1, axis2=2))
    C = S / (sd[:, :, None] * sd[:, None, :])
    lam, V = np.linalg.eigh(C)
    lam = np.maximum(lam, 1e-12 * lam[:, -1:])
    return np.swapaxes(V, 1, 2) / np.sqrt(lam)[:, :, None] / sd[:, None, :]


_IU = np.triu_indices(6)
SIGMA_FLOOR = np.array([1e-9] * 3 + [1e-5] * 3)  # g, nT


def fit_noise(R: np.ndarray, J: np.ndarray, dof_frac: float = 1.0, start: "Noise | None" = None,
              ml: bool = True) -> Noise:
    """Variance components from the residuals R (n, 6): E[r r^T] =
    diag(s_c^2) + J diag(p_k^2) J^T.  A method-of-moments start (non-negative
    least squares on the 21 distinct products of every row, each pair scaled
    by its typical size; or `start`), then Gaussian maximum likelihood."""
    n = len(R)
    scale = np.sqrt(np.maximum(np.mean(R ** 2, 0), 1e-300))
    if start is not None:
        v0, q0 = (start.sigma ** 2) * dof_frac, (start.sigma_pose ** 2) * dof_frac
    else:
        prod = (R[:, :, None] * R[:, None, :])[:, _IU[0], _IU[1]]  # (n, 21)
        w = 1.0 / (scale[_IU[0]] * scale[_IU[1]])
        X = np.zeros((n, 21, 9))
        diag = _IU[0] == _IU[1]
        for c in range(6):
            X[:, np.flatnonzero(diag & (_IU[0] == c))[0], c] = 1.0
        X[:, :, 6:] = J[:, _IU[0], :] * J[:, _IU[1], :]
        A = (X * w[None, :, None]).reshape(-1, 9)
        b = (prod * w[None, :]).ravel()
        colscale = np.maximum(np.abs(A).max(0), 1e-300)
        sol = np.linalg.lstsq(A / colscale, b, rcond=None)[0] / colscale  # a start: clipped below
        # a moment estimate can be 0: start every sensor variance at least at
        # a tenth of what the channel shows
        v0 = np.maximum(sol[:6], (0.1 * scale) ** 2)
        q0 = np.maximum(sol[6:], 1e-12)
    if ml:
        v, q = _ml_variances(R, J, v0, q0, scale)
    else:
        v, q = v0, q0
    # a floor far below any sensor's noise, so that noise-free (simulated) data do not make the covariance singular
    v = np.maximum(v, SIGMA_FLOOR ** 2)
    return Noise(sigma=np.sqrt(v / dof_frac), sigma_pose=np.sqrt(q / dof_frac))


def _ml_variances(R, J, v0, q0, scale):
    """Gaussian maximum likelihood of the nine variance components (sensor
    per channel, turntable per axis), L-BFGS on their logarithms with the
    analytic gradient.  Each sensor variance is kept above (1e-3 x the
    channel's residual RMS)^2 so that no channel gets an absurd weight."""
    n = len(R)
    lo = np.log(np.concatenate([(1e-3 * scale) ** 2, np.full(3, 1e-16)]))
    Rs = R / scale  # work in units of each channel's RMS
    Js = J / scale[None, :, None]

    def nll(theta):
        e = np.exp(theta)
        v, q = e[:6] / scale ** 2, e[6:]
        # batched products, not einsum's generic loops (this is most of a diagnosis' time); the gradient
        # from W = Si - u u^T without forming W: diag(W) = diag(Si) - u^2, J^T W J = J^T Si J - (J^T u)^2
        S = (Js * q) @ np.swapaxes(Js, 1, 2)
        S[:, range(6), range(6)] += v
        L = np.linalg.cholesky(S)
        Si = np.linalg.inv(S)
        u = (Si @ Rs[:, :, None])[:, :, 0]
        val = 2 * np.log(np.diagonal(L, axis1=1, axis2=2)).sum() + float((u * Rs).sum())
        gv = (np.diagonal(Si, axis1=1, axis2=2).sum(0) - (u * u).sum(0)) / scale ** 2
        Ju = (np.swapaxes(Js, 1, 2) @ u[:, :, None])[:, :, 0]
        gq = ((Si @ Js) * Js).sum((0, 1)) - (Ju * Ju).sum(0)
        grad = np.concatenate([gv, gq]) * e
        return 0.5 * val / n, 0.5 * grad / n

    hi = np.log(np.concatenate([(10.0 * scale) ** 2, np.full(3, 100.0)]))  # <= 10x the RMS; <= 10 deg
    # two starts: the given one, and one with each pose variance at a tenth of what the channels show
    # through it -- a variance started near zero barely moves in log-variance (its gradient is
    # proportional to it), so a start from a fit where one effect swamped the pose error would stay there
    jk = np.mean((J / scale[None, :, None]) ** 2, axis=(0, 1))
    q_mod = 0.1 / np.maximum(jk, 1e-300)
    best, th = None, None
    for q_start in (q0, np.maximum(q0, q_mod)):
        theta0 = np.minimum(np.maximum(np.log(np.concatenate([v0, q_start])), lo), hi)
        try:
            res = optimize.minimize(nll, theta0, jac=True, method="L-BFGS-B",
                                    bounds=list(zip(lo, hi)), options={"maxiter": 200})
            cand, f = res.x, res.fun
        except np.linalg.LinAlgError:
            cand, f = theta0, np.inf
        if best is None or f < best:
            best, th = f, cand
    e = np.exp(th)
    return e[:6], e[6:]


# --------------------------------------------------------------------------
# the whitened linear model on Gram matrices
