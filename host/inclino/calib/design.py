"""Which pose to read next: the optimal design of a calibration run
(`inclino acquire --procedure adaptive`, inclino.procedures.adaptive;
docs/calibration.md, "Adaptive runs").

The parameters are the joint fit's (calib.joint, the 31-entry nonlinear
layout: M_a, M_a b_a, M_m, M_m b_m, q_a, q_m, dip) and, for a run through a
chamber, the temperature terms of calib.thermal (bias and scale per axis of
each triad, powers 1..order of dT = T - t_ref; layout (triad, effect, power,
axis)).  At the current estimate, one reading at pose p and temperature T
adds J_p^T J_p to the Fisher information, J_p the whitened 6 x P Jacobian of
the fit's residuals (joint's whitening: sensor noise through M, the
turntable's readout error through the pose Jacobian; divided by the fit's
s^2 when there is one).

Criterion (I-optimal: the integrated variance over the acceptance grid, a
weighted A-optimality).  The error a parameter error d leaves at an
acceptance pose g and temperature T is a_gT^T d: the written linear
calibration moves by the best-linear map of joint (d best_linear / d x),
the attitude by calib.sensitivity's d(azimuth, inclination)/d(coefficients),
and a temperature term's error by d(attitude)/d(raw) times its effect on
the reading brought to t_ref.  With C the parameters' covariance,

    V_q(C) = mean over g, T of a_gT^T C a_gT = trace(C W_q),  q = azimuth, inclination

is the calibration's share of the acceptance's mean square error, and the
criterion is sum_q V_q / tau_q^2 (tau_q: the share the target leaves for the
calibration).  A candidate reading J_c lowers it by

    trace((I + J_c C J_c^T)^-1 J_c C W C J_c^T)          (the rank-6 update of C)

computed for every candidate at once; the procedure divides by the time the
reading costs (turntable move plus reading) and takes the best.

Before the first fit the estimate is the nominal probe (identity
calibration) and a weak prior (PRIOR_SIGMA: the size of an uncalibrated
probe's errors) keeps C finite; once the joint fit runs, the design uses its
estimate and no prior, as the fit does.
"""
from __future__ import annotations

from dataclasses import dataclass, field

import numpy as np

from inclino.engines import reference as ref

from . import common, joint
from .predict import GRID, raw_sensitivity
from .sensitivity import attitude_sensitivity

N_JOINT = 31  # joint's nonlinear layout (with the dip)
# The prior of the design before any fit (1 sigma): an uncalibrated probe of
# this class (docs/sensors.md's typical probe is well inside it).
PRIOR_SIGMA = {"M": 0.05, "c_acc_g": 0.02, "c_mag_nT": 2000.0, "q_acc": 2e-3, "q_mag": 2e-4, "dip_deg": 2.0,
               "bias_acc_g_per_c": 2e-4, "bias_mag_nT_per_c": 20.0, "scale_ppm_per_c": 300.0,
               "bias2_acc_g_per_c2": 4e-6, "bias2_mag_nT_per_c2": 0.4, "scale2_ppm_per_c2": 6.0}


def candidate_poses(inc_step: float = 15.0, azi_step: float = 30.0, tf_step: float = 30.0):
    """The poses the turntable is offered (indicated inc, azi, tf, deg):
    inclination 0-180 every inc_step, azimuth and toolface every azi_step /
    tf_step; at I = 0 and 180, where azimuth and toolface turn the probe
    about the same axis, azimuth 0 only."""
    out = []
    for i in np.arange(0.0, 180.0 + 1e-9, inc_step):
        azis = [0.0] if i in (0.0, 180.0) else np.arange(0.0, 360.0, azi_step)
        for a in azis:
            for t in np.arange(0.0, 360.0, tf_step):
                out.append((float(i), float(a), float(t)))
    a = np.array(out)
    return a[:, 0], a[:, 1], a[:, 2]


