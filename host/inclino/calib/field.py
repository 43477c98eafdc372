"""Field recalibration without poses: what the invariants determine, what
they cannot, and what a prior turntable calibration supplies.

Corrected gravity is g = R_a S_a (a - b_a) and the corrected field
b = R_m S_m (m - b_m) (polar decompositions, S symmetric positive).

* |g| = G determines S_a and b_a (9 numbers), |b| = F determines S_m and b_m
  (9 more), whenever the orientations cover enough of the sphere.
* A constant dip (g.b = G F sin dip) determines the relative rotation of the
  two triads, R_a^T R_m (3 numbers), and the dip.
* Nothing measured without poses changes when both triads are turned by the
  same rotation Q: g -> Q g, b -> Q b leave |g|, |b| and g.b alone.  The
  common rotation of the sensor block relative to the probe's axis (tilt
  about body x and y, roll about z) is unobservable: 3 numbers.

With a prior (a turntable calibration of the same probe) the common rotation
is taken from it: of all calibrations the invariants allow (Q M_a, Q M_m for
any rotation Q), the one closest to the prior, Q = argmin |Q M_a - P_a|^2 +
|Q M_m - P_m|^2 (orthogonal Procrustes, Q = polar factor of
P_a M_a^T + P_m M_m^T).  Drifted biases and per-axis scales (M -> M D) leave
that choice exactly at the prior's rotation.  Its uncertainty is the prior's
uncertainty of that rotation (from the prior's reported 1-sigma of M_a).

Without a prior the body frame is fixed by a convention (M_a symmetric: the
accelerometer's axes) and the true block rotation is unknown to within the
mechanical tolerance of its mounting, DEFAULT_MOUNT_TOLERANCE_DEG (1 sigma
per axis) unless stated otherwise; the covariance includes it.
"""
from __future__ import annotations

import numpy as np

# Not a datasheet figure: a stated assumption for a sensor block mounted in a
# probe housing, the size of the sensor-misalignment terms of survey tool
# error models (tenths of a degree).  --mount-tolerance-deg overrides it.
DEFAULT_MOUNT_TOLERANCE_DEG = 0.3

UNOBSERVABLE = ("the common rotation of both triads relative to the probe axis (3 angles: tilt about body x and "
                "y, roll about z), which leaves |g|, |b| and the dip unchanged")


def _skew(w):
    x, y, z = w
    return np.array([[0.0, -z, y], [z, 0.0, -x], [-y, x, 0.0]])


def rotation_jacobian(Ma, Mm) -> np.ndarray:
    """(24, 3): d(M_a, b_a, M_m, b_m)/d(omega) for a small common rotation
    Q = I + [omega]x applied to both triads (biases unchanged)."""
    J = np.zeros((24, 3))
    for k in range(3):
        e = np.zeros(3)
        e[k] = 1.0
        K = _skew(e)
        J[0:9, k] = (K @ Ma).ravel()
        J[12:21, k] = (K @ Mm).ravel()
    return J


def rotate_cov(cov24, Q) -> np.ndarray:
    """Covariance of (Q M_a, b_a, Q M_m, b_m) from that of (M_a, b_a, M_m, b_m)."""
    T = np.eye(24)
    K = np.kron(Q, np.eye(3))  # row-major vec(Q M) = (Q kron I) vec(M)
    T[0:9, 0:9] = K
    T[12:21, 12:21] = K
    return T @ cov24 @ T.T


def polar_rotation(A) -> np.ndarray:
    U, _, Vt = np.linalg.svd(np.asarray(A, float))
    R = U @ Vt
    return R if np.linalg.det(R) > 0 else U @ np.diag([1.0, 1.0, -1.0]) @ Vt


def align_to_prior(Ma, Mm, prior) -> np.ndarray:
    """The rotation Q that brings (M_a, M_m) closest to the prior's matrices."""
    P = np.asarray(prior.acc_m) @ np.asarray(Ma).T + np.asarray(prior.mag_m) @ np.asarray(Mm).T
    return polar_rotation(P)


def prior_rotation_sigma_rad(prior) -> tuple[np.ndarray, str]:
    """1-sigma of the prior's common rotation about x, y, z (rad), from its
    report's 1-sigma of M_a: omega_x = (M_a[2,1] - M_a[1,2]) / 2 etc.; zeros
    when the prior carries no uncertainty (said so)."""
    try:
        s = prior.report["uncertainty"]["sigma"]
        pairs = ((("acc_m21", "acc_m12")), ("acc_m02", "acc_m20"), ("acc_m10", "acc_m01"))
        out = np.array([0.5 * np.hypot(s[a], s[b]) for a, b in pairs])
        return out, "the prior's reported 1-sigma of M_a"
    except (AttributeError, KeyError, TypeError):
        return np.zeros(3), "the prior has no reported uncertainty: its rotation is taken as exact"


def rotation_cov(Ma, Mm, sigma_rad) -> np.ndarray:
    J = rotation_jacobian(Ma, Mm)
    return J @ np.diag(np.asarray(sigma_rad, float) ** 2) @ J.T


def nonlinear_model_of(prior) -> dict | None:
    """The prior's fitted nonlinear model (report.uncertainty.nonlinear_model),
    when its fit had one."""
    try:
        nl = prior.report["uncertainty"]["nonlinear_model"]
        return nl if nl and "model_acc_m" in nl else None
    except (AttributeError, KeyError, TypeError):
        return None
