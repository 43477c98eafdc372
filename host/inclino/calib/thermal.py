"""Temperature terms of the joint calibration (`inclino calibrate --method
joint --temperature-terms auto|on|off`, docs/calibration.md).

The model is the emulator's (inclino.model.effects: BiasTempco, ScaleTempco,
to_reference_temperature; one definition of each effect): per axis of each
triad, bias and scale are polynomials of order K <= 2 in dT = T - t_ref,

    bias(T)  = c1 dT + c2 dT^2                       (g or nT)
    scale(T) = 1e-6 (p1 dT + p2 dT^2)                (relative)
    raw_ref  = b + (raw - b - bias(T)) / (1 + scale(T))

and the reading brought to t_ref goes through the joint model (corrected =
M (raw_ref [+ q raw_ref^2 / S] - b), the scale nonlinearity q when the joint
fit used it).  With turntable poses, the temperature coefficients (12 K),
M, b, the dip (and q) are fitted together by generalised least squares with
joint's whitening (sensor noise through M, turntable readout through the pose
Jacobian), on the rows joint kept.  The order K (0, 1 or 2) is chosen by
5-fold cross-validation (held-out whitened chi^2 per row): the lowest order
whose score is within one standard error of the best.  The calibration
written (M, b) is the probe at t_ref (the best linear one over the working
range when q is fitted, as joint does); the terms go to CAL.json's
"temperature" block with their 1-sigma and covariance.  The firmware
applies them (applied_by_firmware: true; calibration image version 2,
inclino.formats.caltemp) when they fit the image's fixed-point ranges; the report
gives the azimuth and inclination error over the run's temperature range
with and without them, on the Li 2021 grid, for the fitted probe.

The terms are determined when the run spans at least MIN_SPAN_C, the
normal matrix is regular, and (for K = 2) the temperatures fall in at least
three clusters MIN_CLUSTER_SEP_C apart.  --temperature-terms on refuses otherwise
(CalibrationError, exit 3, with the reason); auto fits only then.
"""
from __future__ import annotations

import numpy as np
from scipy import optimize

from inclino.engines import reference as ref
from inclino.formats.dataset import RawDataset
from inclino.errors import CalibrationError, DataError

from inclino.formats import caltemp

from . import chunked_lm, common

MODES = ("auto", "on", "off")
NOT_FITTED = "temperature terms not fitted"  # how a note that they were not fitted begins (calibrate prints it)
MIN_SPAN_C = 10.0
# diagnose tests the temperature effects against a temp_c that changes by this much or more (diagnose_tests):
# one figure for diagnose (with poses and pose-free) and for calibrate's note that points to it
DIAGNOSE_MIN_SPAN_C = 1.0
MIN_CLUSTER_SEP_C = 5.0
MIN_CLUSTER_ROWS = 6
MAX_ORDER = 2
CV_FOLDS = 5
DEFAULT_T_REF_C = 25.0


def _effects():
    from inclino.model import effects as fx  # the one definition of the temperature effects

    return fx


# ---------------------------------------------------------------- the terms
def _theta_to_terms(theta, order: int) -> dict:
    t = np.asarray(theta, float).reshape(2, 2, order, 3) if order else np.zeros((2, 2, 0, 3))
    return {tri: {"bias": t[i, 0].tolist(), "scale_ppm": t[i, 1].tolist()} for i, tri in enumerate(("acc", "mag"))}


def tempcos(block: dict, tri: str):
    """(BiasTempco, ScaleTempco) of one triad from a CAL.json temperature block."""
    fx = _effects()
    t = block[tri]
    K = int(block["order"])
    b = np.zeros((2, 3))
    s = np.zeros((2, 3))
    b[:K] = np.asarray(t["bias"], float).reshape(K, 3)
    s[:K] = np.asarray(t["scale_ppm"], float).reshape(K, 3)
    tr = float(block["t_ref_c"])
    return fx.BiasTempco(b[0], tr, b[1]), fx.ScaleTempco(s[0], tr, s[1])


def to_reference(acc, mag, temp_c, cal, block: dict):
    """The readings brought to the block's t_ref with the calibration's
    biases as the scale terms' pivot (effects.to_reference_temperature)."""
    fx = _effects()
    out = []
    for tri, raw, b in (("acc", acc, cal.acc_b), ("mag", mag, cal.mag_b)):
        bt, st = tempcos(block, tri)
        out.append(fx.to_reference_temperature(raw, temp_c, b, bt, st))
    return out[0], out[1]


def corrected_dataset(ds: RawDataset, cal, block: dict) -> RawDataset:
    """ds with its sensor columns brought to t_ref (rows without temp_c
    unchanged); its other columns are ds's own arrays (shared, not copied)."""
    acc, mag = to_reference(ds.acc, ds.mag, ds.columns["temp_c"], cal, block)
    cols = dict(ds.columns)
    for k, c in enumerate(("ax_g", "ay_g", "az_g")):
        cols[c] = acc[:, k]
    for k, c in enumerate(("mx_nT", "my_nT", "mz_nT")):
        cols[c] = mag[:, k]
    return RawDataset(cols, dict(ds.meta))