@dataclass
class Estimate:
    """The linearisation point: joint's 31-entry x, the world, the noise,
    the fit's s^2 and (with a chamber) the temperature terms."""
    x: np.ndarray
    field_nT: float
    declination_deg: float
    gravity_g: float
    sigma_acc: float = joint.SIGMA_ACC
    sigma_mag: float = joint.SIGMA_MAG
    sigma_pose_deg: float = joint.SIGMA_POSE_DEG
    s2: float = 1.0
    order: int = 0  # temperature terms' order (0: none)
    t_ref_c: float = 25.0
    theta: np.ndarray = field(default_factory=lambda: np.zeros(0))  # (2, 2, order, 3) flattened

    @property
    def n_params(self) -> int:
        return N_JOINT + 12 * self.order

    @classmethod
    def nominal(cls, field_nT: float, dip_deg: float, declination_deg: float = 0.0, gravity_g: float = 1.0,
                order: int = 0, **kw) -> "Estimate":
        x = np.concatenate([np.eye(3).ravel(), np.zeros(3), np.eye(3).ravel(), np.zeros(3), np.zeros(6),
                            [dip_deg]])
        return cls(x, field_nT, declination_deg, gravity_g, order=order, theta=np.zeros(12 * order), **kw)

    @classmethod
    def from_fit(cls, cal, info: dict, world: dict, sigma_acc: float, sigma_mag: float, sigma_pose_deg: float,
                 order: int = 0) -> "Estimate":
        """From calib.fit's calibration and info (joint, with or without
        the nonlinearity and the temperature terms)."""
        nl = info.get("nonlinear")
        if nl is not None:
            Ma, ba = np.asarray(nl["model_acc_m"]), np.asarray(nl["model_acc_b"])
            Mm, bm = np.asarray(nl["model_mag_m"]), np.asarray(nl["model_mag_b"])
            qa = np.asarray(nl["acc_q_per_g"]) * world["gravity_g"]
            qm = np.asarray(nl["mag_q_per_nT"]) * world["field_nT"]
        else:
            Ma, ba = np.asarray(cal.acc_m), np.asarray(cal.acc_b)
            Mm, bm = np.asarray(cal.mag_m), np.asarray(cal.mag_b)
            qa = qm = np.zeros(3)
        x = np.concatenate([Ma.ravel(), Ma @ ba, Mm.ravel(), Mm @ bm, qa, qm, [float(info["dip_deg"])]])
        th = np.zeros((2, 2, order, 3))
        t_ref = 25.0
        blk = getattr(cal, "temperature", None)
        if order and blk:
            t_ref = float(blk["t_ref_c"])
            k = min(order, int(blk["order"]))
            for i, tri in enumerate(("acc", "mag")):
                th[i, 0, :k] = np.asarray(blk[tri]["bias"], float).reshape(-1, 3)[:k]
                th[i, 1, :k] = np.asarray(blk[tri]["scale_ppm"], float).reshape(-1, 3)[:k]
        return cls(x, world["field_nT"], world["declination_deg"], world["gravity_g"], sigma_acc, sigma_mag,
                   sigma_pose_deg, float(info.get("s2", 1.0)), order, t_ref, th.ravel())

    def linear_calibration(self):
        """The calibration the firmware would hold (joint.best_linear) and
        the 24 x 31 map of x to it."""
        F, dec, G = self.field_nT, self.declination_deg, self.gravity_g
        lin = joint.best_linear(self.x, F, dec, G)
        return common.cal_from_vector(lin), joint.best_linear_jacobian(self.x, F, dec, G)


def prior_information(order: int = 0) -> np.ndarray:
    """Diagonal Fisher information of PRIOR_SIGMA in the design's layout."""
    p = PRIOR_SIGMA
    s = np.concatenate([np.full(9, p["M"]), np.full(3, p["c_acc_g"]), np.full(9, p["M"]), np.full(3, p["c_mag_nT"]),
                        np.full(3, p["q_acc"]), np.full(3, p["q_mag"]), [p["dip_deg"]]])
    if order:
        per = {1: ((p["bias_acc_g_per_c"], p["bias_mag_nT_per_c"]), p["scale_ppm_per_c"]),
               2: ((p["bias2_acc_g_per_c2"], p["bias2_mag_nT_per_c2"]), p["scale2_ppm_per_c2"])}
        th = np.zeros((2, 2, order, 3))
        for tri in range(2):
            for k in range(order):
                th[tri, 0, k] = per[k + 1][0][tri]
                th[tri, 1, k] = per[k + 1][1]
        s = np.concatenate([s, th.ravel()])
    return np.diag(1.0 / s ** 2)


