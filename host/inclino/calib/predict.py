"""Predicted attitude error over a grid, with every term the calibration
knows about (what `inclino calibrate` reports and `bench calibration` checks
against what is achieved).

Per grid pose p, the azimuth (and inclination) error variance is the sum of

* coefficients: J_p C J_p^T, C the fit's covariance of the 24 coefficients
  (sensor noise and turntable readout error of the calibration run; without
  poses also the unobservable rotation from the prior or the mounting
  tolerance: calib/field.py);
* reading noise: the grid's own readings, sensor sigma / sqrt(n) per axis at
  the survey's averaging n, through d(attitude)/d(raw) -- it grows as
  1/sin I at low inclination; the sigmas are the calibration run's own,
  fitted per channel (calib/covariance.py), not one scale for both triads;
* pose error: the error of the pose each grid reading is set to, through
  d(attitude)/d(pose), when the run's fitted pose error is given (the check
  then sits on the same bench);
* input resolution: the sensors' whole counts, 1/sqrt(12 n) count per axis
  once the noise dithers them, plus the firmware's Q6 rounding of the mean
  (1/(64 sqrt 12) count);

plus the square of a bias:

* linear model: the fitted scale nonlinearity (joint's nuisance q) that the
  firmware's linear calibration cannot hold: the written calibration applied
  to the readings the fitted nonlinear model predicts at p.
* (passed in as `bias`) a paper method's model misfit
  (calib/paper_bootstrap.py: its calibration applied to the readings of
  the affine least-squares fit of the same rows), or a prior's nonlinearity
  through a field fit (calib/fieldbias.py).

The RMS over the grid is sqrt(mean_p(variance_p + bias_p^2)).  With
reading_noise=False (a noise-free, unquantised grid, as bench calibration's
accuracy grid) only the coefficients and the linear-model bias count.
"""
from __future__ import annotations

from dataclasses import asdict, dataclass, field

import numpy as np

from inclino.engines import reference as ref
from inclino.formats.calfile import Calibration

from .runs import li2021_grid


GRID = li2021_grid((0.0, 120.0, 240.0))


@dataclass
class Prediction:
    grid: str
    n_avg: float | None
    reading_noise: bool
    azi_rms_deg: float
    inc_rms_deg: float
    terms_azi_rms_deg: dict = field(default_factory=dict)
    terms_inc_rms_deg: dict = field(default_factory=dict)
    sigmas: dict = field(default_factory=dict)

    def to_dict(self) -> dict:
        return asdict(self)

    @classmethod
    def from_dict(cls, d: dict) -> "Prediction":
        return cls(**d)


def _att(cal: Calibration, acc, mag):
    return ref.attitude(ref.correct(acc, cal.acc_m, cal.acc_b), ref.correct(mag, cal.mag_m, cal.mag_b))


def raw_sensitivity(cal: Calibration, acc, mag, h_acc=1e-6, h_mag=0.05):
    """d(azimuth, inclination)/d(raw reading), (n, 6) each, deg per g / nT."""
    X = np.concatenate([acc, mag], axis=1)
    Ja, Ji = np.zeros((len(X), 6)), np.zeros((len(X), 6))
    for k in range(6):
        h = h_acc if k < 3 else h_mag
        o = []
        for s in (1, -1):
            Y = X.copy()
            Y[:, k] += s * h
            o.append(_att(cal, Y[:, :3], Y[:, 3:]))
        Ja[:, k] = ref.angle_diff(o[0]["azi"], o[1]["azi"]) / (2 * h)
        Ji[:, k] = (o[0]["inc"] - o[1]["inc"]) / (2 * h)
    return Ja, Ji


def _model_readings(nl: dict, g, f):
    """Readings of the fitted nonlinear model: raw + (q/S) raw^2 = M^-1 v + b."""
    out = []
    for M, b, qs, v in ((nl["model_acc_m"], nl["model_acc_b"], nl["acc_q_per_g"], g),
                        (nl["model_mag_m"], nl["model_mag_b"], nl["mag_q_per_nT"], f)):
        u = np.linalg.solve(np.asarray(M), np.asarray(v).T).T + np.asarray(b)
        q = np.asarray(qs)
        out.append(2.0 * u / (1.0 + np.sqrt(np.maximum(1.0 + 4.0 * q * u, 0.0))))
    return out