# ---------------------------------------------------------------- the fit
class _Problem:
    """The whitened residuals of the joint model with temperature terms."""

    def __init__(self, ds, rows, w, nonlinear, dip0, fix_dip, Linv, t_ref):
        self.C = common.pose_matrices(ds)[rows]
        self.acc, self.mag = ds.acc[rows], ds.mag[rows]
        self.T = ds.columns["temp_c"][rows]
        self.dT = self.T - t_ref
        self.F, self.dec, self.G = w["field_nT"], w["declination_deg"], w["gravity_g"]
        self.g = self.C @ ref.gravity_ned(self.G)
        self.nonlinear, self.fix_dip, self.dip0 = nonlinear, fix_dip, dip0
        self.Linv = Linv[rows]
        self.nbase = 24 + (6 if nonlinear else 0) + (0 if fix_dip else 1)
        self.t_ref = t_ref

    def unpack(self, x, order):
        Ma, ca = x[0:9].reshape(3, 3), x[9:12]
        Mm, cm = x[12:21].reshape(3, 3), x[21:24]
        k = 24
        qa = qm = np.zeros(3)
        if self.nonlinear:
            qa, qm = x[24:27], x[27:30]
            k = 30
        dip = self.dip0 if self.fix_dip else x[k]
        th = np.asarray(x[self.nbase:], float).reshape(2, 2, order, 3)
        return Ma, ca, Mm, cm, qa, qm, dip, th

    def _ref(self, raw, T, b, th_tri, order):
        """raw (at temperatures T) brought to t_ref: effects.to_reference_temperature
        with the triad's (bias, scale) coefficients th_tri (2, order, 3)."""
        if order == 0:
            return raw
        fx = _effects()
        z = np.zeros(3)
        bt = fx.BiasTempco(th_tri[0, 0], self.t_ref, th_tri[0, 1] if order > 1 else z)
        st = fx.ScaleTempco(th_tri[1, 0], self.t_ref, th_tri[1, 1] if order > 1 else z)
        return fx.to_reference_temperature(raw, T, b, bt, st)

    def residuals(self, x, order, rows=None):
        """(n, 6) whitened residuals of `rows` (every row: None)."""
        s = slice(None) if rows is None else rows
        return np.einsum("nij,nj->ni", self.Linv[s], self.raw_residuals(x, order, rows))

    def raw_residuals(self, x, order, rows=None):
        """(n, 6): the model's residuals of `rows` (every row: None) in
        corrected units (g, nT), unwhitened; each row's from its own data."""
        s = slice(None) if rows is None else rows
        Ma, ca, Mm, cm, qa, qm, dip, th = self.unpack(x, order)
        ba = np.linalg.solve(Ma, ca)
        bm = np.linalg.solve(Mm, cm)
        T = self.T[s]
        ua = self._ref(self.acc[s], T, ba, th[0], order)
        um = self._ref(self.mag[s], T, bm, th[1], order)
        ua = ua + qa * ua * ua / self.G
        um = um + qm * um * um / self.F
        C = self.C[s]
        f = C @ ref.field_ned(self.F, dip, self.dec)
        return np.concatenate([ua @ Ma.T - ca - self.g[s], um @ Mm.T - cm - f], -1)

    def solve(self, x0, order, rows, loss="linear", factor_at_x=True):
        """The fit of `rows` from x0: least squares by chunked_lm (the
        Jacobian a chunk of rows at a time, never the whole 6n x P array;
        the result's R gives J^T J), or with a robust loss by least_squares
        (trf), whose trust-region steps LSMR solves on the Jacobian itself
        (the exact solver held a scaled copy of the 6n x P Jacobian and its
        SVD's U as well)."""
        if loss == "linear":
            return chunked_lm.solve(lambda x, c: self.residuals(x, order, rows[c]).ravel(),
                                    chunked_lm.row_chunks(len(rows), 6), x0, factor_at_x=factor_at_x)
        res = optimize.least_squares(lambda x: self.residuals(x, order, rows).ravel(), x0,
                                     jac=lambda x: chunked_lm.jacobian_2point(
                                         lambda xx: self.residuals(xx, order, rows).ravel(), x),
                                     method="trf", loss=loss, f_scale=3.0, x_scale="jac", tr_solver="lsmr")
        res.jac = None
        return res


def _levels(T: np.ndarray) -> int:
    """Distinct temperature levels MIN_CLUSTER_SEP_C apart (greedy from the
    coldest), each holding MIN_CLUSTER_ROWS readings: what an order-2 term needs
    three of (a continuous ramp counts as many)."""
    t = np.sort(T)
    start, lvl = 0, 0
    while start < len(t):
        end = int(np.searchsorted(t, t[start] + MIN_CLUSTER_SEP_C))
        if end - start >= MIN_CLUSTER_ROWS:
            lvl += 1
        start = max(end, start + 1)
    return lvl


def determined(T, max_order: int = MAX_ORDER) -> tuple[int, str]:
    """(highest order the temperatures can determine, the reason it is not
    higher)."""
    T = np.asarray(T, float)
    span = float(T.max() - T.min()) if T.size else 0.0
    if span < MIN_SPAN_C:
        return 0, (f"the run spans {span:.1f} degC ({T.min():.1f} to {T.max():.1f}); the temperature terms "
                   f"need at least {MIN_SPAN_C:g} degC")
    if max_order >= 2 and _levels(T) < 3:
        return 1, (f"fewer than three temperature levels {MIN_CLUSTER_SEP_C:g} degC apart with "
                   f">= {MIN_CLUSTER_ROWS} readings each: no second-order term")
    return max_order, ""


