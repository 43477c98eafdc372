"""The lag between a sensor's temperature and the probe's TEMP_OUT during a
ramp (docs/calibration.md, "The ramp model").

The temperature terms (calib/thermal.py) take each reading's temperature as
the probe's TEMP_OUT, which is the ADIS16210's die: the accelerometer's own
temperature, but the fluxgate sits elsewhere in the housing and may lag it.
With the fluxgate at T - tau dT/dt (a first-order lag tau, to first order
in tau), a reading taken while the probe warms at rate r reads as if it were
tau r cooler: its error after the terms is -tau r d(raw)/dT, d(raw)/dT the
fitted terms' slope at that temperature.  Readings taken at one temperature
with the rate of either sign (a ramp down and back up) separate tau from the
terms.

`estimate(ds, cal)` regresses what the fit leaves (the corrected readings
against the poses' true vectors) on that signature, per triad, weighted
by the triad's noise: tau with its standard error, and what that lag does at
the run's fastest rate.  The rate is dT/dt of TEMP_OUT against the probe's
clock (t_s), a least-squares slope over RATE_WINDOW_S around each reading.
Soaked runs (rates near zero everywhere) leave tau undetermined and say so.
"""
from __future__ import annotations

import numpy as np

from inclino.engines import reference as ref

from . import common

RATE_WINDOW_S = 120.0


def rates(t_s, temp_c, window_s: float = RATE_WINDOW_S) -> np.ndarray:
    """dT/dt (degC/s) at each reading: the least-squares slope of TEMP_OUT
    over the readings within window_s / 2 either side (time order)."""
    t = np.asarray(t_s, float)
    T = np.asarray(temp_c, float)
    order = np.argsort(t)
    ts, Ts = t[order], T[order]
    out = np.zeros(len(t))
    lo = np.searchsorted(ts, ts - window_s / 2.0, side="left")
    hi = np.searchsorted(ts, ts + window_s / 2.0, side="right")
    for k in range(len(ts)):
        a, b = lo[k], hi[k]
        if b - a >= 3 and np.ptp(ts[a:b]) > 0:
            x = ts[a:b] - ts[a:b].mean()
            out[k] = float(x @ (Ts[a:b] - Ts[a:b].mean()) / (x @ x))
    res = np.empty(len(t))
    res[order] = out
    return res


def _slope(block: dict, tri: str, raw, temp, b) -> np.ndarray:
    """d(raw)/dT (per degC) of the fitted terms at each reading: (n, 3)."""
    K = int(block["order"])
    tr = float(block["t_ref_c"])
    bias = np.asarray(block[tri]["bias"], float).reshape(K, 3)
    scale = np.asarray(block[tri]["scale_ppm"], float).reshape(K, 3) * 1e-6
    dT = np.asarray(temp, float)[:, None] - tr
    dbias = sum((k + 1) * bias[k] * dT ** k for k in range(K))
    dscale = sum((k + 1) * scale[k] * dT ** k for k in range(K))
    return dbias + (np.asarray(raw, float) - b) * dscale


def _nuisance(raw_ref, b, M, T, blk) -> np.ndarray:
    """d e / d (M entries, offsets, the triad's temperature terms): (3n, 12 + 6K)."""
    n = len(raw_ref)
    u = raw_ref - b
    K = int(blk["order"])
    dT = np.asarray(T, float) - float(blk["t_ref_c"])
    cols = []
    for i in range(3):  # e_i = sum_j M_ij u_j - c_i
        for j in range(3):
            c = np.zeros((n, 3))
            c[:, i] = u[:, j]
            cols.append(c)
        c = np.zeros((n, 3))
        c[:, i] = -1.0
        cols.append(c)
    for k in range(K):
        for i in range(3):
            cols.append(-np.outer(dT ** (k + 1), M[:, i]))  # bias
            cols.append(-np.outer(u[:, i] * 1e-6 * dT ** (k + 1), M[:, i]))  # scale
    return np.stack([c.reshape(-1) for c in cols], axis=1)


