"""The papers' methods' uncertainty (li2021, guo2009, ren2014): closed forms
without a covariance, so a parametric bootstrap of refits around the fit.

What a calibration run's readings carry, and how each enters the refits:

* the sensor noise of each reading: per channel, the larger of the noise
  assumed (given, else the nominal ADIS16210-class reading) and what the
  run's own residuals show;
* a pose error: the turntable's readout, shared by every row read at one
  setting of a pose (`covariance.cluster_labels`).  The probe then sat at a
  slightly different orientation, so its *readings* changed, the same way
  for every row of that setting, while the pose columns say what was
  indicated either way.  A refit's readings are the fitted forward model's
  at the indicated pose turned by a pose error drawn once per setting (per
  turntable axis: inc, azi, tf), the pose columns as indicated -- not the
  pose columns perturbed row by row, which the methods barely feel (they
  read the positions' rows by their indicated pose): with that, li2021's
  coefficients missed their sigma by 4.5-12 times (z RMS);
* a drift shared by a setting's rows (per channel, when some pose has more
  than one row).

What the residuals show is read off the firmware's own model -- the
12-parameter affine raw = A true + c per triad, fitted by least squares to
the same rows against the indicated poses -- by REML
(`covariance.fit_components`, as joint reads its run's noise: sensor noise
per channel, pose error per turntable axis through the pose Jacobian, the
per-channel drift; the restricted likelihood counts the 24 parameters the
fit spent, i.e. it is dof-corrected), the sensor noise constrained to at
least the assumed one so that what that already explains is not counted
again.  The pose error and drift are taken as fitted.

The papers' models are that affine model (li2021, guo2009) or narrower
(ren2014's fluxgate: a non-tilted ellipsoid and three circle normals, no
soft iron).  A method whose residuals exceed the affine model's by more than
the noise explains (`misfit`) misses what the data hold: its coefficients'
difference from the affine fit is a bias, not noise.  It is added to the
reported covariance as its outer product (a mean square error, said so in
the source line), and its effect on the attitude over the Li grid enters the
predicted accuracy as the `model_misfit` bias.
"""
from __future__ import annotations

from dataclasses import dataclass, field

import numpy as np

from inclino.engines import reference as ref
from inclino.formats.calfile import Calibration
from inclino.formats.dataset import RawDataset

from . import common, covariance

ACC_COLS = ("ax_g", "ay_g", "az_g")
MAG_COLS = ("mx_nT", "my_nT", "mz_nT")
# a misfit: the method's residual excess over the affine model's beyond what the noise gives by this many of its
# standard deviations (misfit()); tested with this many refits at least
MISFIT_SD = 6.0
MISFIT_MIN_REFITS = 5
# refits by default: the covariance of 24 coefficients from n refits has an inverse (chi^2, a tool model's
# projection) biased by (n - 1)/(n - 26): 2.8x with 40 refits, 1.14x with 200 (a few ms each)
DEFAULT_REFITS = 200


@dataclass
class PaperUncertainty:
    """cov: the coefficients' covariance from the refits (24 x 24); mse: cov
    plus the misfit bias' outer product (= cov without a misfit); refits:
    the refits that succeeded; sigma (6,), sigma_cluster (6,) raw units and
    sigma_pose_deg (3,) what the refits drew; noise_from: per triad, which
    of the assumed and the residuals' noise won; comps: the REML fit;
    misfit: None, or what the method's model misses (triads, residual
    excess, coefficient bias, grid bias)."""
    cov: np.ndarray
    mse: np.ndarray
    refits: int
    sigma: np.ndarray
    sigma_cluster: np.ndarray
    sigma_pose_deg: np.ndarray
    noise_from: dict
    comps: covariance.NoiseComponents
    clusters: int
    rows: int
    misfit: dict | None = None
    notes: list = field(default_factory=list)

    def per_cell(self) -> np.ndarray:
        """One new reading's noise per channel at a new pose (raw units)."""
        return np.sqrt(self.sigma ** 2 + self.sigma_cluster ** 2)


def affine_fit(acc, mag, g, f):
    """The firmware's model by least squares, per triad: raw = A true + c
    (true: the indicated poses' vectors, exact regressors).  Returns
    (A_a, c_a, A_m, c_m)."""
    out = []
    for raw, true in ((acc, g), (mag, f)):
        X = np.column_stack([true, np.ones(len(true))])
        sol, *_ = np.linalg.lstsq(X, raw, rcond=None)
        out += [sol[:3].T, sol[3]]
    return tuple(out)


def forward_residuals(acc, mag, g, f, Aa, ca, Am, cm) -> np.ndarray:
    """raw - (A true + c) per row, both triads (n, 6), raw units."""
    return np.concatenate([acc - (g @ Aa.T + ca), mag - (f @ Am.T + cm)], axis=1)


