"""How a calibration's coefficients move the attitude: noise-free raw
readings on the Li 2021 grid, d(azimuth, inclination)/d(24 coefficients) and
the attitude RMS a coefficient covariance predicts.

Its own module because the fit (joint.py, choosing the nonlinear terms), the
prediction (predict.py) and the report (report.py) all use it, and the report
imports the fit: here it depends on none of them.
"""
from __future__ import annotations

import numpy as np

from inclino.engines import reference as ref
from inclino.formats.calfile import Calibration

from . import common
from .runs import li2021_grid


def grid_readings(cal: Calibration, w: dict, dip: float, toolfaces=(0.0, 120.0, 240.0)):
    """Noise-free raw readings a probe with exactly these coefficients gives
    on the Li grid (raw = M^-1 true + b), quantised to sensor counts as the
    parts would (so that the firmware and float engines see the same input)."""
    I, A, T = li2021_grid(toolfaces)
    g, f = ref.body_vectors(I, A, T, w["field_nT"], dip, 0.0, w["gravity_g"])
    acc = g @ np.linalg.inv(np.asarray(cal.acc_m)).T + np.asarray(cal.acc_b)
    mag = f @ np.linalg.inv(np.asarray(cal.mag_m)).T + np.asarray(cal.mag_b)
    return (I, A, T), ref.quantise_acc(acc) * ref.ACC_LSB_G, ref.quantise_mag(mag) * ref.MAG_LSB_NT


def attitude_sensitivity(cal: Calibration, acc, mag):
    """d(azimuth, inclination)/d(24 coefficients) at the given raw readings
    (deg per unit), by central differences."""
    v0 = common.cal_vector(cal)
    steps = np.where(np.arange(24) % 12 < 9, 1e-6, 0.0)
    steps[9:12] = 1e-6  # g
    steps[21:24] = 0.05  # nT
    Ja, Ji = [], []
    for k in range(24):
        outs = []
        for s in (1, -1):
            v = v0.copy()
            v[k] += s * steps[k]
            c = common.cal_from_vector(v)
            a = ref.attitude(ref.correct(acc, c.acc_m, c.acc_b), ref.correct(mag, c.mag_m, c.mag_b))
            outs.append(a)
        Ja.append(ref.angle_diff(outs[0]["azi"], outs[1]["azi"]) / (2 * steps[k]))
        Ji.append((outs[0]["inc"] - outs[1]["inc"]) / (2 * steps[k]))
    return np.array(Ja).T, np.array(Ji).T


def predicted_attitude_rms(cal: Calibration, cov, w: dict, dip: float) -> tuple[float, float]:
    _, acc, mag = grid_readings(cal, w, dip)
    Ja, Ji = attitude_sensitivity(cal, acc, mag)
    va = np.einsum("nk,kl,nl->n", Ja, cov, Ja)
    vi = np.einsum("nk,kl,nl->n", Ji, cov, Ji)
    return float(np.sqrt(va.mean())), float(np.sqrt(vi.mean()))
