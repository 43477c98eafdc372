"""A typical uncalibrated probe for the fixed-point benchmarks: its
coefficients, and the raw readings it gives for true vectors.

Apart from bench.py because the averaging benchmark (bench_averaging.py)
uses it and bench.py runs the averaging benchmark.
"""
from __future__ import annotations

import numpy as np

from inclino.formats.calfile import Calibration


def typical_calibration(seed: int = 7) -> Calibration:
    """A typical probe's coefficients: scale errors of a few percent,
    misalignments of about a degree, accelerometer bias tens of mg,
    fluxgate hard iron hundreds of nT.  Not round numbers, so that
    coefficient quantisation is exercised."""
    rng = np.random.default_rng(seed)
    def m():
        return (np.diag(1 + rng.uniform(-0.05, 0.05, 3)) + rng.uniform(-0.02, 0.02, (3, 3)) * (1 - np.eye(3)))
    return Calibration(acc_m=m().tolist(), acc_b=rng.uniform(-0.03, 0.03, 3).tolist(),
                       mag_m=m().tolist(), mag_b=rng.uniform(-800, 800, 3).tolist(), method="typical")


def _raw_for(cal: Calibration, g_true, b_true):
    """Readings an uncalibrated probe with these coefficients gives:
    raw = M^-1 @ true + b (the inverse of the correction)."""
    ga = g_true @ np.linalg.inv(np.asarray(cal.acc_m)).T + np.asarray(cal.acc_b)
    bm = b_true @ np.linalg.inv(np.asarray(cal.mag_m)).T + np.asarray(cal.mag_b)
    return ga, bm