def _cal_forward(cal: Calibration):
    Aa, ca = common.correction_to_forward(cal.acc_m, cal.acc_b)
    Am, cm = common.correction_to_forward(cal.mag_m, cal.mag_b)
    return Aa, ca, Am, cm


def _forward_rows(cal: Calibration) -> np.ndarray:
    """(2, 3, 4): per triad and axis, row i of the forward A and c_i."""
    p = _cal_forward(cal)
    return np.stack([np.column_stack([p[2 * t], p[2 * t + 1]]) for t in range(2)])


def forward_difference(ds: RawDataset, cal: Calibration, g, f) -> np.ndarray:
    """(2, 3, 4): per triad and axis, the method's forward coefficients
    (row i of A, c_i) less the affine least-squares fit's on the same rows."""
    a = affine_fit(ds.acc, ds.mag, g, f)
    return _forward_rows(cal) - np.stack([np.column_stack([a[2 * t], a[2 * t + 1]]) for t in range(2)])


def excess(delta, V) -> np.ndarray:
    """Per triad, the residual sum of squares (raw units, against the
    indicated poses) that coefficients off the least-squares fit by delta
    (2, 3, 4) add to it: sum_i delta_i^T V^T V delta_i per triad, V = [true 1]
    per triad ((2, n, 4)).  For the method's own coefficients this is its
    residual sum of squares less the affine fit's (the least-squares
    residual is orthogonal to V)."""
    out = []
    for t in range(2):
        G = V[t].T @ V[t]
        out.append(float(np.einsum("ij,jk,ik->", delta[t], G, delta[t])))
    return np.array(out)


def residual_noise(ds: RawDataset, w: dict, dip: float, labels, floor=None, pose_floor_deg=None) -> tuple:
    """REML noise components of the affine fit's residuals on these rows
    (raw units; pose error per turntable axis in deg), each at least its
    floor (floor (6,): the noise assumed per channel; pose_floor_deg: the
    pose error assumed), fitted jointly so that what the floors already
    explain is not counted again; and the affine fit (A_a, c_a, A_m, c_m)."""
    from .joint import _pose_jacobian

    acc, mag = ds.acc, ds.mag
    inc, azi, tf = (np.asarray(ds.columns[c], float) for c in ("inc_deg", "azi_deg", "tf_deg"))
    g, f = common.true_vectors(ds, dip, w["field_nT"], w["declination_deg"], w["gravity_g"])
    fitted = affine_fit(acc, mag, g, f)
    Aa, _, Am, _ = fitted
    R = forward_residuals(acc, mag, g, f, *fitted)
    n = len(R)
    # the residual's Jacobian in the 24 parameters (raw = A true + c): -true_j for A_ij, -1 for c_i
    X = np.zeros((n, 6, 24))
    for t, (off, v) in enumerate(((0, g), (3, f))):
        for i in range(3):
            X[:, off + i, 12 * t + 3 * i:12 * t + 3 * i + 3] = -v
            X[:, off + i, 12 * t + 9 + i] = -1.0
    Jp = _pose_jacobian(inc, azi, tf, w["field_nT"], dip, w["declination_deg"], w["gravity_g"])  # body, per deg
    B = covariance.block_diag2(Aa, Am)
    Jraw = -np.einsum("ij,njk->nik", B, Jp)
    comps = covariance.fit_components(R, labels, Jpose=Jraw, X=X, channels=covariance.CHANNELS_6, floor=floor,
                                      pose_floor_deg=pose_floor_deg)
    return comps, fitted


def _simulated(base: RawDataset, fwd, lab, k, inc, azi, tf, w, dip, sigma, sigma_cl, sigma_pose, rng):
    """One refit's dataset: the fitted forward model's readings at the
    indicated poses turned by a pose error drawn per cluster, plus a drift
    per cluster and channel and each row's noise; the pose columns as
    indicated."""
    Aa, ca, Am, cm = fwd
    e = rng.normal(0.0, 1.0, (k, 3)) * sigma_pose
    g, f = ref.body_vectors(inc + e[lab, 0], azi + e[lab, 1], tf + e[lab, 2], w["field_nT"], dip,
                            w["declination_deg"], w["gravity_g"])
    raw = np.concatenate([g @ Aa.T + ca, f @ Am.T + cm], axis=1)
    raw += (rng.normal(0.0, 1.0, (k, 6)) * sigma_cl)[lab]
    raw += rng.normal(0.0, 1.0, raw.shape) * sigma
    cols = {c: v.copy() for c, v in base.columns.items()}
    for j, c in enumerate(ACC_COLS + MAG_COLS):
        cols[c] = raw[:, j]
    return RawDataset(cols, dict(base.meta))


