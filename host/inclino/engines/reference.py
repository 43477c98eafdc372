"""Float64 reference: frames, poses, sensor truth and attitude, vectorised.

The conventions (docs/conventions.md) in one place:

* World frame NED.  Body frame: z along the tool axis pointing down-hole;
  at I = A = T = 0 the body axes are N, E, D.
* Pose (I, A, T) in degrees: body = C @ world with C = Rz(T) @ Ry(I) @ Rz(A),
  Rz(a) = [[cos a, sin a, 0], [-sin a, cos a, 0], [0, 0, 1]],
  Ry(i) = [[cos i, 0, -sin i], [0, 1, 0], [sin i, 0, cos i]].
* The accelerometer reads +1 g on an axis pointing down: the gravity reading in
  NED is [0, 0, +1] g.  Earth field in NED: F [cos dip cos dec,
  cos dip sin dec, sin dip].
"""
from __future__ import annotations

import numpy as np

ACC_LSB_G = 1.0 / 16384.0  # ADIS16210 accelerometer, g per count
MAG_LSB_NT = 1.0  # fluxgate ADC, nT per count (nominal)
ACC_RAW_MIN, ACC_RAW_MAX = -32768, 32767
MAG_RAW_MIN, MAG_RAW_MAX = -(2**23), 2**23 - 1


def rz(a_deg):
    a = np.radians(np.asarray(a_deg, dtype=float))
    c, s = np.cos(a), np.sin(a)
    z, o = np.zeros_like(a), np.ones_like(a)
    return np.stack([np.stack([c, s, z], -1), np.stack([-s, c, z], -1), np.stack([z, z, o], -1)], -2)


def ry(i_deg):
    i = np.radians(np.asarray(i_deg, dtype=float))
    c, s = np.cos(i), np.sin(i)
    z, o = np.zeros_like(i), np.ones_like(i)
    return np.stack([np.stack([c, z, -s], -1), np.stack([z, o, z], -1), np.stack([s, z, c], -1)], -2)


def pose_matrix(inc_deg, azi_deg, tf_deg):
    """C = Rz(T) Ry(I) Rz(A): body = C @ world (NED), shape (..., 3, 3)."""
    return rz(tf_deg) @ ry(inc_deg) @ rz(azi_deg)


def gravity_ned(gravity_g=1.0):
    return np.array([0.0, 0.0, gravity_g])


def field_ned(field_nT, dip_deg, declination_deg=0.0):
    d = np.radians(dip_deg)
    c = np.radians(declination_deg)
    return field_nT * np.array([np.cos(d) * np.cos(c), np.cos(d) * np.sin(c), np.sin(d)])


def body_vectors(inc_deg, azi_deg, tf_deg, field_nT=50000.0, dip_deg=60.0,
                 declination_deg=0.0, gravity_g=1.0):
    """True gravity reading (g) and field (nT) in the body frame, (..., 3) each.
    Azimuth is taken from magnetic north when declination_deg = 0, from true
    north otherwise."""
    C = pose_matrix(inc_deg, azi_deg, tf_deg)
    g = C @ gravity_ned(gravity_g)
    b = C @ field_ned(field_nT, dip_deg, declination_deg)
    return g, b


def _wrap360(a):
    a = np.mod(a, 360.0)
    return np.where(a >= 360.0, a - 360.0, a)


