"""Guo Yue, Shi Xiaofeng, Wang Xin, "A Calibration Algorithm and Its
Simulation Study on Continuous Inclinometer", Well Logging Technology 2009,
33(6):567-570.

The web copy (seeds/002_...) has garbled equations; what follows is our
reconstruction, in our frame (docs/conventions.md: Guo's eq. (10) is our
b = C f exactly; Guo's eq. (7) gravity is the negative of our reading, so
the accelerometer signs below are Guo's with G -> -G).

Each sensor axis i reads  y_i = SF_i (u_i . v + Bias_i)  (eq. 1/3, 6), v the
true body-frame vector, u_i the axis' direction cosines (|u_i| = 1, eq. 16/21),
SF_i its scale, Bias_i its bias in input units.  Rotating the toolface r at a
fixed inclination d and azimuth a, every axis traces
y = M cos r + N sin r + P (eq. 8/11), fitted by least squares on the
orthogonal basis {cos r, sin r, 1}.  With p = SF u and c = SF Bias:

  accelerometer (our sign, g = G [-sin d cos r, sin d sin r, cos d]):
      M = -G sin d p_x,   N = G sin d p_y,   P = G cos d p_z + c      (eq. 9)
  fluxgate (Bh = B cos(dip), Bv = B sin(dip), a from magnetic north):
      M = al p_x - be p_y,  N = -be p_x - al p_y,  P = ga p_z + c      (eq. 12)
      al = Bh cos a cos d - Bv sin d,  be = Bh sin a,  ga = Bh cos a sin d + Bv cos d

Two rotations at d1 and d2 = d1 + 90 deg, same azimuth (eq. 13-15, 18-20):
d1 = arctan(M1/M2) (eq. 17; pooled over the three accelerometer axes here:
tan d1 = sqrt(sum(M1^2+N1^2) / sum(M2^2+N2^2))), then p_x, p_y by least
squares from the four (M, N), p_z = (P1 - P2)/(G (cos d1 - cos d2)) and
c = mean of P_k - G cos d_k p_z; SF = |p|, u = p/SF, Bias = c/SF (eq. 17, 21).
The forward matrix A has rows p_i; our correction is M = inv(A), b = c.
"""
from __future__ import annotations

import numpy as np

from inclino.formats.dataset import RawDataset
from inclino.errors import DataError

from . import common


def fit_trig(r_deg, y):
    """Least-squares y = M cos r + N sin r + P; r (..., n) deg, y (..., n).
    Returns M, N, P (...)."""
    r = np.radians(np.asarray(r_deg, float))
    X = np.stack([np.cos(r), np.sin(r), np.ones_like(r)], -1)  # (..., n, 3)
    XtX = np.swapaxes(X, -1, -2) @ X
    Xty = np.swapaxes(X, -1, -2) @ np.asarray(y, float)[..., None]
    sol = np.linalg.solve(XtX, Xty)[..., 0]
    return sol[..., 0], sol[..., 1], sol[..., 2]


def inclination_from_acc(MN1, MN2):
    """d1 (deg) from the first-harmonic amplitudes of the accelerometer at
    d1 and d1 + 90: MN_k arrays (..., axes, 2) of (M, N)."""
    s1 = np.sqrt((np.asarray(MN1) ** 2).sum(axis=(-1, -2)))
    s2 = np.sqrt((np.asarray(MN2) ** 2).sum(axis=(-1, -2)))
    return np.degrees(np.arctan2(s1, s2))


def acc_axis(fit1, fit2, d1_deg, G=1.0):
    """One accelerometer axis: fit_k = (M, N, P) at d1, d1 + 90.
    Returns p (..., 3) = SF u, c (...) = SF Bias."""
    d1 = np.radians(d1_deg)
    d2 = d1 + np.pi / 2
    s1, s2, c1, c2 = np.sin(d1), np.sin(d2), np.cos(d1), np.cos(d2)
    (M1, N1, P1), (M2, N2, P2) = fit1, fit2
    den = G * (s1 * s1 + s2 * s2)
    px = -(M1 * s1 + M2 * s2) / den
    py = (N1 * s1 + N2 * s2) / den
    pz = (P1 - P2) / (G * (c1 - c2))
    c = 0.5 * ((P1 - G * c1 * pz) + (P2 - G * c2 * pz))
    return np.stack([px, py, pz], -1), c