def pose_sensitivity(I, A, T, w: dict, dip: float, h: float = 1e-3):
    """d(azimuth, inclination)/d(turntable inc, azi, tf), (n, 3) each: how
    an error of the pose the probe is set to shows in its survey against
    the indicated pose."""
    def att(i, a, t):
        g, f = ref.body_vectors(i, a, t, w["field_nT"], dip, 0.0, w["gravity_g"])
        return ref.attitude(g, f)
    Pa, Pi = np.zeros((len(I), 3)), np.zeros((len(I), 3))
    for k in range(3):
        p1 = [np.asarray(v, float).copy() for v in (I, A, T)]
        p0 = [v.copy() for v in p1]
        p1[k] += h
        p0[k] -= h
        o1, o0 = att(*p1), att(*p0)
        Pa[:, k] = ref.angle_diff(o1["azi"], o0["azi"]) / (2 * h)
        Pi[:, k] = (o1["inc"] - o0["inc"]) / (2 * h)
    return Pa, Pi


def predict(cal: Calibration, cov, w: dict, dip: float, sigma_acc, sigma_mag,
            n_avg: float | None = None, reading_noise: bool = True, nonlinear: dict | None = None,
            grid=None, grid_name: str = "Li 2021 grid, toolfaces 0/120/240",
            resolution_n: float | None = None, bias=None, bias_name: str = "linear_model_bias",
            sigma_pose_deg=None, lsb=(None, None)) -> Prediction:
    """sigma_acc, sigma_mag: noise of one sample (a number, or one per
    axis); n_avg samples per reading (noise / sqrt(n_avg)); resolution_n:
    the samples behind the input resolution term when it differs from n_avg
    (e.g. sigmas already given per averaged reading, n_avg = 1);
    sigma_pose_deg: (3,) the error of the pose each grid reading is set to
    (turntable inc, azi, tf; the calibration run's fitted pose error when
    the check is on the same bench), a term of its own; lsb: (g, nT) per
    count of the sensor that read the run (its description), else the
    ADIS16210's and the fluxgate's."""
    I, A, T = grid if grid is not None else GRID
    g, f = ref.body_vectors(I, A, T, w["field_nT"], dip, 0.0, w["gravity_g"])
    acc = g @ np.linalg.inv(np.asarray(cal.acc_m)).T + np.asarray(cal.acc_b)
    mag = f @ np.linalg.inv(np.asarray(cal.mag_m)).T + np.asarray(cal.mag_b)
    from .sensitivity import attitude_sensitivity

    terms_a, terms_i = {}, {}
    var_a = np.zeros(len(I))
    var_i = np.zeros(len(I))
    Ca, Ci = attitude_sensitivity(cal, acc, mag)
    va = np.einsum("nk,kl,nl->n", Ca, cov, Ca)
    vi = np.einsum("nk,kl,nl->n", Ci, cov, Ci)
    terms_a["coefficients"], terms_i["coefficients"] = va, vi
    n = float(n_avg) if n_avg else 1.0
    if reading_noise:
        Ra, Ri = raw_sensitivity(cal, acc, mag)
        s_noise = np.concatenate([np.broadcast_to(np.asarray(sigma_acc, float), (3,)),
                                  np.broadcast_to(np.asarray(sigma_mag, float), (3,))]) / np.sqrt(n)
        nr = float(resolution_n) if resolution_n else n
        s_res = np.array([ref.ACC_LSB_G] * 3 + [ref.MAG_LSB_NT] * 3) * np.sqrt(1.0 / (12 * nr) + 1.0 / (12 * 64.0**2))
        if lsb[0] is not None or lsb[1] is not None:
            # the sensor's own resolution (report.input_lsb; 0.0: none in the logged values), then the firmware's
            # Q6 rounding
            own = np.array([ref.ACC_LSB_G if lsb[0] is None else float(lsb[0])] * 3
                           + [ref.MAG_LSB_NT if lsb[1] is None else float(lsb[1])] * 3)
            probe = np.array([ref.ACC_LSB_G] * 3 + [ref.MAG_LSB_NT] * 3)
            s_res = np.sqrt(own ** 2 / (12 * nr) + probe ** 2 / (12 * 64.0**2))
        for name, s in (("reading_noise", s_noise), ("input_resolution", s_res)):
            terms_a[name] = (Ra ** 2) @ (s ** 2)
            terms_i[name] = (Ri ** 2) @ (s ** 2)
        if sigma_pose_deg is not None and np.any(np.asarray(sigma_pose_deg) > 0):
            Pa, Pi = pose_sensitivity(I, A, T, w, dip)
            sp2 = np.asarray(sigma_pose_deg, float) ** 2
            terms_a["pose_error"], terms_i["pose_error"] = (Pa ** 2) @ sp2, (Pi ** 2) @ sp2
    for k in terms_a:
        var_a = var_a + terms_a[k]
        var_i = var_i + terms_i[k]
    if nonlinear and "model_acc_m" in nonlinear:
        ra, rm = _model_readings(nonlinear, g, f)
        a = _att(cal, ra, rm)
        ba = ref.angle_diff(a["azi"], _att(cal, acc, mag)["azi"])
        bi = a["inc"] - _att(cal, acc, mag)["inc"]
        terms_a["linear_model_bias"], terms_i["linear_model_bias"] = ba ** 2, bi ** 2
        var_a, var_i = var_a + ba ** 2, var_i + bi ** 2
    if bias is not None:  # a bias known per grid pose (e.g. field.nonlinear_bias)
        ba, bi = bias
        terms_a[bias_name], terms_i[bias_name] = np.asarray(ba) ** 2, np.asarray(bi) ** 2
        var_a, var_i = var_a + terms_a[bias_name], var_i + terms_i[bias_name]
    rms = lambda v: float(np.sqrt(np.mean(v)))  # noqa: E731
    sig = lambda v: float(v) if np.ndim(v) == 0 else np.asarray(v, float).tolist()  # noqa: E731
    sigmas = {"acc_g": sig(sigma_acc), "mag_nT": sig(sigma_mag)}
    if sigma_pose_deg is not None:
        sigmas["pose_deg"] = sig(sigma_pose_deg)
    return Prediction(grid_name, n_avg, reading_noise, rms(var_a), rms(var_i),
                      {k: rms(v) for k, v in terms_a.items()}, {k: rms(v) for k, v in terms_i.items()}, sigmas)


