"""The pose-free view of a model: what the readings say once corrected by it.

A model of a turntable run (the baseline's A, c and dip plus effects)
corrects each row's readings without using the pose: the sensor chain
inverted per axis (temperature scale and bias, scale nonlinearity), A^-1,
and the rig field removed.  The corrected vectors must then satisfy what
holds at any pose: |g| = G, |b| = F(t) and the angle between them = the
dip(t) (with a field drift, F and the dip of the drift's trend).  These are
the invariants.  An effect that truly acts makes them more consistent or
leaves them alone; one that only fits the poses (a pose error, a rig
effect the model lacks, a stand-in for something else) can make them worse
-- the second view of the data a named cause must survive.
"""
from __future__ import annotations

import numpy as np

from . import forward
from .names import TRIADS

INVARIANTS = ("|g|", "|b|", "dip")
WORSE_Z = 3.0  # a worsening must be this many standard errors of the paired difference
WORSE_REL = 0.01  # and at least this fraction of the RMS


def corrected(d, A, c, theta):
    """(g, b): each row's readings corrected by the state (n, 3 each)."""
    out = []
    dT = forward._dT(d)[:, None]
    dTs = ((d.temp - forward.SCALE_T_REF_C) if d.temp is not None else np.zeros(d.n))[:, None]
    for ti, tri in enumerate(TRIADS):
        ppm, k2, cT = forward.sensor_terms(d, theta, tri)
        z = d.Y[:, 3 * ti:3 * ti + 3] - c[tri] - cT * dT
        # v + k2 v^2 = z, the root near z (written so that k2 = 0 is exact)
        v = 2.0 * z / (1.0 + np.sqrt(np.maximum(1.0 + 4.0 * k2 * z, 1e-12)))
        u = v / (1.0 + 1e-6 * ppm * dTs)
        out.append(u @ np.linalg.inv(A[tri]).T)
    g, b = out
    rb = forward.rig_body(d, theta)
    if rb is not None:
        b = b - rb
    return g, b


def expected(d, dip, theta):
    """(F (n,), dip (n,)): the field total and dip each row should show."""
    F = np.full(d.n, d.field_nT)
    dp = np.full(d.n, float(dip))
    if d.t is not None:
        tau = d.t - d.t.mean()
        F = F + forward._val(theta, "field-drift:field:total") * tau
        dp = dp + forward._val(theta, "field-drift:field:dip") * tau
    return F, dp


def residuals(d, A, c, dip, theta) -> dict:
    """Invariant -> (n,) residual: |g| - G (g), |b| - F(t) (nT), dip - dip(t) (deg)."""
    g, b = corrected(d, A, c, theta)
    F, dp = expected(d, dip, theta)
    ng, nb = np.linalg.norm(g, axis=1), np.linalg.norm(b, axis=1)
    dip_meas = np.degrees(np.arcsin(np.clip(np.einsum("ni,ni->n", g, b) / (ng * nb), -1.0, 1.0)))
    return {"|g|": ng - d.gravity_g, "|b|": nb - F, "dip": dip_meas - dp}


def which(cand) -> tuple:
    """The invariants an effect acts on (what its check compares)."""
    if cand.sensor == "acc":
        return ("|g|", "dip")
    if cand.sensor in ("mag", "rig"):
        return ("|b|", "dip") if cand.name != "sample-skew" else ()
    if cand.name == "field-drift":
        return {"total": ("|b|",), "dip": ("dip",)}.get(cand.axis, ())
    if cand.name.startswith("turntable-"):
        return INVARIANTS
    return ()


def compare(r_with: dict, r_without: dict, names, ok) -> dict:
    """Per invariant: RMS without and with the effect, and whether it is
    worse with it (by WORSE_Z standard errors of the paired difference of
    squares and by WORSE_REL of the RMS)."""
    out = {}
    for k in names:
        a, b = r_without[k][ok], r_with[k][ok]
        a, b = a[np.isfinite(a) & np.isfinite(b)], b[np.isfinite(a) & np.isfinite(b)]
        if len(a) < 3:
            continue
        dsq = b ** 2 - a ** 2
        se = float(np.std(dsq, ddof=1) / np.sqrt(len(dsq))) if len(dsq) > 1 else np.inf
        r0, r1 = float(np.sqrt(np.mean(a ** 2))), float(np.sqrt(np.mean(b ** 2)))
        worse = bool(np.mean(dsq) > WORSE_Z * se and r1 > (1.0 + WORSE_REL) * r0)
        out[k] = {"rms_without": r0, "rms_with": r1, "worse": worse,
                  "z": float(np.mean(dsq) / se) if se > 0 else 0.0}
    return out