def row_jacobians(est: Estimate, poses, temps=None) -> np.ndarray:
    """Whitened Jacobians of the fit's residuals at `poses` (tuple of inc,
    azi, tf arrays) and temperatures `temps` (degC, or None: t_ref), (n, 6,
    P), divided by sqrt(s^2): each row's Fisher information is J^T J."""
    return RowJacobians(est, poses).at(temps)


class RowJacobians:
    """The rows' Jacobians at fixed poses, for any temperatures: the joint
    part does not depend on the temperature, a temperature term's column is
    its unit column times dT^k."""

    def __init__(self, est: Estimate, poses):
        F, dec, G = est.field_nT, est.declination_deg, est.gravity_g
        poses = tuple(np.atleast_1d(np.asarray(p, float)) for p in poses)
        n = len(poses[0])
        self.est, self.n = est, n
        Ma, ca, Mm, cm = est.x[0:9].reshape(3, 3), est.x[9:12], est.x[12:21].reshape(3, 3), est.x[21:24]
        dip = float(est.x[30])
        acc, mag = joint.nonlinear_readings(est.x, poses, F, dec, G)
        Jp = joint._pose_jacobian(*poses, F, dip, dec, G)
        Linv = joint._whiteners(Ma, Mm, Jp, est.sigma_acc, est.sigma_mag, est.sigma_pose_deg)
        k = 1.0 / np.sqrt(max(est.s2, 1e-12))
        self.joint = joint._pose_jacobian_params(est.x, acc, mag, poses, F, dec, G, Linv).reshape(n, 6, N_JOINT) * k
        self.unit = None
        if est.order:
            U = np.zeros((n, 6, 2, 2, 3))  # (triad, effect, axis) at dT = 1
            for tri, (M, c, raw) in enumerate(((Ma, ca, acc), (Mm, cm, mag))):
                b = np.linalg.solve(M, c)
                sl = slice(3 * tri, 3 * tri + 3)
                for i in range(3):
                    U[:, sl, tri, 0, i] = -M[:, i][None, :]
                    U[:, sl, tri, 1, i] = -M[:, i][None, :] * ((raw[:, i] - b[i]) * 1e-6)[:, None]
            self.unit = np.einsum("nij,njtea->nitea", Linv, U) * k  # (n, 6, 2, 2, 3)

    def at(self, temps=None) -> np.ndarray:
        est = self.est
        if not est.order:
            return self.joint
        dT = (np.full(self.n, est.t_ref_c) if temps is None
              else np.broadcast_to(np.asarray(temps, float), (self.n,))) - est.t_ref_c
        pw = np.stack([dT ** (k + 1) for k in range(est.order)], -1)  # (n, order)
        Jt = np.einsum("nitea,nk->niteka", self.unit, pw).reshape(self.n, 6, -1)
        return np.concatenate([self.joint, Jt], axis=-1)


