"""Keeping an adaptive run diagnosable (inclino.procedures.adaptive;
docs/calibration.md, "What the adaptive plan keeps diagnosable").

`inclino diagnose` names an effect from its signature outside the baseline's
span: for candidate k, z_k = the norm of its whitened regressor once the 25
baseline columns have absorbed what they can (diagnose.plans.signature_z),
z_k^2 = 1 / [(G_{b+k})^-1]_kk with G_{b+k} the Gram matrix of the baseline
and that regressor over the run's rows.  The static candidates a turntable
run can test at one temperature -- the scale nonlinearity of each axis, the
turntable's inclination and azimuth offsets, its azimuth-axis tilt and
inclination-axis skew -- get a floor: the run may not stop before every z_k
is at least `share` times what the multi-position procedure's 94 poses give
(so the smallest effect diagnose names is at most 1/share times today's).
Their signatures on every candidate pose are computed once, with the
diagnose bench's probe and noise (diagnose.plans.PROBE), and the design adds
to its criterion sum_k (share z_ref_k / z_k)^2, whose decrease for a
reading is again a rank-6 update: the poses are chosen for both.

The field drift (it grows with the run's duration), the sample skew
(continuous rotation) and the temperature effects (a temperature that moves)
are not static candidates: the floor leaves them to the run's time and
temperatures (the bench reports what each run can test).
"""
from __future__ import annotations

import functools

import numpy as np

STATIC = ("scale-nonlinearity", "turntable-inclination-offset", "turntable-azimuth-offset",
          "turntable-azimuth-axis-tilt", "turntable-inclination-axis-skew")


def _candidates():
    from inclino.diagnose import core

    return [c for c in core.all_candidates() if c.name in STATIC]


def whitened_columns(poses) -> tuple[np.ndarray, int, list]:
    """(Xw (n, 6, 25 + k), 25, candidate keys): the diagnose baseline's
    columns and the static candidates' regressors at `poses`, each row
    whitened by the diagnose bench's noise (as plans.signature_z)."""
    from inclino.diagnose import core, plans

    I, A, T = (np.asarray(p, float) for p in poses)
    n = len(I)
    plan = {"kind": "static", "inc": I, "azi": A, "tf": T, "t_s": np.arange(n, dtype=float), "temp_c": np.full(n, 25.0)}
    d, _, _, bl, cols = plans.true_baseline(plans.PROBE, plan)
    cands = _candidates()
    X = np.stack(cols + [core.regressor(d, bl, k) for k in cands], -1)
    noise = plans.true_noise()
    Linv = noise.whitener(bl.Jpose)
    return np.einsum("nij,njp->nip", Linv, X), len(cols), [k.key for k in cands]


@functools.lru_cache(maxsize=1)
def reference_z() -> tuple:
    """z_k on the multi-position procedure's poses (the floor's reference)."""
    from inclino.procedures.acquire import procedure_steps

    st = procedure_steps("multi-position")
    Xw, nb, _ = whitened_columns(tuple(np.array([getattr(x, a) for x in st]) for a in ("inc", "azi", "tf")))
    G = np.einsum("nip,niq->pq", Xw, Xw)
    return tuple(_z(G, nb))


def _z(G: np.ndarray, nb: int) -> np.ndarray:
    out = []
    for k in range(nb, G.shape[0]):
        idx = list(range(nb)) + [k]
        Gk = G[np.ix_(idx, idx)]
        d = np.sqrt(np.clip(np.diag(Gk), 1e-300, None))
        try:
            v = np.linalg.inv(Gk / np.outer(d, d))[-1, -1] / d[-1] ** 2
        except np.linalg.LinAlgError:
            v = np.inf
        out.append(1.0 / np.sqrt(v) if np.isfinite(v) and v > 0 else 0.0)
    return np.array(out)


class Floor:
    """The run's diagnosability so far and the floor's part of the design."""

    RIDGE = 1e-9  # relative: keeps the Gram invertible before the baseline is determined

    def __init__(self, cand_poses, share: float = 0.5):
        self.share = float(share)
        self.Xc, self.nb, self.keys = whitened_columns(cand_poses)
        self.z_ref = np.array(reference_z())
        p = self.Xc.shape[-1]
        self.G = np.zeros((p, p))
        scale = np.einsum("nip,nip->p", self.Xc, self.Xc) / len(self.Xc)
        self.ridge = np.diag(self.RIDGE * scale)

    def add(self, j: int) -> None:
        self.G += self.Xc[j].T @ self.Xc[j]

    def z(self) -> np.ndarray:
        return _z(self.G + self.ridge, self.nb)

    def ratios(self) -> dict:
        return dict(zip(self.keys, (self.z() / self.z_ref).tolist()))

    def met(self) -> bool:
        return bool(np.all(self.z() >= self.share * self.z_ref))

    def gains(self) -> np.ndarray:
        """Decrease of sum_k (share z_ref_k)^2 / z_k^2 for one more reading at
        each candidate pose (the rank-6 update of each [G_{b+k}]^-1)."""
        out = np.zeros(len(self.Xc))
        Gr = self.G + self.ridge
        for j, k in enumerate(range(self.nb, Gr.shape[0])):
            w = (self.share * self.z_ref[j]) ** 2
            idx = list(range(self.nb)) + [k]
            Gk = Gr[np.ix_(idx, idx)]
            d = np.sqrt(np.clip(np.diag(Gk), 1e-300, None))  # the columns' units differ by orders of magnitude
            C = np.linalg.inv(Gk / np.outer(d, d)) / np.outer(d, d)
            Jc = self.Xc[:, :, idx]  # (m, 6, q)
            A = Jc @ C
            S = np.eye(6)[None] + A @ np.swapaxes(Jc, 1, 2)
            a = A[:, :, -1]  # (m, 6): J_c C e_k
            out += w * np.einsum("mi,mij,mj->m", a, np.linalg.inv(S), a)
        return out

    def criterion(self) -> float:
        z = self.z()
        return float(np.sum((self.share * self.z_ref / np.maximum(z, 1e-300)) ** 2))