def _start(cal, info, w, nonlinear):
    nl = info.get("nonlinear")
    if nonlinear and nl is not None:
        Ma, ba = np.asarray(nl["model_acc_m"]), np.asarray(nl["model_acc_b"])
        Mm, bm = np.asarray(nl["model_mag_m"]), np.asarray(nl["model_mag_b"])
        q = np.concatenate([np.asarray(nl["acc_q_per_g"]) * w["gravity_g"], np.asarray(nl["mag_q_per_nT"]) * w["field_nT"]])
    else:
        Ma, ba = np.asarray(cal.acc_m), np.asarray(cal.acc_b)
        Mm, bm = np.asarray(cal.mag_m), np.asarray(cal.mag_b)
        q = np.zeros(0)
    return np.concatenate([Ma.ravel(), Ma @ ba, Mm.ravel(), Mm @ bm, q])


def _cv(prob: _Problem, x_full: dict, rows: np.ndarray, rng) -> dict:
    """Held-out whitened chi^2 per row for each order, CV_FOLDS folds of `rows`."""
    folds = np.array_split(rng.permutation(rows), CV_FOLDS)
    out = {}
    for order, x0 in x_full.items():
        scores = []
        for f in folds:
            train = np.setdiff1d(rows, f)
            res = prob.solve(x0, order, train, factor_at_x=False)  # its J^T J not used
            r = prob.residuals(res.x, order, f)
            scores.append((r ** 2).sum(-1))
        s = np.concatenate(scores)
        out[order] = {"cv_chi2_per_row": float(s.mean()), "se": float(s.std(ddof=1) / np.sqrt(len(s)))}
    return out


def _param_cov(JtJ, s2) -> tuple:
    """(covariance of every fitted parameter, the scaled condition number)
    from the whitened J^T J and the variance factor s2: inverted with the
    parameters scaled to unit diagonal (their units differ by decades);
    refused when a parameter has no effect or the fit is singular."""
    d = np.sqrt(np.diag(JtJ))
    if not np.all(np.isfinite(d)) or np.any(d == 0):
        raise CalibrationError("the poses at the run's temperatures do not separate the temperature terms "
                               "(a parameter has no effect on the readings)")
    N = JtJ / np.outer(d, d)
    cond = float(np.linalg.cond(N))
    if not np.isfinite(cond) or cond > 1e12:
        raise CalibrationError("the poses at the run's temperatures do not separate the temperature terms "
                               f"(singular fit, scaled condition number {cond:.3g})")
    return s2 * np.linalg.inv(N) / np.outer(d, d), cond


def _cov_24(x, prob: _Problem, order, JtJ, s2, w):
    """Covariance of the written (M, b) [and dip], and of the temperature
    coefficients, from the GLS covariance of x (JtJ: the whitened J^T J);
    with the scale nonlinearity
    also the best linear calibration and the covariance of (M, b, q[, dip])
    for the report's nonlinear block (None, None without it)."""
    from . import joint

    cov, cond = _param_cov(JtJ, s2)
    nb = prob.nbase
    dip_i = None if prob.fix_dip else nb - 1
    if prob.nonlinear:
        Ma, ca, Mm, cm, qa, qm, dip, _ = prob.unpack(x, order)
        x31 = np.concatenate([x[:30], [dip]])
        lin = joint.best_linear(x31, prob.F, prob.dec, prob.G)
        Jb = joint.best_linear_jacobian(x31, prob.F, prob.dec, prob.G)  # (24, 31)
        if prob.fix_dip:
            Jb = Jb[:, :30]
        T = np.zeros((24 + (0 if prob.fix_dip else 1), len(x)))
        T[:24, :Jb.shape[1]] = Jb
        if dip_i is not None:
            T[24, dip_i] = 1.0
        covc = T @ cov @ T.T
        Tn = np.eye(nb)  # (M, b, q[, dip]) for the report's nonlinear block: b = M^-1 c
        common.fill_bias_jacobian(x, Tn)
        cov_nl = Tn @ cov[:nb, :nb] @ Tn.T
    else:
        lin = cov_nl = None
        T = np.zeros((24 + (0 if prob.fix_dip else 1), len(x)))
        common.fill_bias_jacobian(x, T)
        if dip_i is not None:
            T[24, dip_i] = 1.0
        covc = T @ cov @ T.T
    return covc, cov[nb:, nb:], lin, cov_nl, cond


def _effective_linear(x, prob: _Problem, order, t):
    """The 24 coefficients (PARAM_NAMES order) of the linear calibration the
    fit amounts to at temperature t: corrected = M (raw_ref - b) with
    raw_ref = b + (raw - b - bias(t)) / (1 + scale(t)) per axis is
    M diag(1 / (1 + scale(t))) (raw - (b + bias(t))); M, b the written ones
    at t_ref (the best linear representation when q is fitted)."""
    from . import joint

    Ma, ca, Mm, cm, qa, qm, dip, th = prob.unpack(x, order)
    if prob.nonlinear:
        lin = joint.best_linear(np.concatenate([x[:30], [dip]]), prob.F, prob.dec, prob.G)
        Ma, ba, Mm, bm = lin[0:9].reshape(3, 3), lin[9:12], lin[12:21].reshape(3, 3), lin[21:24]
    else:
        ba, bm = np.linalg.solve(Ma, ca), np.linalg.solve(Mm, cm)
    dT = float(t) - prob.t_ref
    out = []
    for tri, (M, b) in enumerate(((Ma, ba), (Mm, bm))):
        bias = sum(th[tri, 0, k] * dT ** (k + 1) for k in range(order)) if order else np.zeros(3)
        scale = 1e-6 * sum(th[tri, 1, k] * dT ** (k + 1) for k in range(order)) if order else np.zeros(3)
        out += [np.ravel(M / (1.0 + scale)[None, :]), b + bias]
    return np.concatenate(out)


