"""Residual study and the structure test.

Per sensor axis (channel), the residuals are regressed on families of
generic regressors -- functions of what a residual could depend on, not of
any one library effect:

* pose: the quadratic terms of the gravity and field directions (12; the
  linear ones are the baseline's);
* temperature: dT, dT^2, dT x (x = the axis's own signal);
* time: tau, tau^2, tau x (tau = time since the first reading);
* field: x^2, x^3 -- the component the axis measures;
* move: the direction (+1/-1) of the last move of each turntable axis,
  alone and times the axis's change per degree of that turntable axis
  (backlash: the probe lags behind the move);
* rate: the axis's signal change per second through each turntable axis'
  rotation rate (continuous data only).

Each family is one F-test against the channel's own model (its baseline
columns, and the kept effects' columns on that channel), weighted by the
row's variance from the noise model (the turntable's readout error makes the
noise differ from pose to pose).  Whiteness: a Ljung-Box test on the
standardised residuals in time order.  On the baseline's residuals this is
the residual study; on the final residuals it is the structure test: a
result is `unexplained` when any test has p < alpha / (number of tests).
"""
from __future__ import annotations

import numpy as np
from scipy import stats

from .core import CHANNELS, TRIADS, Data
from . import serial
from .serial import ljung_box_q

FAMILIES = ("pose", "temperature", "time", "field", "move", "rate")