def mag_axis(fit1, fit2, d1_deg, a_deg, B, dip_deg):
    """One fluxgate axis (see the module docstring), a = azimuth from
    magnetic north.  Returns p (..., 3), c (...)."""
    d1 = np.radians(d1_deg)
    d = (d1, d1 + np.pi / 2)
    a = np.radians(a_deg)
    Bh, Bv = B * np.cos(np.radians(dip_deg)), B * np.sin(np.radians(dip_deg))
    al = [Bh * np.cos(a) * np.cos(dk) - Bv * np.sin(dk) for dk in d]
    be = Bh * np.sin(a)
    ga = [Bh * np.cos(a) * np.sin(dk) + Bv * np.cos(dk) for dk in d]
    # normal equations of the four equations in (p_x, p_y):
    #   M_k = al_k p_x - be p_y,  N_k = -be p_x - al_k p_y
    a11 = sum(alk * alk + be * be for alk in al)
    a12 = sum(-alk * be + be * alk for alk in al)  # = 0
    a22 = sum(be * be + alk * alk for alk in al)
    r1 = sum(alk * f[0] - be * f[1] for alk, f in zip(al, (fit1, fit2)))
    r2 = sum(-be * f[0] - alk * f[1] for alk, f in zip(al, (fit1, fit2)))
    det = a11 * a22 - a12 * a12
    px = (a22 * r1 - a12 * r2) / det
    py = (a11 * r2 - a12 * r1) / det
    pz = (fit1[2] - fit2[2]) / (ga[0] - ga[1])
    c = 0.5 * ((fit1[2] - ga[0] * pz) + (fit2[2] - ga[1] * pz))
    return np.stack([px, py, pz], -1), c


def scale_bias_cosines(p, c):
    """SF = |p|, direction cosines u = p/SF, Bias = c/SF (input units)."""
    sf = np.linalg.norm(p, axis=-1)
    return sf, p / sf[..., None], c / sf


def find_rotations(ds: RawDataset, min_rows: int = 6, tol_deg: float = 1.0):
    """The two toolface rotations: (rows at d1, rows at d2) with d2 - d1 =
    90 deg (within tol) at one azimuth, each with >= min_rows rows spread
    over the toolface.  The pair with the most rows wins."""
    inc, azi, tf = (ds.columns[c] for c in ("inc_deg", "azi_deg", "tf_deg"))
    key = np.round(inc / tol_deg).astype(int), np.round(np.mod(azi, 360.0) / tol_deg).astype(int)
    groups = {}
    for i, k in enumerate(zip(*key)):
        groups.setdefault(k, []).append(i)
    def spread(rows):
        r = np.radians(tf[rows])
        return len(rows) >= min_rows and np.hypot(np.cos(r).mean(), np.sin(r).mean()) < 0.5
    good = {k: np.array(v) for k, v in groups.items() if spread(v)}
    best = None
    for (i1, a1), r1 in good.items():
        for (i2, a2), r2 in good.items():
            if a1 == a2 and abs((i2 - i1) * tol_deg - 90.0) <= tol_deg and inc[r1].mean() < inc[r2].mean():
                if best is None or len(r1) + len(r2) > len(best[0]) + len(best[1]):
                    best = (r1, r2)
    return best


def fit(ds: RawDataset, **_):
    """Guo's continuous calibration; needs the pose columns, the dip, and two
    toolface rotations (>= 6 readings each, e.g. every 30 deg) at
    inclinations 90 deg apart at one azimuth."""
    common.need_poses(ds, "guo2009")
    dip = common.require_dip(ds, "guo2009")
    w = common.world_of(ds)
    pair = find_rotations(ds)
    if pair is None:
        raise DataError("guo2009 needs two toolface rotations (>= 6 readings each, spread over the "
                        "toolface) at inclinations 90 deg apart at one azimuth")
    r1, r2 = pair
    tf = ds.columns["tf_deg"]
    fa1 = fit_trig(tf[r1], ds.acc[r1].T)
    fa2 = fit_trig(tf[r2], ds.acc[r2].T)
    fm1 = fit_trig(tf[r1], ds.mag[r1].T)
    fm2 = fit_trig(tf[r2], ds.mag[r2].T)
    d1 = float(inclination_from_acc(np.stack(fa1[:2], -1), np.stack(fa2[:2], -1)))
    a = float(np.mean(ds.columns["azi_deg"][r1])) - w["declination_deg"]
    G = w["gravity_g"]
    pa, ca = acc_axis(fa1, fa2, d1, G)
    pm, cm = mag_axis(fm1, fm2, d1, a, w["field_nT"], dip)
    Ma, ba = common.forward_to_correction(pa, ca)
    Mm, bm = common.forward_to_correction(pm, cm)
    cal = common.make_cal(Ma, ba, Mm, bm, "guo2009", ds)
    sf_a, u_a, bias_a = scale_bias_cosines(pa, ca)
    sf_m, u_m, bias_m = scale_bias_cosines(pm, cm)
    return cal, {"rows_used": np.concatenate([r1, r2]),
                 "paper_parameters": {"d1_deg": d1, "d1_turntable_deg": float(np.mean(ds.columns["inc_deg"][r1])),
                                      "acc": {"SF": sf_a.tolist(), "cos": u_a.tolist(), "Bias": bias_a.tolist()},
                                      "mag": {"SF": sf_m.tolist(), "cos": u_m.tolist(), "Bias": bias_m.tolist()}},
                 "notes": [f"rotations at inclination {np.mean(ds.columns['inc_deg'][r1]):.1f} and "
                           f"{np.mean(ds.columns['inc_deg'][r2]):.1f} deg (d1 from the accelerometer: {d1:.3f} deg), "
                           f"azimuth {a:.1f} deg"]}


