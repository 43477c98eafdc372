"""Helpers the row-pairing and moving-log tests share: a log with its
magnetometer's rows shifted, and band-limited noise."""
from __future__ import annotations

import numpy as np

from inclino.formats import dataset


def shifted(ds, k):
    """The magnetometer's rows k behind (its row i + k is the accelerometer's
    row i's: the lag the checks name, and `[magnetometer] lag = k` undoes);
    the rows the shift leaves unpaired dropped."""
    c = {key: v.copy() for key, v in ds.columns.items()}
    for m in dataset.MAG_COLS:
        c[m] = np.roll(c[m], k)  # the magnetometer's row j is now the true row j - k
    n = len(ds)
    return dataset.RawDataset({key: v[k:] if k > 0 else v[:n + k] for key, v in c.items()}, dict(ds.meta))


def band_noise(rng, n, lo, hi, rate, rms):
    """White noise filtered to lo..hi Hz (FFT), scaled to rms per axis, (n, 3)."""
    f = np.fft.rfftfreq(n, 1.0 / rate)
    X = np.fft.rfft(rng.normal(size=(n, 3)), axis=0)
    X[(f < lo) | (f > hi)] = 0.0
    x = np.fft.irfft(X, n=n, axis=0)
    return x * (rms / x.std(0))