def attitude_weights(est: Estimate, temps=None, grid=None, per_temperature: bool = False):
    """(W_azi, W_inc), P x P: the mean over the acceptance grid (calib.predict's
    Li grid, toolfaces 0/120/240) and the temperatures `temps` (None: t_ref)
    of a a^T, a the attitude's sensitivity to the parameters (deg per unit).
    per_temperature: [(W_azi, W_inc)] for each temperature instead."""
    I, A, T = grid if grid is not None else GRID
    cal, Jb = est.linear_calibration()
    g, f = ref.body_vectors(I, A, T, est.field_nT, float(est.x[30]), 0.0, est.gravity_g)
    acc = g @ np.linalg.inv(np.asarray(cal.acc_m)).T + np.asarray(cal.acc_b)
    mag = f @ np.linalg.inv(np.asarray(cal.mag_m)).T + np.asarray(cal.mag_b)
    Sa, Si = attitude_sensitivity(cal, acc, mag)  # (n, 24)
    base = (Sa @ Jb, Si @ Jb)  # (n, 31)
    temps = [est.t_ref_c] if temps is None else list(temps)
    if est.order:
        Rs = raw_sensitivity(cal, acc, mag)
        bvec = np.concatenate([np.asarray(cal.acc_b), np.asarray(cal.mag_b)])
        raw = np.concatenate([acc, mag], axis=1)
    per = [[None, None] for _ in temps]
    out = []
    for q, B in enumerate(base):
        W = np.zeros((est.n_params, est.n_params))
        if est.order:
            R = Rs[q]
        for m, t in enumerate(temps):
            a = np.zeros((len(I), est.n_params))
            a[:, :N_JOINT] = B
            if est.order:
                dT = float(t) - est.t_ref_c
                at = np.zeros((len(I), 2, 2, est.order, 3))
                for tri in range(2):
                    for k in range(est.order):
                        for i in range(3):
                            c = 3 * tri + i
                            at[:, tri, 0, k, i] = -R[:, c] * dT ** (k + 1)
                            at[:, tri, 1, k, i] = -R[:, c] * (raw[:, c] - bvec[c]) * 1e-6 * dT ** (k + 1)
                a[:, N_JOINT:] = at.reshape(len(I), -1)
            Wt = a.T @ a / len(I)
            per[m][q] = Wt
            W += Wt
        out.append(W / len(temps))
    if per_temperature:
        return [tuple(p) for p in per]
    return out[0], out[1]


class Design:
    """The information gathered so far and the criterion's weights.
    weights: [(W, tau)]: V = trace(C W), criterion = sum V / tau^2."""

    def __init__(self, info: np.ndarray, weights: list):
        self.info = np.array(info, float)
        self.weights = list(weights)
        self._cov = None

    @property
    def cov(self) -> np.ndarray:
        if self._cov is None:
            self._cov = _inv_sym(self.info)
        return self._cov

    def add(self, J: np.ndarray) -> None:
        """Add readings' whitened Jacobians ((6, P) or (n, 6, P))."""
        J = np.asarray(J, float).reshape(-1, self.info.shape[0])
        self.info += J.T @ J
        self._cov = None

    def variances(self) -> list:
        C = self.cov
        return [float(np.trace(C @ W)) for W, _ in self.weights]

    def criterion(self) -> float:
        return float(sum(v / tau ** 2 for v, (_, tau) in zip(self.variances(), self.weights)))

    def gains(self, Jc: np.ndarray) -> np.ndarray:
        """The criterion's decrease for one more reading at each candidate
        (Jc: (m, 6, P))."""
        C = self.cov
        A = Jc @ C  # (m, 6, P)
        S = np.eye(Jc.shape[1])[None] + A @ np.swapaxes(Jc, 1, 2)
        Sinv = np.linalg.inv(S)
        out = np.zeros(len(Jc))
        for W, tau in self.weights:
            B = A @ W @ np.swapaxes(A, 1, 2)
            out += np.einsum("mij,mji->m", Sinv, B) / tau ** 2
        return out

    def variances_after(self, J: np.ndarray) -> list:
        """The variances V_q with readings J ((n, 6, P)) added."""
        d = Design(self.info, self.weights)
        d.add(J)
        return d.variances()


def _inv_sym(N: np.ndarray) -> np.ndarray:
    """Inverse of a symmetric positive (semi)definite information matrix,
    scaled to unit diagonal first (the parameters' units differ by decades);
    a parameter the readings do not determine gets an infinite variance
    (1e30), not the pseudo-inverse's zero."""
    from scipy import linalg

    dg = np.diag(N)
    d = np.sqrt(np.where(dg > 0, dg, 1.0))
    Ns = N / np.outer(d, d)
    try:
        c = linalg.cho_factor(Ns, check_finite=False)
        Ci = linalg.cho_solve(c, np.eye(len(N)), check_finite=False)
        piv = np.abs(np.diag(c[0]))
        if np.all(np.isfinite(Ci)) and piv.min() > 3e-7 * piv.max():  # about cond < 1e13
            return Ci / np.outer(d, d)
    except linalg.LinAlgError:
        pass
    w, V = np.linalg.eigh(Ns)
    inv_w = np.where(w > 1e-13 * max(w.max(), 1e-300), 1.0 / np.where(w > 0, w, 1.0), 1e30)
    return (V * inv_w) @ V.T / np.outer(d, d)
