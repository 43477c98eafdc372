"""Outlier-robust noise: a few spiked rows (a knock on the table, a
settling window cut short) must neither inflate the fitted noise nor mask
an effect.

Start: per channel 1.4826 x the median absolute deviation of the residuals
(the MAD: a 50 % breakdown point, so 1 % of spiked rows do not move it).
Then, alternately: the rows whose whitened squared norm (6 channels, under
the current noise model's 6x6 covariance) exceeds the chi-square point at
p = OUTLIER_P / n (a Bonferroni bound: on Gaussian data the chance of
flagging any row in a dataset is about OUTLIER_P) are set aside, and the
noise model (noise.fit_noise: sensor white noise per channel plus the
turntable readout error through the pose Jacobian, Gaussian maximum
likelihood) is fitted to the other rows.  The mask is recomputed from every
row each time, so a row set aside while a large effect was still unmodelled
comes back once the effect is in the model."""
from __future__ import annotations

from dataclasses import dataclass

import numpy as np
from scipy import stats

from . import names, noise as core_noise

OUTLIER_P = 1e-3
MAX_OUTLIER_FRACTION = 0.2  # more than this: it is the noise, not outliers (heavy-tailed noise is kept)
ITERATIONS = 3


def mad_sigma(R) -> np.ndarray:
    """Per column 1.4826 x the median absolute deviation about the median."""
    med = np.median(R, 0)
    return 1.4826 * np.median(np.abs(R - med), 0)


def _d2(R, noise, J):
    S = noise.row_cov(J)
    w = np.einsum("nij,nj->ni", core_noise.whitener_of(S), R)
    return (w ** 2).sum(1), np.sqrt(np.diagonal(S, axis1=1, axis2=2))


def outlier_mask(R, noise, J, p=OUTLIER_P):
    """(outlier rows (n,) bool, per-channel size in sigma (n, 6))."""
    n = len(R)
    d2, sd = _d2(R, noise, J)
    thr = stats.chi2.isf(p / max(n, 1), R.shape[1])
    out = d2 > thr
    if out.mean() > MAX_OUTLIER_FRACTION:  # keep the worst MAX_OUTLIER_FRACTION only
        k = int(MAX_OUTLIER_FRACTION * n)
        out = np.zeros(n, bool)
        out[np.argsort(d2)[::-1][:k]] = True
    return out, R / sd


def robust_noise(R, J, dof_frac, start=None, ml=True, iterations=ITERATIONS):
    """(Noise, outlier rows): the noise model fitted to the rows that are not
    outliers, the outliers judged under it."""
    if start is None:
        s0 = np.maximum(mad_sigma(R), 1e-12)
        start = core_noise.Noise(s0, np.full(3, 1e-6))
        pre = True
    else:
        pre = False
    out, _ = outlier_mask(R, start, J)
    noise = start
    for it in range(iterations):
        keep = ~out
        if keep.sum() < 12:
            keep = np.ones(len(R), bool)
        noise = core_noise.fit_noise(R[keep], J[keep], dof_frac=dof_frac, start=None if (pre and it == 0) else noise,
                               ml=ml)
        new, _ = outlier_mask(R, noise, J)
        if np.array_equal(new, out):
            break
        out = new
    return noise, out


@dataclass
class OutlierRow:
    row: int  # the file's data row (0 = the first data row)
    channel: str  # the channel furthest out
    sigma: float  # its residual in its own standard deviations (signed)
    channels: dict  # every channel beyond 4 sigma: name -> size in sigma

    def to_dict(self):
        return {"row": int(self.row), "channel": self.channel, "sigma": float(self.sigma),
                "channels": {k: float(v) for k, v in self.channels.items()}}


def describe(mask, z, order) -> list:
    """The outlier rows as OutlierRow records, in file order."""
    rows = []
    for i in np.flatnonzero(mask):
        k = int(np.argmax(np.abs(z[i])))
        rows.append(OutlierRow(int(order[i]), names.CHANNELS[k], float(z[i, k]),
                               {names.CHANNELS[j]: float(z[i, j]) for j in range(6) if abs(z[i, j]) >= 4.0}))
    return sorted(rows, key=lambda r: r.row)