def _predicted_over_range(x, prob: _Problem, order, JtJ, s2, w, dip):
    """The calibration's own predicted azimuth and inclination RMS on the
    Li grid (as the report's "coefficients" term) at the run's lowest
    temperature, t_ref and its highest: the covariance of every fitted
    parameter, the temperature terms' included, carried to the linear
    calibration the fit amounts to at each temperature (central
    differences of _effective_linear at a hundredth of each parameter's
    sigma).  The report's own prediction is the one at t_ref; away from it
    the temperature terms' error adds (about 1.3x at the ends of a -5 to
    55 degC run of generated probes)."""
    from .sensitivity import predicted_attitude_rms

    cov, _ = _param_cov(JtJ, s2)
    h = 1e-2 * np.sqrt(np.clip(np.diag(cov), 0.0, None))
    h[h == 0] = 1e-9
    lo, hi = float(prob.T.min()), float(prob.T.max())
    rows = []
    for t in (lo, prob.t_ref, hi):
        G = np.zeros((24, len(x)))
        for i in range(len(x)):
            xp, xm = x.copy(), x.copy()
            xp[i] += h[i]
            xm[i] -= h[i]
            G[:, i] = (_effective_linear(xp, prob, order, t) - _effective_linear(xm, prob, order, t)) / (2 * h[i])
        cal_t = common.cal_from_vector(_effective_linear(x, prob, order, t))
        a, i_ = predicted_attitude_rms(cal_t, G @ cov @ G.T, w, dip)
        rows.append({"temp_c": round(float(t), 2), "azi_rms_deg": a, "inc_rms_deg": i_})
    return rows


def _probe_readings(x, prob: _Problem, order, poses, temps):
    """Noise-free raw readings of the fitted probe at `poses` and each of
    `temps`: the reference reading from the joint model, then the
    temperature effects forward (effects' chain order)."""
    from . import joint

    fx = _effects()
    Ma, ca, Mm, cm, qa, qm, dip, th = prob.unpack(x, order)
    x31 = np.concatenate([x[:24], qa, qm, [dip]])
    acc0, mag0 = joint.nonlinear_readings(x31, poses, prob.F, prob.dec, prob.G)
    out = []
    for t in temps:
        pair = []
        for raw0, M, c, tri in ((acc0, Ma, ca, 0), (mag0, Mm, cm, 1)):
            b = np.linalg.solve(M, c)
            c1 = th[tri, 0, 0] if order >= 1 else np.zeros(3)
            c2 = th[tri, 0, 1] if order >= 2 else np.zeros(3)
            p1 = th[tri, 1, 0] if order >= 1 else np.zeros(3)
            p2 = th[tri, 1, 1] if order >= 2 else np.zeros(3)
            bt = fx.BiasTempco(c1, prob.t_ref, c2)
            st = fx.ScaleTempco(p1, prob.t_ref, p2)
            pair.append(fx.from_reference_temperature(raw0, t, b, bt, st))
        out.append(pair)
    return out, dip


def _errors_over_range(cal, block, x, prob, order, w):
    """Azimuth (I >= 5, from magnetic north) and inclination RMS on the Li
    2021 grid at temperatures across the run's range, for the fitted probe:
    the calibration with its temperature terms and without (M, b only)."""
    from .runs import li2021_grid

    I, A, T = li2021_grid((0.0, 120.0, 240.0))
    lo, hi = float(prob.T.min()), float(prob.T.max())
    tr = float(block["t_ref_c"])
    temps = np.round(np.linspace(lo, hi, 5), 2)
    temps = np.sort(np.concatenate([temps[np.abs(temps - tr) >= 1.0], [tr]]))
    readings, dip = _probe_readings(x, prob, order, (I, A, T), temps)
    rows = []
    ok = (I >= 5.0) & (I <= 175.0)
    for t, (acc, mag) in zip(temps, readings):
        res = {"temp_c": float(t)}
        for name, (a_in, m_in) in (("with", to_reference(acc, mag, np.full(len(acc), t), cal, block)),
                                   ("without", (acc, mag))):
            att = ref.attitude(ref.correct(a_in, cal.acc_m, cal.acc_b), ref.correct(m_in, cal.mag_m, cal.mag_b))
            da = ref.angle_diff(att["azi"], A - prob.dec)[ok]  # the probe reads from magnetic north
            di = att["inc"] - I
            res[f"azi_rms_{name}_deg"] = float(np.sqrt(np.mean(da ** 2)))
            res[f"inc_rms_{name}_deg"] = float(np.sqrt(np.mean(di ** 2)))
        rows.append(res)
    return rows


