"""What the tests' own generators share, written from docs/conventions.md
alone (not inclino.model): the body frame's reading of a world vector at a
pose, so that data made with it check inclino rather than agree with it."""
from __future__ import annotations

import numpy as np


def body(I, A, T, v):
    """(n, 3): the world vector v (north, east, down) read in the body frame
    at inclination I, azimuth A and toolface T (degrees, arrays of n): the
    transpose of Rz(A) Ry(I) Rz(T), written out."""
    I, A, T = np.radians(I), np.radians(A), np.radians(T)
    cI, sI, cA, sA, cT, sT = np.cos(I), np.sin(I), np.cos(A), np.sin(A), np.cos(T), np.sin(T)
    C = np.array([[cT * cI * cA - sT * sA, cT * cI * sA + sT * cA, -cT * sI],
                  [-sT * cI * cA - cT * sA, -sT * cI * sA + cT * cA, sT * sI],
                  [sI * cA, sI * sA, cI]])
    return np.einsum("ijn,j->ni", C, v)


F_NT, DIP_DEG = 50000.0, 60.0  # the field the generators below put the sensor in


def sensor_matrix(rng, scale=0.01, cross=0.005, mis=0.5):
    """A triad's 3x3 reading matrix: per-axis scale errors (1 sigma `scale`),
    cross-axis terms above the diagonal (`cross`) and a small misalignment
    rotation (`mis` degrees per axis, made orthonormal), drawn from rng."""
    k = np.eye(3) + np.diag(rng.normal(0, scale, 3))
    k[np.triu_indices(3, 1)] = rng.normal(0, cross, 3)
    a = np.radians(rng.normal(0, mis, 3))  # a small rotation, first order
    rm = np.eye(3) + np.array([[0, -a[2], a[1]], [a[2], 0, -a[0]], [-a[1], a[0], 0]])
    u, _, vt = np.linalg.svd(rm)
    return k @ (u @ vt)


def ar1(rng, n, rho, sd):
    """(n, 3): AR(1) noise of standard deviation sd, lag-1 correlation rho."""
    w = rng.normal(0, sd * np.sqrt(1 - rho ** 2), (n, 3))
    out = np.empty((n, 3))
    out[0] = rng.normal(0, sd, 3)
    for i in range(1, n):
        out[i] = rho * out[i - 1] + w[i]
    return out


def canonical_csv(t, acc, mag, temp=None) -> str:
    """The rows as the canonical raw dataset's text (docs/dataset.md), with
    the field the generators use in its header."""
    import io

    out = io.StringIO()
    out.write(f"# field_nT={F_NT:g}\n# dip_deg={DIP_DEG:g}\nt_s,{'temp_c,' if temp is not None else ''}"
              "ax_g,ay_g,az_g,mx_nT,my_nT,mz_nT\n")
    for i in range(len(t)):
        out.write(f"{t[i]:.3f}," + (f"{temp[i]:.4f}," if temp is not None else "")
                  + ",".join(f"{v:.9g}" for v in (*acc[i], *mag[i])) + "\n")
    return out.getvalue()


def smooth_log(seed, rho=None, n=2000, rate=10.0, cubic=0.0, drift_nT_s=0.0, tbias_g_per_c=0.0) -> str:
    """A sensor turned smoothly through the sphere (the inclination's swing
    widening and narrowing, azimuth and toolface turning) for n rows at
    `rate` Hz, the temperature on a slow ramp (canonical CSV text).  Noise
    1 mg and 20 nT per axis: white (rho None) or AR(1) of lag-1 correlation
    rho.  cubic: an acc z term c z^3 (g/g^3, no library effect);
    drift_nT_s: a drift of |b|; tbias_g_per_c: an acc z temperature bias."""
    rng = np.random.default_rng(seed)
    sa, sm = sensor_matrix(rng), sensor_matrix(rng)
    oa, om = rng.normal(0, 0.01, 3), rng.normal(0, 300.0, 3)
    t = np.arange(n) / rate
    T = t[-1]
    ph = rng.uniform(0, 2 * np.pi, 6)
    inc = 90 + 85 * np.sin(2 * np.pi * 3.3 * t / T + ph[0]) * (0.6 + 0.4 * np.sin(2 * np.pi * 1.1 * t / T + ph[1]))
    azi = (360 * 2.7 * t / T + 60 * np.sin(2 * np.pi * 4.1 * t / T + ph[2])) % 360
    tf = (360 * 5.3 * t / T + 90 * np.sin(2 * np.pi * 2.3 * t / T + ph[3])) % 360
    dp = np.radians(DIP_DEG)
    g = body(inc, azi, tf, np.array([0, 0, 1.0]))
    b = body(inc, azi, tf, F_NT * np.array([np.cos(dp), 0.0, np.sin(dp)]))
    b = b * (1 + drift_nT_s * (t - t.mean()) / F_NT)[:, None]
    temp = 20 + 15 * (1 - np.exp(-t / (0.4 * T))) + rng.normal(0, 0.02, n)
    acc = g @ sa.T + oa
    acc[:, 2] += cubic * acc[:, 2] ** 3 + tbias_g_per_c * (temp - temp.mean())
    mag = b @ sm.T + om
    if rho is None:
        acc = acc + rng.normal(0, 1e-3, (n, 3))
        mag = mag + rng.normal(0, 20.0, (n, 3))
    else:
        acc = acc + ar1(rng, n, rho, 1e-3)
        mag = mag + ar1(rng, n, rho, 20.0)
    return canonical_csv(t, acc, mag, temp)