def estimate(ds, cal) -> dict:
    """tau (s) of each triad's temperature behind TEMP_OUT, with its
    standard error, from a run with temp_c, t_s and poses and a calibration
    with temperature terms; {} without them."""
    blk = getattr(cal, "temperature", None)
    if not blk or not ds.has_pose or "t_s" not in ds.columns or "temp_c" not in ds.columns:
        return {}
    from .thermal import to_reference

    w = common.world_of(ds)
    dip = float((cal.report or {}).get("uncertainty", {}).get("dip_deg", w["dip_deg"] if w["dip_deg"] is not None
                                                                       else 60.0))
    T = ds.columns["temp_c"]
    r = rates(ds.columns["t_s"], T)
    acc, mag = to_reference(ds.acc, ds.mag, T, cal, blk)
    g, f = common.true_vectors(ds, dip, w["field_nT"], w["declination_deg"], w["gravity_g"])
    out = {"rate_max_c_per_min": float(np.abs(r).max() * 60.0), "window_s": RATE_WINDOW_S}
    for tri, raw_ref, raw, v, M, b in (("acc", acc, ds.acc, g, cal.acc_m, cal.acc_b),
                                       ("mag", mag, ds.mag, f, cal.mag_m, cal.mag_b)):
        M, b = np.asarray(M, float), np.asarray(b, float)
        e = (raw_ref - b) @ M.T - v  # what the fit leaves, corrected units
        x = (-r[:, None] * _slope(blk, tri, raw, T, b)) @ M.T  # d e / d tau
        if float((x * x).sum()) <= 0 or np.abs(r).max() < 1e-4:
            out[tri] = {"tau_s": None, "why": "the run's temperature hardly changed while reading (soaked): "
                                              "the lag is not determined"}
            continue
        # with the triad's M, offset and temperature terms free as well (a Gauss-Newton step
        # from the fit, which is at its optimum for tau = 0): what the terms can absorb of a
        # lag is not counted as lag
        X = np.concatenate([x.reshape(-1, 1), _nuisance(raw_ref, b, M, T, blk)], axis=1)
        nrm = np.linalg.norm(X, axis=0)
        nrm[nrm == 0] = 1.0
        Xs = X / nrm  # the columns' units differ by decades
        sol, *_ = np.linalg.lstsq(Xs, e.reshape(-1), rcond=None)
        resid = e.reshape(-1) - Xs @ sol
        s2 = float(resid @ resid / max(len(resid) - X.shape[1], 1))
        cov = s2 * np.linalg.pinv(Xs.T @ Xs)
        tau = float(sol[0] / nrm[0])
        se = float(np.sqrt(max(cov[0, 0], 0.0)) / nrm[0])
        # what this lag leaves at the run's fastest rate, in the triad's corrected units (g or nT)
        k = int(np.argmax(np.abs(r)))
        eff = float(np.linalg.norm(tau * x[k]))
        out[tri] = {"tau_s": tau, "tau_se_s": se, "effect_at_max_rate": eff,
                    "units": "g" if tri == "acc" else "nT"}
    return out


def attitude_effect(cal, ds, tau_s: float, tri: str = "mag") -> float:
    """Azimuth RMS (deg) over the run's poses that a lag tau_s of one triad
    leaves after the terms, at each reading's own rate: the figure that says
    whether a lag of that size matters for this run."""
    blk = cal.temperature
    T = ds.columns["temp_c"]
    r = rates(ds.columns["t_s"], T)
    from .thermal import to_reference

    acc, mag = to_reference(ds.acc, ds.mag, T, cal, blk)
    b = np.asarray(cal.mag_b if tri == "mag" else cal.acc_b, float)
    d = -tau_s * r[:, None] * _slope(blk, tri, ds.mag if tri == "mag" else ds.acc, T, b)
    a0 = ref.attitude(ref.correct(acc, cal.acc_m, cal.acc_b), ref.correct(mag, cal.mag_m, cal.mag_b))
    acc2, mag2 = (acc + d, mag) if tri == "acc" else (acc, mag + d)
    a1 = ref.attitude(ref.correct(acc2, cal.acc_m, cal.acc_b), ref.correct(mag2, cal.mag_m, cal.mag_b))
    ok = (ds.columns["inc_deg"] >= 5.0) & (ds.columns["inc_deg"] <= 175.0)
    da = ref.angle_diff(a1["azi"], a0["azi"])[ok]
    return float(np.sqrt(np.mean(da ** 2))) if da.size else 0.0