def fit(ds: RawDataset, cal, info: dict, mode: str, sigma_acc: float, sigma_mag: float, sigma_pose_deg: float,
        fix_dip: bool = False, seed: int = 20261123):
    """The temperature terms on top of a joint fit (cal, info from
    joint.fit).  Returns (cal, info) updated, or unchanged (with a note)
    when the mode is off or auto finds them not determined.  auto also
    keeps joint's fit, with a note, when the temperature fit fails or keeps
    fewer readings than joint's own fit did (then the temperature is not
    what the model lacks: e.g. a turntable offset or a drift)."""
    if mode != "auto":
        return _fit(ds, cal, info, mode, sigma_acc, sigma_mag, sigma_pose_deg, fix_dip, seed)
    try:
        with np.errstate(all="ignore"):
            return _fit(ds, cal, info, mode, sigma_acc, sigma_mag, sigma_pose_deg, fix_dip, seed)
    except (CalibrationError, np.linalg.LinAlgError, ValueError) as e:
        if isinstance(e, DataError):
            raise
        info["notes"].append(f"temperature terms not fitted ({str(e).removeprefix('joint: ')})")
        return cal, info


def diagnose_tests(T) -> bool:
    """Whether inclino diagnose tests the temperature effects against the
    temperature column T: every value finite and a span of
    DIAGNOSE_MIN_SPAN_C or more.  The one test of diagnose (with the poses
    and pose-free) and of calibrate's note, so that calibrate never says
    diagnose tests a temp_c that diagnose calls not testable."""
    if T is None:
        return False
    T = np.asarray(T, float)
    return T.size > 0 and bool(np.all(np.isfinite(T))) and float(np.ptp(T)) >= DIAGNOSE_MIN_SPAN_C


def not_fitted_without_poses(ds) -> str | None:
    """The note of a run without the turntable's poses (or with one triad)
    whose temp_c changes: its temperature terms are not fitted (they need
    the poses and both triads), and the pose-free fit leaves what the
    temperature does in its residual; None without a temp_c that changes.
    It says diagnose tests the residual against temp_c only when diagnose
    does (diagnose_tests)."""
    T0 = ds.columns.get("temp_c")
    if T0 is None or len(T0) == 0:
        return None
    T = np.asarray(T0, float)
    T = T[np.isfinite(T)]
    if len(T) == 0 or not np.ptp(T) > 0.0:
        return None
    if diagnose_tests(T0):
        then = "inclino diagnose tests it against temp_c"
    else:
        then = (f"too small a change for inclino diagnose to test it against temp_c: that needs "
                f"{DIAGNOSE_MIN_SPAN_C:g} degC or more")
    return (f"temperature terms not fitted: temp_c spans {np.ptp(T):.3g} degC ({T.min():.3g} to {T.max():.3g}), "
            f"but the temperature fit needs the turntable's poses and both triads; the fit leaves what the "
            f"temperature does in its residual ({then})")