def rms_spread(cal: Calibration, cov, w: dict, dip: float, sigma_acc, sigma_mag, grid, n_avg: float = 1.0,
               band=(0.7, 1.4), draws: int = 4000, seed: int = 0, sigma_pose_deg=None) -> dict:
    """How far one grid's measured azimuth RMS strays from the predicted
    (expected) RMS by chance alone: Monte Carlo of the prediction's own
    random terms on `grid` -- the coefficients' error (one draw per check,
    common to every position), each position's reading noise and pose
    error.  Returns the 5/50/95 % points of measured / predicted and the
    chance that the ratio falls outside `band` although the prediction is
    right.  A grid whose RMS rests on a few near-vertical positions scatters
    widely: compare a miss with this before blaming an effect."""
    I, A, T = (np.asarray(v, float) for v in grid)
    g, f = ref.body_vectors(I, A, T, w["field_nT"], dip, 0.0, w["gravity_g"])
    acc = g @ np.linalg.inv(np.asarray(cal.acc_m)).T + np.asarray(cal.acc_b)
    mag = f @ np.linalg.inv(np.asarray(cal.mag_m)).T + np.asarray(cal.mag_b)
    from .sensitivity import attitude_sensitivity

    Ca, _ = attitude_sensitivity(cal, acc, mag)
    Ra, _ = raw_sensitivity(cal, acc, mag)
    ok = I >= 0.5
    Ca, Ra = Ca[ok], Ra[ok]
    s = np.concatenate([np.broadcast_to(np.asarray(sigma_acc, float), (3,)),
                        np.broadcast_to(np.asarray(sigma_mag, float), (3,))]) / np.sqrt(float(n_avg))
    cov = np.asarray(cov, float)[:Ca.shape[1], :Ca.shape[1]]
    wv, V = np.linalg.eigh((cov + cov.T) / 2)
    L = V * np.sqrt(np.clip(wv, 0, None))
    sp = np.zeros(3) if sigma_pose_deg is None else np.asarray(sigma_pose_deg, float)
    Pa = pose_sensitivity(I[ok], A[ok], T[ok], w, dip)[0] if np.any(sp > 0) else np.zeros((int(ok.sum()), 3))
    expected = np.mean(np.einsum("nk,kl,nl->n", Ca, cov, Ca) + (Ra ** 2) @ (s ** 2) + (Pa ** 2) @ (sp ** 2))
    rng = np.random.default_rng(seed)
    r = np.empty(draws)
    for k in range(draws):
        e = Ca @ (L @ rng.standard_normal(L.shape[1])) + (Ra * (rng.standard_normal(Ra.shape) * s)).sum(1) \
            + (Pa * (rng.standard_normal(Pa.shape) * sp)).sum(1)
        r[k] = np.sqrt(np.mean(e ** 2) / expected)
    p5, p50, p95 = np.percentile(r, [5, 50, 95])
    return {"ratio_p5": float(p5), "ratio_median": float(p50), "ratio_p95": float(p95),
            "p_outside_band": float(np.mean((r < band[0]) | (r > band[1]))), "band": list(band),
            "positions": int(ok.sum()), "draws": draws}