def attitude(g, b):
    """Attitude from body-frame gravity (any unit) and field (nT).

    Returns a dict of float arrays: inc, azi, gtf, mtf (degrees), gt (unit of
    g), bt (unit of b), dip (degrees)."""
    g = np.asarray(g, dtype=float)
    b = np.asarray(b, dtype=float)
    gx, gy, gz = g[..., 0], g[..., 1], g[..., 2]
    bx, by, bz = b[..., 0], b[..., 1], b[..., 2]
    gn = np.sqrt(gx * gx + gy * gy + gz * gz)
    bn = np.sqrt(bx * bx + by * by + bz * bz)
    h = np.hypot(gx, gy)
    out = {
        "inc": np.degrees(np.arctan2(h, gz)),
        # "+ 0.0" turns -0.0 into +0.0: atan2(0, 0) is 0, as in the firmware
        "gtf": _wrap360(np.degrees(np.arctan2(gy, -gx + 0.0))),
        "azi": _wrap360(np.degrees(np.arctan2(gn * (gx * by - gy * bx),
                                              bz * (gx * gx + gy * gy) - gz * (gx * bx + gy * by)))),
        "mtf": _wrap360(np.degrees(np.arctan2(-by + 0.0, bx))),
        "gt": gn,
        "bt": bn,
    }
    gb = gx * bx + gy * by + gz * bz
    cross = np.cross(g, b)
    out["dip"] = np.degrees(np.arctan2(gb, np.linalg.norm(cross, axis=-1)))
    return out


def correct(raw, m, bias):
    """Float correction of one triad: M @ (raw - b), raw (..., 3) in nominal
    units (g or nT), M (3, 3), b (3,) in the same units."""
    raw = np.asarray(raw, dtype=float)
    return (raw - np.asarray(bias, dtype=float)) @ np.asarray(m, dtype=float).T


def quantise_acc(g):
    """Ideal ADIS16210 counts for a reading in g (round, saturate to int16)."""
    return np.clip(np.round(np.asarray(g) / ACC_LSB_G), ACC_RAW_MIN, ACC_RAW_MAX).astype(np.int64)


def quantise_mag(b):
    """Ideal fluxgate ADC counts for a field in nT (round, 24-bit rails)."""
    return np.clip(np.round(np.asarray(b) / MAG_LSB_NT), MAG_RAW_MIN, MAG_RAW_MAX).astype(np.int64)


def readings_acc(g):
    """The firmware's accelerometer readings for an averaged value in g: Q6
    counts (golden.IN_ONE = 64 per count, acq_avg_q6's rounding, half up),
    saturated to the int16 rails.  Whole counts give counts * 64 exactly."""
    q = np.floor(np.asarray(g, dtype=float) / ACC_LSB_G * 64.0 + 0.5)
    return np.clip(q, ACC_RAW_MIN * 64, ACC_RAW_MAX * 64).astype(np.int64)


def readings_mag(b):
    """The firmware's fluxgate readings for an averaged value in nT: Q6
    counts, saturated to the 24-bit rails."""
    q = np.floor(np.asarray(b, dtype=float) / MAG_LSB_NT * 64.0 + 0.5)
    return np.clip(q, MAG_RAW_MIN * 64, MAG_RAW_MAX * 64).astype(np.int64)


def angle_diff(a, b):
    """Signed smallest difference a - b in degrees, in (-180, 180]."""
    d = np.mod(np.asarray(a, dtype=float) - np.asarray(b, dtype=float) + 180.0, 360.0) - 180.0
    return np.where(d == -180.0, 180.0, d)


# --------------------------------------------------------------------------
# The papers' own azimuth and toolface formulas, as printed, for the mapping
# tests (docs/conventions.md explains each offset).
def li2021_azimuth(a, h):
    """Li 2021 eq. (2) taken literally with atan2 (numerator, denominator)."""
    ax, ay, az = a[..., 0], a[..., 1], a[..., 2]
    hx, hy, hz = h[..., 0], h[..., 1], h[..., 2]
    num = np.sqrt(ax * ax + ay * ay + az * az) * (hx * ay - hy * ax)
    den = az * (hx * ax + hy * ay) - hz * (ax * ax + ay * ay)
    return _wrap360(np.degrees(np.arctan2(num, den)))


def ren2014_azimuth(a, m):
    """Ren 2014 eq. (7) taken literally with atan2 (numerator, denominator),
    on normalised readings."""
    a = a / np.linalg.norm(a, axis=-1, keepdims=True)
    m = m / np.linalg.norm(m, axis=-1, keepdims=True)
    q = (m * a).sum(axis=-1)
    num = m[..., 2] - a[..., 2] * q
    den = m[..., 0] * a[..., 1] - m[..., 1] * a[..., 0]
    return _wrap360(np.degrees(np.arctan2(num, den)))