def _fit(ds, cal, info, mode, sigma_acc, sigma_mag, sigma_pose_deg, fix_dip, seed):
    from . import joint

    if mode not in MODES:
        raise DataError(f"--temperature-terms must be one of {', '.join(MODES)}")
    if mode == "off":
        return cal, info
    if "temp_c" not in ds.columns:
        if mode == "on":
            raise DataError("joint --temperature-terms on: the data have no temp_c column")
        return cal, info
    if info.get("mode") != "poses":
        if mode == "on":
            raise DataError("joint --temperature-terms on needs the turntable poses (inc_deg, azi_deg, tf_deg)")
        note = not_fitted_without_poses(ds)
        if note:
            info["notes"].append(note)
        return cal, info
    T_all = np.asarray(ds.columns["temp_c"], float)
    if not np.all(np.isfinite(T_all)):
        raise DataError("temp_c holds non-finite values")
    from inclino.checks import not_a_temperature

    bad = not_a_temperature(ds)  # a pose angle or a sensor axis: no temperature terms from it
    if bad is not None:
        why = f"temp_c does not look like a temperature: {bad[0]}"
        if mode == "on":
            raise CalibrationError(f"joint --temperature-terms on: {why}")
        info["notes"].append(f"{NOT_FITTED} ({why})")
        return cal, info
    # every row: joint's outlier rejection saw the temperature effects as outliers
    rows = np.arange(len(ds))
    max_order, why = determined(T_all[rows])
    if max_order == 0:
        if mode == "on":
            raise CalibrationError(f"joint --temperature-terms on: the temperature terms are not determined: {why}")
        info["notes"].append(f"temperature terms not fitted ({why})")
        return cal, info
    w = common.world_of(ds)
    lo, hi = float(T_all[rows].min()), float(T_all[rows].max())
    t_ref = DEFAULT_T_REF_C if lo <= DEFAULT_T_REF_C <= hi else float(np.round(np.median(T_all[rows]), 1))
    nonlinear = "nonlinear" in info
    dip0 = float(info["dip_deg"])
    poses = tuple(ds.columns[c] for c in ("inc_deg", "azi_deg", "tf_deg"))
    Jp = joint._pose_jacobian(*poses, w["field_nT"], dip0, w["declination_deg"], w["gravity_g"])
    x_base = _start(cal, info, w, nonlinear)
    Ma0, Mm0 = x_base[0:9].reshape(3, 3), x_base[12:21].reshape(3, 3)
    Linv = joint._whiteners(Ma0, Mm0, Jp, sigma_acc, sigma_mag, sigma_pose_deg)
    prob = _Problem(ds, rows, w, nonlinear, dip0, fix_dip, Linv, t_ref)
    x0 = np.concatenate([x_base, [] if fix_dip else [dip0]])
    allrows = np.arange(len(rows))
    # robust pass with the highest order: soft-L1 loss, then the rows whose
    # whitened squared residual passes joint's outlier point (the chi-square
    # 99.9 % point scaled by the median residual, triad.robust_threshold) are
    # kept, for every order.  The whitening is the nominal noise: against the
    # bare chi-square point a fluxgate 3x noisier than the nominal 5 nT lost
    # 15-20 % of its rows as outliers and the verdict failed on them
    th = np.zeros(12 * max_order)
    r0 = prob.solve(np.concatenate([x0, th]), max_order, allrows, loss="soft_l1")
    d2 = (prob.residuals(r0.x, max_order) ** 2).sum(-1)
    keep = np.flatnonzero(d2 <= joint.robust_threshold(d2, 6)[0])
    if len(keep) < joint.MIN_ROWS_POSES:
        raise CalibrationError("joint: too many readings rejected as outliers to fit the temperature terms")
    if mode == "auto" and len(keep) < len(info["rows_used"]):
        raise CalibrationError(f"with them {len(ds) - len(keep)} readings are outliers, without them "
                               f"{len(ds) - len(info['rows_used'])}: the temperature is not what the model lacks")
    sols = {}
    x_full = {}
    for order in range(0, max_order + 1):
        th = np.zeros((2, 2, order, 3))  # layout (triad, effect, power, axis)
        if order >= 1:  # from the lower order's solution
            prev = x_full[order - 1]
            th[:, :, :order - 1] = prev[prob.nbase:].reshape(2, 2, order - 1, 3)
            base = prev[:prob.nbase]
        else:
            base = x0
        res = prob.solve(np.concatenate([base, th.ravel()]), order, keep)
        sols[order] = res
        x_full[order] = res.x
    cv = _cv(prob, x_full, keep, np.random.default_rng(seed))
    best = min(cv, key=lambda k: cv[k]["cv_chi2_per_row"])
    chosen = min(k for k in cv if cv[k]["cv_chi2_per_row"] <= cv[best]["cv_chi2_per_row"] + cv[best]["se"])
    if chosen == 0:
        if mode == "on":
            chosen = 1  # asked for: the first order, with its covariance (cross-validation did not prefer it)
        else:
            info["notes"].append("temperature terms not fitted: cross-validation prefers none "
                                 + ", ".join(f"order {k}: {v['cv_chi2_per_row']:.3f}" for k, v in cv.items())
                                 + " (held-out chi^2 per row)")
            info["temperature_cv"] = cv
            return cal, info
    res = sols[chosen]
    sols.clear()
    x = res.x
    JtJ = res.jtj  # of the whitened 6n x P Jacobian at x (chunked_lm: the Jacobian itself is not held)
    dof = max(1, 6 * len(keep) - len(x))
    s2 = 2.0 * res.cost / dof
    noise = _noise_components(prob, x, chosen, keep, ds, rows, w)
    s2_cov = s2
    if not isinstance(noise, str):
        # the nominal whitening's shape (its pose error, the triads' relative noise) is not the run's:
        # s^2 scales it as a whole and left the terms' 1-sigma about 1.3x small over drawn probes;
        # refit whitened by the run's own noise (joint's way) and take the covariance from that fit
        try:
            res = _refit_fitted_noise(prob, x, chosen, keep, noise, ds, rows, w)
            x, JtJ, s2_cov = res.x, res.jtj, 1.0
            # the outlier test again under the run's own noise (joint's way): the nominal whitening's
            # shape (5 nT against a noisier fluxgate) makes the rows' squared norms heavier-tailed than
            # chi-square, and the rows in that tail were dropped as outliers
            keep2 = _kept_under_fitted_noise(prob, x, chosen, noise, ds, rows, w)
            if len(keep2) >= joint.MIN_ROWS_POSES and not np.array_equal(keep2, keep):
                keep = keep2
                noise2 = _noise_components(prob, x, chosen, keep, ds, rows, w)
                if not isinstance(noise2, str):
                    noise = noise2
                res = _refit_fitted_noise(prob, x, chosen, keep, noise, ds, rows, w)
                x, JtJ = res.x, res.jtj
                dof = max(1, 6 * len(keep) - len(x))
            s2 = float((prob.residuals(x, chosen, keep) ** 2).sum()) / dof
        except (np.linalg.LinAlgError, ValueError) as e:
            info["notes"].append(f"the temperature fit was not refitted with the run's own noise ({e}); its "
                                 "covariance is the nominal noise's scaled by s^2")
    try:
        cov_c, cov_th, lin, cov_nl, cond = _cov_24(x, prob, chosen, JtJ, s2_cov, w)
    except CalibrationError as e:
        if mode == "on":
            raise CalibrationError(f"joint --temperature-terms on: {e}")
        info["notes"].append(f"temperature terms not fitted ({e})")
        return cal, info
    Ma, ca, Mm, cm, qa, qm, dip, th = prob.unpack(x, chosen)
    if lin is not None:
        # the nonlinear model the report's linear-model bias is computed from:
        # this fit's, not joint's without the terms (whose q took up part of
        # the temperature effects)
        info = dict(info)
        info["nonlinear"] = joint.nonlinear_block(np.concatenate([x[:30], [dip]]), cov_nl, lin, w["field_nT"],
                                                  float(dip), w["declination_deg"], w["gravity_g"])
        new = common.make_cal(lin[0:9].reshape(3, 3), lin[9:12], lin[12:21].reshape(3, 3), lin[21:24], "joint", ds)
    else:
        new = common.make_cal(Ma, np.linalg.solve(Ma, ca), Mm, np.linalg.solve(Mm, cm), "joint", ds)
    sig = np.sqrt(np.clip(np.diag(cov_th), 0.0, None)).reshape(2, 2, chosen, 3)
    block = {
        "model": ("raw_ref = b + (raw - b - bias(T)) / (1 + scale(T)), bias = sum_k bias[k] dT^(k+1), "
                  "scale = 1e-6 sum_k scale_ppm[k] dT^(k+1), dT = T - t_ref_c; then corrected = M (raw_ref - b) "
                  "(inclino.model.effects.to_reference_temperature)"),
        "t_ref_c": t_ref, "order": int(chosen), "span_c": [lo, hi],
        **_theta_to_terms(th.ravel(), chosen),
        "sigma": _theta_to_terms(sig.ravel(), chosen),
        "covariance": cov_th.tolist(),
        "units": {"acc": "bias g/degC^k, scale ppm/degC^k", "mag": "bias nT/degC^k, scale ppm/degC^k"},
        "cross_validation": {str(k): v for k, v in cv.items()},
        "applied_by_firmware": False,
    }
    block.update(caltemp.firmware_block(block))  # True when the image (version 2) carries them
    block["error_over_range"] = _errors_over_range(new, block, x, prob, chosen, w)
    block["predicted_over_range"] = _predicted_over_range(x, prob, chosen, JtJ, s2_cov, w, float(dip))
    new.temperature = block
    info = dict(info)
    info["dip_deg"] = float(dip)
    info["covariance"] = cov_c[:24, :24]
    info["s2"], info["dof"], info["chi2"] = s2, dof, s2 * dof
    info["normal_matrix_cond"] = cond
    info["rows_used"] = keep
    info["outliers"] = np.setdiff1d(np.arange(len(ds)), keep).tolist()
    info["notes"] = [f"mode {info['mode']}; s^2 = {s2:.3g} (chi^2/dof with the temperature terms; 1 when the noise "
                     "model is right)" if n.startswith("mode ") else n for n in info["notes"]
                     if not n.startswith("the residuals are ")]  # joint's, about the fit without the terms
    if s2 > 2.0 and s2 > 1.0 + 5.0 * np.sqrt(2.0 / max(dof, 1)):
        info["notes"].append(f"the residuals are {np.sqrt(s2):.2g}x what the noise model expects, with the "
                             "temperature terms: an effect the model still lacks or noisier sensors; the "
                             "covariance is scaled by s^2; `inclino diagnose --cal` names the effect")
    if not fix_dip:
        info["dip_sigma_deg"] = float(np.sqrt(cov_c[24, 24]))
    worst = max(block["error_over_range"], key=lambda r: r["azi_rms_without_deg"])
    info["notes"] = list(info["notes"]) + [
        f"temperature terms fitted, order {chosen} about {t_ref:g} degC over {lo:.1f} to {hi:.1f} degC "
        f"(cross-validation, held-out chi^2 per row: "
        + ", ".join(f"order {k} {v['cv_chi2_per_row']:.3f}" for k, v in cv.items())
        + f"); the residuals are of the readings brought to {t_ref:g} degC; at {worst['temp_c']:g} degC the "
        f"azimuth RMS is {worst['azi_rms_with_deg']:.4f} deg with them, {worst['azi_rms_without_deg']:.4f} without "
        + ("(Li grid); the firmware applies them (calibration image version 2)" if block["applied_by_firmware"]
           else "(Li grid); the firmware applies M, b only: "
           + block["firmware"]["why_not"])]
    info["report_dataset"] = corrected_dataset(ds, new, block)
    # the reading noise the report's acceptance prediction takes: joint's components were fitted to
    # residuals that still held the temperature effects (tens of times the sensors' noise on a chamber
    # run); these are the residuals with the terms
    info.pop("noise", None)
    info.pop("noise_components", None)
    if isinstance(noise, str):
        info["notes"].append(f"the run's own noise was not fitted with the temperature terms ({noise}); the "
                             "acceptance prediction takes the nominal noise scaled by s^2")
    else:
        info["noise_components"] = noise
    return new, info