# --------------------------------------------------------------------------
# The paper's simulation (section 4)
SIM_WORLD = {"G": 9.8, "a0_deg": 2.0, "d1_deg": 30.0, "B": 54.0, "dip_deg": 55.0}
# The sensor truth of the simulation is not legible in the web copy (Tables
# 1-3 lost their numbers); these are our choices, in Guo's units: SF in V per
# m/s^2 (accelerometer) and V per uT (fluxgate), Bias in m/s^2 and uT.
SIM_TRUTH = {
    "A_x": {"SF": 0.25, "Bias": 0.02, "cos": (0.9993, 0.0300, -0.0200)},
    "F_x": {"SF": 0.05, "Bias": 0.30, "cos": (0.9980, -0.0400, 0.0500)},
}


def _unit(v):
    v = np.asarray(v, float)
    return v / np.linalg.norm(v)


def simulate(runs: int = 1000, seed: int = 2009, noise_v: float = 0.001, tf_err_deg: float = 1.0,
             step_deg: float = 30.0) -> dict:
    """Guo's Monte Carlo: A_x and F_x over two toolface rotations (every
    step_deg) at d1 = 30 and d1 + 90 deg, azimuth 2 deg, G = 9.8, B = 54,
    dip 55; each output plus a uniform error within +-noise_v V, each
    toolface read with a uniform error within +-tf_err_deg.  Returns, per
    sensor and parameter, truth, mean and standard deviation over the runs."""
    rng = np.random.default_rng(seed)
    W = SIM_WORLD
    r = np.arange(0.0, 360.0, step_deg)
    n = len(r)
    out = {}
    d1_est = None
    for sensor in ("A_x", "F_x"):
        t = SIM_TRUTH[sensor]
        u = _unit(t["cos"])
        fits = []
        for d in (W["d1_deg"], W["d1_deg"] + 90.0):
            r_true = r[None, :] + rng.uniform(-tf_err_deg, tf_err_deg, (runs, n))  # turntable reads r
            I, Rr = np.radians(d), np.radians(r_true)
            if sensor == "A_x":  # our sign (Guo's gravity negated)
                v = W["G"] * np.stack([-np.sin(I) * np.cos(Rr), np.sin(I) * np.sin(Rr),
                                       np.cos(I) + 0 * Rr], -1)
            else:
                a = np.radians(W["a0_deg"])
                Bh = W["B"] * np.cos(np.radians(W["dip_deg"]))
                Bv = W["B"] * np.sin(np.radians(W["dip_deg"]))
                v = np.stack([Bh * (np.cos(Rr) * np.cos(a) * np.cos(I) - np.sin(Rr) * np.sin(a)) - Bv * np.cos(Rr) * np.sin(I),
                              Bh * (-np.sin(Rr) * np.cos(a) * np.cos(I) - np.cos(Rr) * np.sin(a)) + Bv * np.sin(Rr) * np.sin(I),
                              Bh * np.cos(a) * np.sin(I) + Bv * np.cos(I) + 0 * Rr], -1)
            y = t["SF"] * (v @ u + t["Bias"]) + rng.uniform(-noise_v, noise_v, (runs, n))
            fits.append(fit_trig(np.broadcast_to(r, (runs, n)), y))
        if sensor == "A_x":
            # eq. (17): tan d1 = M1/M2 (one axis here)
            d1_est = np.degrees(np.arctan2(np.hypot(fits[0][0], fits[0][1]), np.hypot(fits[1][0], fits[1][1])))
            p, c = acc_axis(fits[0], fits[1], d1_est, W["G"])
        else:
            p, c = mag_axis(fits[0], fits[1], d1_est, W["a0_deg"], W["B"], W["dip_deg"])
        sf, cosines, bias = scale_bias_cosines(p, c)
        est = {"SF": sf, "Bias": bias, "cos_x": cosines[:, 0], "cos_y": cosines[:, 1], "cos_z": cosines[:, 2]}
        truth = {"SF": t["SF"], "Bias": t["Bias"], "cos_x": u[0], "cos_y": u[1], "cos_z": u[2]}
        out[sensor] = {k: {"truth": float(truth[k]), "mean": float(np.mean(v)), "std": float(np.std(v, ddof=1))}
                       for k, v in est.items()}
    out["d1_deg"] = {"truth": W["d1_deg"], "mean": float(np.mean(d1_est)), "std": float(np.std(d1_est, ddof=1))}
    out["runs"] = runs
    return out
