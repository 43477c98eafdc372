"""Ren, Wang, Wang, Wu, Wei, "A Measuring System for Well Logging Attitude
and a Method of Sensor Calibration", Sensors 2014, 14(5):9256-9270.

Accelerometer, eq. (8)-(10): the 12-parameter least squares
[A_x A_y A_z] = [A_x0 A_y0 A_z0 1] a over >= 10 static positions of known
gravity direction (the turntable's poses; normalised gravity, in g here).
It is our correction directly: M = a[:3].T, M b = -a[3].

Fluxgate, eq. (13)-(23): the non-tilted ellipsoid
x^2 = [x y z -y^2 -z^2 1] I fitted by least squares to all readings, giving
the offsets e_m (eq. 17) and the semi-axes k_m (eq. 18, 21), so that
x_2 = (raw - e_m)/k_m lies on the unit sphere.  Misalignment, eq. (24)-(27):
for each of the three circle rotations (X_b, Y_b, Z_b pointing down, turned
about the vertical) the normalised points satisfy w . x_2 = sin(dip);
least squares of x_2 I = 1 (eq. 25) and w = I/|I| (eq. 26) give the body
axis in the sensor frame.  Eq. (27) writes M_m = [w_x w_y w_z]; since w_k is
body axis k in sensor coordinates, the body components are w_k . x_2, i.e.
M_m has the w_k as *rows* here.  The result is scaled by the field total so
the corrected field is in nT:
    corrected = F M_m diag(1/k_m) (raw - e_m).
The soft-iron matrix M_s of eq. (11) is taken as the identity, as the paper
does (its eq. 13 drops the ellipsoid's cross terms).
"""
from __future__ import annotations

import numpy as np

from inclino.formats.dataset import RawDataset
from inclino.errors import DataError

from . import common

MIN_POSITIONS = 10
MIN_CIRCLE = 6


def accelerometer(raw, g_true):
    """Eq. (9)-(10): least squares of g_true = [raw 1] a.  Returns M, b."""
    X = np.column_stack([raw, np.ones(len(raw))])
    a, *_ = np.linalg.lstsq(X, g_true, rcond=None)
    M = a[:3].T
    b = -np.linalg.solve(M, a[3])
    return M, b


def ellipsoid(raw):
    """Eq. (14)-(18), (21): offsets e_m and scale factors k_m of the
    non-tilted ellipsoid through the readings."""
    x, y, z = np.asarray(raw, float).T
    X = np.column_stack([x, y, z, -y * y, -z * z, np.ones_like(x)])
    I, *_ = np.linalg.lstsq(X, x * x, rcond=None)
    if I[3] <= 0 or I[4] <= 0:
        raise DataError("ren2014: the fluxgate readings do not lie on an ellipsoid (too few orientations?)")
    x0, y0, z0 = I[0] / 2, I[1] / (2 * I[3]), I[2] / (2 * I[4])
    A = I[5] + x0 * x0 + I[3] * y0 * y0 + I[4] * z0 * z0
    if A <= 0:
        raise DataError("ren2014: degenerate ellipsoid fit")
    k = np.sqrt([A, A / I[3], A / I[4]])
    return np.array([x0, y0, z0]), k


def circle_normal(x2):
    """Eq. (24)-(26): unit normal of the plane through the normalised points
    of one circle rotation."""
    I, *_ = np.linalg.lstsq(np.asarray(x2, float), np.ones(len(x2)), rcond=None)
    return I / np.linalg.norm(I)


def fit(ds: RawDataset, circle_tol_deg: float = 3.0, **_):
    common.need_poses(ds, "ren2014")
    dip = common.require_dip(ds, "ren2014")
    w = common.world_of(ds)
    g_true, _ = common.true_vectors(ds, dip, w["field_nT"], w["declination_deg"], w["gravity_g"])
    C = common.pose_matrices(ds)
    # distinct positions (gravity directions) for the 12-parameter fit
    dirs = np.unique(np.round(g_true / w["gravity_g"], 2), axis=0)
    if len(dirs) < MIN_POSITIONS:
        raise DataError(f"ren2014 needs >= {MIN_POSITIONS} static positions of distinct gravity direction; "
                        f"the data have {len(dirs)}")
    Ma, ba = accelerometer(ds.acc, g_true)
    groups = common.body_axis_groups(C, circle_tol_deg)
    circles = {}
    for k, name in enumerate("xyz"):
        rows = groups[(k, 1)]  # body axis k pointing down, turned about the vertical
        if len(rows) < MIN_CIRCLE:
            raise DataError(f"ren2014 needs a circle rotation with body {name} pointing down "
                            f"(>= {MIN_CIRCLE} readings); the data have {len(rows)}")
        circles[k] = rows
    em, km = ellipsoid(ds.mag)
    Mm_rows = []
    for k in range(3):
        x2 = (ds.mag[circles[k]] - em) / km
        n = circle_normal(x2)
        if n[k] < 0:  # dip > 0: the normal points along +axis k
            n = -n
        Mm_rows.append(n)
    Mm = np.array(Mm_rows)
    if abs(np.linalg.det(Mm)) < 0.5:
        raise DataError("ren2014: the three circle normals are nearly dependent")
    Mmag = w["field_nT"] * Mm / km[None, :]
    cal = common.make_cal(Ma, ba, Mmag, em, "ren2014", ds)
    used = np.arange(len(ds))
    return cal, {"rows_used": used,
                 "paper_parameters": {"e_m": em.tolist(), "k_m": km.tolist(), "M_m": Mm.tolist()},
                 "notes": [f"{len(dirs)} accelerometer positions; circles of "
                           f"{', '.join(str(len(circles[k])) for k in range(3))} readings (x, y, z down)"]}