def _at_the_rows(prob: _Problem, x, order, keep, ds, rows, w):
    """(Ma, Mm, the residuals' pose Jacobian (n, 6, 3) at x, cluster labels)
    of the rows kept: what the run's noise components are fitted with and
    what their whitener is built from."""
    from . import covariance, joint

    Ma, ca, Mm, cm, qa, qm, dip, th = prob.unpack(x, order)
    poses = tuple(ds.columns[c][rows][keep] for c in ("inc_deg", "azi_deg", "tf_deg"))
    Jp = joint._pose_jacobian(*poses, w["field_nT"], float(dip), w["declination_deg"], w["gravity_g"])
    return Ma, Mm, Jp, covariance.cluster_labels(ds)[rows][keep]


def _kept_under_fitted_noise(prob: _Problem, x, order, comps, ds, rows, w):
    """The rows (indices into `rows`) kept by joint's outlier test under the
    fitted noise components: each row's whitened squared norm (sensor noise,
    cluster effect, pose error through its own pose Jacobian) within
    robust_threshold's point for 6 degrees of freedom."""
    from . import covariance, joint

    allrows = np.arange(len(rows))
    Ma, Mm, Jp, labels = _at_the_rows(prob, x, order, allrows, ds, rows, w)
    W = covariance.component_whitener(comps, Ma, Mm, Jp, labels)
    d2 = W.row_d2(prob.raw_residuals(x, order, allrows))
    return np.flatnonzero(d2 <= joint.robust_threshold(d2, 6)[0])