def _channel_signal(bl, ch):
    tri = TRIADS[ch // 3]
    return bl.signal(tri)[:, ch % 3]


def family_columns(d: Data, bl, ch: int) -> dict:
    """Family name -> (n, q) generic regressors for channel ch."""
    x = _channel_signal(bl, ch)
    xs = x / max(np.abs(x).max(), 1e-300)
    out = {}
    ug = bl.G / np.linalg.norm(bl.G, axis=1, keepdims=True)
    uf = bl.B / np.linalg.norm(bl.B, axis=1, keepdims=True)
    iu = np.triu_indices(3)
    out["pose"] = np.column_stack([(ug[:, :, None] * ug[:, None, :])[:, iu[0], iu[1]],
                                   (uf[:, :, None] * uf[:, None, :])[:, iu[0], iu[1]]])
    if d.temp is not None and np.ptp(d.temp) > 0:
        dT = (d.temp - d.temp.mean()) / max(np.abs(d.temp - d.temp.mean()).max(), 1e-300)
        out["temperature"] = np.column_stack([dT, dT ** 2, dT * xs])
    if d.t is not None and np.ptp(d.t) > 0:
        tau = (d.t - d.t[0]) / np.ptp(d.t)
        out["time"] = np.column_stack([tau, tau ** 2, tau * xs])
    out["field"] = np.column_stack([xs ** 2, xs ** 3])
    # direction of the last move of each turntable axis: alone (a direction-
    # dependent reading) and times the reading's change per degree of that
    # axis (a pose that lags behind the move: backlash)
    mv = [c for k in range(3) if np.ptp(d.last_move[:, k]) > 0
          for c in (d.last_move[:, k], d.last_move[:, k] * bl.Jpose[:, ch, k])]
    if mv:
        out["move"] = np.column_stack(mv)
    if d.moving.sum() >= 10:
        out["rate"] = bl.Jpose[:, ch, :] * d.rates
    return out


def _wls_fit(y, X, w):
    """(whitened residual, rank) of y on the columns X under the weights w
    (the columns scaled to unit length before the solve)."""
    sw = np.sqrt(w)
    A = X * sw[:, None]
    s = np.sqrt((A ** 2).sum(0))
    s[s == 0] = 1.0
    A = A / s
    beta, _, rank, _ = np.linalg.lstsq(A, y * sw, rcond=1e-8)
    return y * sw - A @ beta, int(rank)


def _wls_rss(y, X, w):
    r, rank = _wls_fit(y, X, w)
    return float(r @ r), rank


def ljung_box(r, h):
    n = len(r)
    r = r - r.mean()
    den = float(r @ r)
    if den <= 0 or n <= h + 1:
        return 1.0, 0.0
    rho = np.array([float(r[k:] @ r[:-k]) / den for k in range(1, h + 1)])
    return ljung_box_q(rho, n)


def study(d: Data, bl, R, var, own_cols) -> dict:
    """R (n, 6) residuals; var (n, 6) each row's noise variance per channel;
    own_cols: channel -> (n, p) columns the channel's model already has.
    Returns per channel the family tests and the Ljung-Box test."""
    out = {}
    for ch, name in enumerate(CHANNELS):
        y = R[:, ch]
        w = 1.0 / var[:, ch]
        base = own_cols[ch]
        rss0, rank0 = _wls_rss(y, base, w)
        # rows whose noise correlates from one to the next (a sensor's filter read at a high rate while the
        # table turns): each family's F-test is deflated by its Bartlett factor and the whiteness test asks
        # for more than AR(p) noise, as the pose-free structure test does
        correlated = serial.row_correlated(_wls_resid(y, base, w), len(CHANNELS))
        fams = {}
        for fam, Z in family_columns(d, bl, ch).items():
            rss1, rank1 = _wls_rss(y, np.column_stack([base, Z]), w)
            q = rank1 - rank0
            dof = d.n - rank1
            if q <= 0 or dof <= 0:
                continue
            F = ((rss0 - rss1) / q) / (rss1 / dof) if rss1 > 0 else np.inf
            f = _family_factor(y, base, Z, w) if correlated else 1.0
            fams[fam] = {"p": float(stats.f.sf(F / f, q, max(dof / f, 1.0))), "F": float(F), "q": int(q),
                         "explained": float(max(rss0 - rss1, 0.0) / rss0) if rss0 > 0 else 0.0,
                         **({"serial_factor": f} if correlated else {})}
        h = int(min(10, max(1, d.n // 5)))
        if correlated:
            p_lb, ar = serial.prewhitened_ljung_box(_wls_resid(y, base, w))
            white = {"test": "Ljung-Box of the residual less an AR(p) noise model", "lags": serial.LJUNG_BOX_LAGS,
                     "p": p_lb, "ar_order": int(ar)}
        else:
            p_lb, Q = ljung_box(y * np.sqrt(w), h)
            white = {"test": "Ljung-Box", "lags": h, "p": p_lb, "Q": Q}
        strongest = min(fams, key=lambda k: fams[k]["p"]) if fams else None
        out[name] = {"rms": float(np.sqrt(np.mean(y ** 2))), "families": fams, "whiteness": white,
                     "serially_correlated": bool(correlated), "strongest": strongest}
    return out


def _wls_resid(y, X, w):
    """The whitened residual (time order) of y on the columns X under the weights w."""
    return _wls_fit(y, X, w)[0]


def _family_factor(y, base, Z, w) -> float:
    """The Bartlett factor (serial.columns_factor) of a family's columns Z,
    whitened and with the channel's own columns projected out, against the
    whitened residual of the model with them."""
    sw = np.sqrt(w)
    A = base * sw[:, None]
    Zw = Z * sw[:, None]
    s = np.sqrt((A ** 2).sum(0))
    s[s == 0] = 1.0
    Zc = Zw - (A / s) @ np.linalg.lstsq(A / s, Zw, rcond=1e-8)[0]
    return serial.columns_factor(Zc, _wls_resid(y, np.column_stack([base, Z]), w))


def structure_verdict(st: dict, alpha: float) -> dict:
    tests = []
    for ch, s in st.items():
        for fam, r in s["families"].items():
            tests.append((r["p"], ch, fam))
        tests.append((s["whiteness"]["p"], ch, "whiteness"))
    m = len(tests)
    p, ch, fam = min(tests) if tests else (1.0, None, None)
    return {"alpha": alpha, "tests": m, "threshold": alpha / max(m, 1), "min_p": p,
            "worst": {"channel": ch, "test": fam}, "unexplained": bool(p < alpha / max(m, 1)),
            "significant": [dict({"channel": c, "test": f, "p": q},
                                 **({"ar_order": st[c]["whiteness"]["ar_order"]}
                                    if f == "whiteness" and st[c]["whiteness"].get("ar_order") else {}))
                            for q, c, f in sorted(tests) if q < alpha / max(m, 1)]}