def bootstrap(ds: RawDataset, cal: Calibration, refit, rows, w: dict, dip: float, sigma_acc: float,
              sigma_mag: float, pose_floor_deg: float | None = None, n: int = DEFAULT_REFITS,
              seed: int = 12345) -> PaperUncertainty | None:
    """The coefficients' covariance of a paper method (refit: dataset ->
    Calibration) on the rows it used, by n refits of readings simulated
    from its fitted model (module docstring): sensor noise per channel at
    least sigma_acc / sigma_mag, the pose error and drift as the residuals
    show them (the pose error at least pose_floor_deg when given).  None
    when fewer than half the refits (and at least 2) succeed."""
    base = common.subset(ds, rows)
    lab, k = covariance._relabel(covariance.cluster_labels(base))
    assumed = np.array([sigma_acc] * 3 + [sigma_mag] * 3, float)
    try:
        comps, affine = residual_noise(base, w, dip, lab, floor=assumed, pose_floor_deg=pose_floor_deg)
    except (np.linalg.LinAlgError, ValueError):  # the affine fit or REML failed: no uncertainty, said so
        return None
    sigma = np.maximum(assumed, comps.sigma)
    sigma_cl = np.asarray(comps.sigma_cluster, float)
    sigma_pose = np.zeros(3) if comps.sigma_pose_deg is None else np.asarray(comps.sigma_pose_deg, float)
    if pose_floor_deg is not None:
        sigma_pose = np.maximum(float(pose_floor_deg), sigma_pose)
    noise_from = {t: ("the residuals" if np.any(comps.sigma[s] > 1.001 * assumed[s]) else "assumed")
                  for t, s in (("acc", slice(0, 3)), ("mag", slice(3, 6)))}
    inc, azi, tf = (np.asarray(base.columns[c], float) for c in ("inc_deg", "azi_deg", "tf_deg"))
    g, f = common.true_vectors(base, dip, w["field_nT"], w["declination_deg"], w["gravity_g"])
    fwd = _cal_forward(cal)
    rng = np.random.default_rng(seed)
    vs, deltas, fwds = [], [], []
    for _ in range(n):
        d = _simulated(base, fwd, lab, k, inc, azi, tf, w, dip, sigma, sigma_cl, sigma_pose, rng)
        try:
            c = refit(d)
            delta = forward_difference(d, c, g, f)
        except Exception:  # a simulated run the method cannot fit: counted below
            continue
        vs.append(common.cal_vector(c))
        deltas.append(delta)
        fwds.append(_forward_rows(c))
    if len(vs) < max(2, n // 2):  # a covariance needs two refits at least
        return None
    cov = np.cov(np.array(vs).T)
    out = PaperUncertainty(cov=cov, mse=cov.copy(), refits=len(vs), sigma=sigma, sigma_cluster=sigma_cl,
                           sigma_pose_deg=sigma_pose, noise_from=noise_from, comps=comps, clusters=k,
                           rows=len(base))
    if len(vs) >= MISFIT_MIN_REFITS:
        out.misfit = misfit(base, cal, affine, g, f, np.array(deltas), np.array(fwds), w, dip)
    else:
        out.notes.append(f"the method's model misfit not tested (fewer than {MISFIT_MIN_REFITS} refits)")
    if out.misfit is not None:
        d = np.asarray(out.misfit["coefficient_bias"], float)
        out.mse = cov + np.outer(d, d)
    return out


def misfit(base: RawDataset, cal: Calibration, affine, g, f, deltas, fwds, w, dip) -> dict | None:
    """What the method's model misses.  Its residual sum of squares less
    the affine least-squares fit's (`excess`) is tested, per triad, against
    what the noise alone gives: the same excess of each refit's coefficients
    about the refits' mean difference from their own affine fits (centred,
    so that a method that cannot reproduce even its own fitted model -- the
    refits' readings -- is judged by its spread, not its bias).  A triad
    misfits when its excess lies more than MISFIT_SD standard deviations
    beyond those refits' mean, and exceeds what the coefficients' own noise
    adds (the refits' forward coefficients about their mean, same metric):
    a bias of the method smaller than that (ren2014's accelerometer, a
    regression of the poses' gravity on the readings: 1e-4 of it) is within
    the stated sigma.  Returns None when neither triad misfits; else the
    coefficient bias (the method's correction coefficients less the affine
    fit's, the other triad's 0) and the attitude bias it leaves over the Li
    grid (predict.GRID), read with the affine fit's readings there."""
    from .predict import GRID

    V = np.stack([np.column_stack([v, np.ones(len(v))]) for v in (g, f)])
    obs = excess(forward_difference(base, cal, g, f), V)
    centred = deltas - deltas.mean(0)
    null = np.array([excess(dk, V) for dk in centred])
    mean, sd = null.mean(0), null.std(0, ddof=1)
    own = np.mean([excess(fk, V) for fk in fwds - fwds.mean(0)], axis=0)
    bad = [t for j, t in enumerate(("acc", "mag")) if obs[j] > max(mean[j] + MISFIT_SD * sd[j], own[j])]
    if not bad:
        return None
    Aa, ca, Am, cm = affine
    Ma, ba = common.forward_to_correction(Aa, ca)
    Mm, bm = common.forward_to_correction(Am, cm)
    va = np.concatenate([Ma.ravel(), ba, Mm.ravel(), bm])
    vp = common.cal_vector(cal)
    bias = np.zeros(24)
    mixed = va.copy()
    for t in bad:
        s = slice(0, 12) if t == "acc" else slice(12, 24)
        bias[s] = vp[s] - va[s]
        mixed[s] = vp[s]
    I, A, T = GRID
    gg, fg = ref.body_vectors(I, A, T, w["field_nT"], dip, 0.0, w["gravity_g"])
    m = common.cal_from_vector(mixed)
    att = ref.attitude(ref.correct(gg @ Aa.T + ca, m.acc_m, m.acc_b), ref.correct(fg @ Am.T + cm, m.mag_m, m.mag_b))
    azi_bias = ref.angle_diff(att["azi"], A)
    inc_bias = att["inc"] - I
    n_rows = len(base)
    return {"triads": bad,
            "of": "the method's residual sum of squares less the affine least-squares fit's (raw units); the same "
                  "of the refits' differences about their mean (what the noise gives: mean, sd); what the refits' "
                  "own coefficients' noise adds",
            "residual_excess": {t: float(obs[j]) for j, t in enumerate(("acc", "mag"))},
            "residual_excess_noise": {t: [float(mean[j]), float(sd[j])] for j, t in enumerate(("acc", "mag"))},
            "residual_excess_coefficient_noise": {t: float(own[j]) for j, t in enumerate(("acc", "mag"))},
            "excess_rms_per_axis": {t: float(np.sqrt(max(obs[j], 0.0) / (3 * n_rows)))
                                    for j, t in enumerate(("acc", "mag")) if t in bad},
            "coefficient_bias": bias.tolist(),
            "grid_azi_bias_deg": azi_bias.tolist(), "grid_inc_bias_deg": inc_bias.tolist(),
            "azi_rms_deg": float(np.sqrt(np.mean(azi_bias ** 2))),
            "inc_rms_deg": float(np.sqrt(np.mean(inc_bias ** 2)))}


_ASSUMED = {"given": "the given", "declared": "the declared", "nominal": "the nominal"}


def source_text(u: PaperUncertainty, an: dict) -> str:
    """The uncertainty-source line: what the refits drew and whence (an:
    common.assumed_noise's dict, the noise assumed)."""
    def triad(t, unit, s, k):
        vals = ", ".join(f"{v:.3g}" for v in u.sigma[s] * k)
        value = an["acc_g" if t == "acc" else "mag_nT"] * k
        assumed = f"{_ASSUMED.get(an[t + '_from'], an[t + '_from'])} {value:.3g} {unit}"
        whence = (f"above {assumed} on some axis: the residuals', REML of the affine least-squares fit"
                  if u.noise_from[t] == "the residuals" else f"{assumed}: the residuals show no more")
        return f"{t} {vals} {unit} ({whence})"
    txt = (f"bootstrap of {u.refits} refits of readings simulated from the fitted model at the run's {u.rows} rows "
           f"({u.clusters} pose settings): noise per reading {triad('acc', 'mg', slice(0, 3), 1e3)}, "
           f"{triad('mag', 'nT', slice(3, 6), 1.0)}; pose error "
           f"{', '.join(f'{v:.3g}' for v in u.sigma_pose_deg)} deg (inc, azi, tf; the residuals', REML) drawn per "
           f"pose setting, turning the readings of all its rows")
    if np.any(u.sigma_cluster > 0):
        txt += (f"; drift shared by a setting's rows {', '.join(f'{v:.3g}' for v in u.sigma_cluster[:3] * 1e3)} mg, "
                f"{', '.join(f'{v:.3g}' for v in u.sigma_cluster[3:])} nT")
    m = u.misfit
    if m:
        names = " and ".join({"acc": "accelerometer", "mag": "magnetometer"}[t] for t in m["triads"])
        txt += (f"; plus the method's model misfit ({names}: its residuals exceed the affine model's by "
                + ", ".join(f"{m['excess_rms_per_axis'][t] * (1e3 if t == 'acc' else 1):.3g} "
                            f"{'mg' if t == 'acc' else 'nT'} RMS per axis" for t in m["triads"])
                + f", far beyond the noise): its coefficients' difference from the affine least-squares fit is a "
                  f"bias, in sigma and the covariance (a mean square error, not a variance) and, over the Li grid "
                  f"({m['azi_rms_deg']:.3g} deg azimuth RMS), in the predictions")
    for note in u.notes:
        txt += f"; {note}"
    return txt