def _refit_fitted_noise(prob: _Problem, x, order, keep, comps, ds, rows, w):
    """The fit whitened by the run's noise components (calib/covariance.py;
    joint._refit_with_components for the model without temperature terms):
    per-channel noise, the cluster effect and the pose error per turntable
    axis, in corrected units.  Returns chunked_lm's result (x, R), its
    chunks whole clusters (the whitening couples a cluster's rows)."""
    from . import covariance

    Ma, Mm, Jp, labels = _at_the_rows(prob, x, order, keep, ds, rows, w)
    W = covariance.component_whitener(comps, Ma, Mm, Jp, labels)
    del Jp

    def fun(xx, c):
        return W.apply_rows(prob.raw_residuals(xx, order, keep[c]), c)

    return chunked_lm.solve(fun, chunked_lm.row_chunks(len(keep), 6, W.starts()), x)


def _noise_components(prob: _Problem, x, order, keep, ds, rows, w):
    """The run's noise per channel and its pose error (REML, calib/covariance.py,
    as joint fits them) from the residuals of the fit with the temperature
    terms, in raw units, with that fit's Jacobian in raw units for the
    restricted likelihood: its cluster means (k x 6 x P), summed a chunk of
    rows at a time (the n x 6 x P Jacobian is never held); the
    reason as a string when it cannot be fitted."""
    from . import covariance

    try:
        Ma, Mm, Jp, labels = _at_the_rows(prob, x, order, keep, ds, rows, w)
        Bi = np.linalg.inv(covariance.block_diag2(Ma, Mm))
        r = prob.raw_residuals(x, order, keep) @ Bi.T  # raw units
        lab, k = covariance._relabel(labels)
        n_c = np.bincount(lab, minlength=k).astype(float)
        Xc = np.zeros((k, 6, len(x)))
        for c in chunked_lm.row_chunks(len(keep), 6):
            Jc = chunked_lm.jacobian_2point(lambda xx: prob.raw_residuals(xx, order, keep[c]).ravel(), x, "C")
            np.add.at(Xc, lab[c], np.einsum("ij,njk->nik", Bi, Jc.reshape(-1, 6, len(x))))
        Xc /= n_c[:, None, None]
        return covariance.fit_components(r, labels, Jpose=np.einsum("ij,njk->nik", Bi, Jp),
                                         X_means=Xc, channels=covariance.CHANNELS_6)
    except (np.linalg.LinAlgError, ValueError) as e:
        return str(e) or type(e).__name__


def summary(block: dict) -> str:
    """Text lines for `inclino calibrate`'s output."""
    lines = [f"  temperature terms: order {block['order']} about {block['t_ref_c']:g} degC, run "
             f"{block['span_c'][0]:.1f} to {block['span_c'][1]:.1f} degC ("
             + ("applied by the firmware: image version 2)" if block.get("applied_by_firmware")
                else "not applied by the firmware)")]
    for tri, ub, in (("acc", 1e6), ("mag", 1.0)):
        unit = "ug" if tri == "acc" else "nT"
        for k in range(block["order"]):
            b = np.asarray(block[tri]["bias"][k]) * ub
            sb = np.asarray(block["sigma"][tri]["bias"][k]) * ub
            s = np.asarray(block[tri]["scale_ppm"][k])
            ss = np.asarray(block["sigma"][tri]["scale_ppm"][k])
            pw = "" if k == 0 else "^2"
            lines.append(f"    {tri} bias {', '.join(f'{v:.3g}+-{e:.2g}' for v, e in zip(b, sb))} {unit}/degC{pw}; "
                         f"scale {', '.join(f'{v:.3g}+-{e:.2g}' for v, e in zip(s, ss))} ppm/degC{pw}")
    if block.get("predicted_over_range"):
        lines.append("    predicted error of the calibration (its coefficients and temperature terms, Li grid): " + "; ".join(
            f"{r['temp_c']:g} degC azimuth RMS {r['azi_rms_deg']:.4f}, inclination {r['inc_rms_deg']:.4f} deg"
            for r in block["predicted_over_range"]))
    lines.append("    Li grid, fitted probe: " + "; ".join(
        f"{r['temp_c']:g} degC azimuth RMS {r['azi_rms_with_deg']:.4f} with / {r['azi_rms_without_deg']:.4f} "
        f"without, inclination {r['inc_rms_with_deg']:.4f} / {r['inc_rms_without_deg']:.4f} deg"
        for r in block["error_over_range"]))
    return "\n".join(lines)
