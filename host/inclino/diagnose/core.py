"""Model discrepancy: what the per-triad 12-parameter model leaves in a raw
turntable dataset, which library effect explains it, and what it gains.

Model.  Each row gives six readings y = [acc (g), mag (nT)] at an indicated
turntable pose.  The baseline is the papers' per-triad 12-parameter model
referenced to the poses (Li 2021 eq. 3/4, Ren 2014 eq. 8/11):

    acc = A_a g(pose) + c_a,    mag = A_m f(pose, dip) + c_m

g, f the true body-frame gravity and field at the indicated pose
(inclino.engines.reference), the dip fitted, the field total and declination from
the header.  It is started from calib.joint (our calibration fit, with
poses) and refined here together with the effects.  Every candidate effect
of the library (inclino.model.effects, the models the emulator simulates) adds
columns to this linear model: the change of the six readings per unit of the
effect's parameter, computed by applying the library's own model to the
baseline's signal (BiasTempco, ScaleTempco, ScaleNonlinearity, the
turntable's EncoderErrors and TurntableGeometry, FieldDrift, SamplingSkew).  The baseline's
coefficients are always re-estimated with the effects, so an effect is only
what the 12 parameters cannot absorb.

Noise.  Estimated from the residuals, never assumed: each row's 6x6
covariance is diag(sigma_c^2) (white sensor noise per channel) plus
J diag(sigma_pose^2) J^T (the turntable's readout error on inclination,
azimuth and toolface through the pose Jacobian J: correlated between all six
channels and different at every pose).  The nine variances are fitted to the
residual products by non-negative least squares (method of moments) and the
rows are whitened with the result (generalised least squares).

Selection.  Forward stepwise over the testable candidates: the candidate
with the smallest F-test p-value against the current model is kept when
(a) p < alpha / m, m the number of candidates still in play (Bonferroni:
the chance of naming any effect on data that have none is at most alpha,
0.01 by default), and (b) it lowers the K-fold cross-validated residual
(held-out rows, folds of interleaved time blocks).  The noise is
re-estimated after every kept effect; a final backward pass drops any kept
effect whose p-value rose above alpha once the others were in.
"""
from __future__ import annotations

from dataclasses import dataclass, field

import numpy as np
from scipy import stats

from inclino.engines import reference as ref
from inclino.formats.dataset import POSE_COLS, RawDataset
from inclino.holds import declared_static
from inclino.errors import CalibrationError, DataError
from inclino.model import effects as fx
from inclino.calib.thermal import DIAGNOSE_MIN_SPAN_C, diagnose_tests
from inclino.model.world import EncoderErrors, TurntableGeometry

from . import serial, tails
from .names import AXES, CHANNELS, EFFECT_NAMES, RIG_AXES, TRIAD_UNITS, TRIADS  # noqa: F401
from .noise import Noise, _ml_variances, fit_noise  # noqa: F401

MIN_ROWS = 16
MIN_ORIENTATIONS = 6
DEFAULT_ALPHA = 0.01
DEFAULT_FOLDS = 5
MOVING_MIN_RATE_DEG_S = 1.0  # slower than this is a static pose for the skew
MOVING_MAX_STEP_DEG = 30.0  # consecutive rows further apart are separate poses
MOVE_DEADBAND_DEG = 0.5  # smaller pose changes are the turntable's readout jitter, not moves
SEPARABLE_MIN = 1e-3  # fraction of a regressor left once the baseline is projected out
RIG_SEPARABLE_MIN = 1e-3  # a rig-field direction kept when this fraction of it is not absorbed by the baseline
RIG_MIN_SPAN_DEG = 30.0
POSE_STEP_DEG = 1e-3
JOINT_START_ROWS = 240


# --------------------------------------------------------------------------
# candidates
@dataclass(frozen=True)
class Candidate:
    name: str
    sensor: str  # acc | mag | turntable | field
    axis: str  # x y z | inc azi | total dip declination | xyz
    units: str

    @property
    def key(self) -> str:
        return f"{self.name}:{self.sensor}:{self.axis}"

    @property
    def triad(self) -> str:
        """The triad whose residual RMS the gain is given in."""
        if self.sensor in TRIADS:
            return self.sensor
        return "acc" if self.name in ("turntable-inclination-offset", "turntable-azimuth-axis-tilt") else "mag"

    @property
    def channels(self) -> list:
        """Channels (indices into CHANNELS) the gain's RMS is taken over."""
        off = 0 if self.triad == "acc" else 3
        if self.sensor in TRIADS and self.axis in AXES:
            return [off + AXES.index(self.axis)]
        return [off, off + 1, off + 2]


def all_candidates() -> list:
    out = []
    for tri in TRIADS:
        u = TRIAD_UNITS[tri]
        for ax in AXES:
            out.append(Candidate("temperature-bias", tri, ax, f"{u}/degC"))
    for tri in TRIADS:
        for ax in AXES:
            out.append(Candidate("temperature-scale", tri, ax, "ppm/degC"))
    for tri in TRIADS:
        for ax in AXES:
            out.append(Candidate("scale-nonlinearity", tri, ax, f"1/{TRIAD_UNITS[tri]}"))
    out.append(Candidate("turntable-inclination-offset", "turntable", "inc", "deg"))
    out.append(Candidate("turntable-azimuth-offset", "turntable", "azi", "deg"))
    out.append(Candidate("field-drift", "field", "total", "nT/s"))
    out.append(Candidate("field-drift", "field", "dip", "deg/s"))
    out.append(Candidate("field-drift", "field", "declination", "deg/s"))
    out.append(Candidate("sample-skew", "mag", "xyz", "s"))
    out.append(Candidate("turntable-azimuth-axis-tilt", "turntable", "north", "deg"))
    out.append(Candidate("turntable-azimuth-axis-tilt", "turntable", "east", "deg"))
    out.append(Candidate("turntable-inclination-axis-skew", "turntable", "inc", "deg"))
    for ax in RIG_AXES:  # a field that moves with a turntable axis (effects.RigField): several columns
        out.append(Candidate("rig-field", "rig", ax, "nT"))
    return out


# --------------------------------------------------------------------------
# the data
@dataclass
class Data:
    n: int
    Y: np.ndarray  # (n, 6) acc g, mag nT
    inc: np.ndarray
    azi: np.ndarray
    tf: np.ndarray
    t: np.ndarray | None  # s, time order
    temp: np.ndarray | None  # degC
    field_nT: float
    dip_header: float | None
    declination_deg: float
    gravity_g: float
    order: np.ndarray  # file row of each (time-ordered) row
    rates: np.ndarray  # (n, 3) deg/s of inc, azi, tf while moving, else 0
    moving: np.ndarray  # (n,) bool
    last_move: np.ndarray  # (n, 3) sign of the last move of each turntable axis
    orientations: int
    kind: str  # static | continuous
    meta: dict = field(default_factory=dict)


def _wrapdiff(a, b):
    return ref.angle_diff(a, b)


def prepare(ds: RawDataset) -> Data:
    if not ds.has_pose:
        missing = [c for c in POSE_COLS if c not in ds.columns]
        raise DataError("diagnose needs the turntable's pose for every reading; missing column(s): "
                        + ", ".join(missing))
    n = len(ds)
    t = ds.columns.get("t_s")
    order = np.argsort(t, kind="stable") if t is not None else np.arange(n)
    col = {k: np.asarray(v, float)[order] for k, v in ds.columns.items()}
    inc, azi, tf = col["inc_deg"], col["azi_deg"], col["tf_deg"]
    C = ref.pose_matrix(inc, azi, tf)
    orient = len(np.unique(np.round(C.reshape(n, 9), 2), axis=0))
    if n < MIN_ROWS or orient < MIN_ORIENTATIONS:
        raise DataError(f"too few poses to fit: diagnose needs at least {MIN_ROWS} readings at "
                        f"{MIN_ORIENTATIONS} or more distinct orientations; the data have {n} reading(s) "
                        f"at {orient} orientation(s)")
    Y = np.column_stack([ds.acc[order], ds.mag[order]])
    m = ds.meta
    F = m.get("field_nT")
    if F is None:
        # the radius of the sphere the raw readings lie on, as calibrate takes it: not the median |b|, which
        # holds the hard-iron offset too
        from inclino.calib.common import world_of

        F = world_of(ds)["field_nT"]
    t = col.get("t_s")
    temp = col.get("temp_c")
    rates = np.zeros((n, 3))
    moving = np.zeros(n, bool)
    last = np.zeros((n, 3))
    d = np.column_stack([np.diff(inc), _wrapdiff(azi[1:], azi[:-1]), _wrapdiff(tf[1:], tf[:-1])])
    # direction of the last move of each axis, carried forward
    cur = np.zeros(3)
    for i in range(1, n):
        s = np.sign(np.where(np.abs(d[i - 1]) > MOVE_DEADBAND_DEG, d[i - 1], 0.0))
        cur = np.where(s != 0, s, cur)
        last[i] = cur
    if t is not None and n > 1:
        dt = np.diff(t)
        with np.errstate(divide="ignore", invalid="ignore"):
            r = np.where(dt[:, None] > 0, d / dt[:, None], 0.0)
        pair = (dt > 0) & (np.abs(d).max(1) <= MOVING_MAX_STEP_DEG) & (np.abs(r).max(1) >= MOVING_MIN_RATE_DEG_S)
        cnt = np.zeros(n)
        for sl in (slice(0, n - 1), slice(1, n)):  # each pair counts for both of its rows
            rates[sl] += np.where(pair[:, None], r, 0.0)
            cnt[sl] += pair
        moving = cnt > 0
        rates[moving] /= cnt[moving, None]
        # an axis that is not turning shows only the readout jitter of the
        # poses (0.05 deg / 0.1 s is 0.5 deg/s): below 1 deg/s, or below a
        # tenth of the fastest axis of that row, its rate is taken as 0
        fastest = np.abs(rates).max(1, keepdims=True)
        rates[np.abs(rates) < np.maximum(MOVING_MIN_RATE_DEG_S, 0.1 * fastest)] = 0.0
    if declared_static(ds):  # declared step-and-hold (# static=true, --static): never turning
        moving[:] = False
        rates[:] = 0.0
    kind = "continuous" if moving.mean() >= 0.5 else "static"
    return Data(n=n, Y=Y, inc=inc, azi=azi, tf=tf, t=t, temp=temp, field_nT=float(F),
                dip_header=m.get("dip_deg"), declination_deg=float(m.get("declination_deg", 0.0)),
                gravity_g=float(m.get("gravity_g", 1.0)), order=order, rates=rates, moving=moving,
                last_move=last, orientations=orient, kind=kind, meta=dict(m))


# --------------------------------------------------------------------------
# baseline and regressors
@dataclass
class Baseline:
    A: dict  # triad -> (3, 3)
    c: dict  # triad -> (3,)
    dip: float
    G: np.ndarray  # (n, 3) true gravity at the poses, g
    B: np.ndarray  # (n, 3) true field, nT
    Jpose: np.ndarray  # (n, 6, 3) readings per degree of inc, azi, tf
    theta: dict = field(default_factory=dict)  # effects in the state (forward.py), key -> value
    data: "Data | None" = None  # needed with theta
    outliers: "np.ndarray | None" = None  # (n,) bool, rows set aside as outliers (robust.py)

    def predict(self) -> np.ndarray:
        if self.theta:
            from . import forward

            return forward.readings(self.data, self.A, self.c, self.dip, self.theta)
        return np.column_stack([self.G @ self.A["acc"].T + self.c["acc"], self.B @ self.A["mag"].T + self.c["mag"]])

    def signal(self, triad) -> np.ndarray:
        """The triad's signal after scale, before bias (A @ true)."""
        return (self.G if triad == "acc" else self.B) @ self.A[triad].T


def _truth(d: Data, inc, azi, tf, dip, field_params=None):
    if field_params is None:
        return ref.body_vectors(inc, azi, tf, d.field_nT, dip, d.declination_deg, d.gravity_g)
    F, dp, dc = field_params
    C = ref.pose_matrix(inc, azi, tf)
    f = np.stack([np.broadcast_to(v, np.shape(inc)) for v in (F, dp, dc)], -1)
    dpr, dcr = np.radians(f[..., 1]), np.radians(f[..., 2])
    ned = np.stack([f[..., 0] * np.cos(dpr) * np.cos(dcr), f[..., 0] * np.cos(dpr) * np.sin(dcr),
                    f[..., 0] * np.sin(dpr)], -1)
    g = C @ ref.gravity_ned(d.gravity_g)
    return g, (C @ ned[..., None])[..., 0]


def _map(A, v):
    return v @ A.T


def pose_jacobian(d: Data, A_a, A_m, dip) -> np.ndarray:
    """Readings per degree of turntable encoder offset on inc, azi, tf:
    (n, 6, 3), through the emulator's EncoderErrors (true = offset +
    indicated), central differences."""
    out = np.zeros((d.n, 6, 3))
    for k in range(3):
        vs = []
        for s in (1.0, -1.0):
            off = np.zeros(3)
            off[k] = s * POSE_STEP_DEG
            I, A, T = EncoderErrors(off).true_pose(d.inc, d.azi, d.tf)
            vs.append(_truth(d, I, A, T, dip))
        out[:, 0:3, k] = _map(A_a, (vs[0][0] - vs[1][0]) / (2 * POSE_STEP_DEG))
        out[:, 3:6, k] = _map(A_m, (vs[0][1] - vs[1][1]) / (2 * POSE_STEP_DEG))
    return out


def dip_column(d: Data, A_m, dip) -> np.ndarray:
    h = 1e-3
    _, b1 = _truth(d, d.inc, d.azi, d.tf, dip + h)
    _, b0 = _truth(d, d.inc, d.azi, d.tf, dip - h)
    col = np.zeros((d.n, 6))
    col[:, 3:] = _map(A_m, (b1 - b0) / (2 * h))
    return col


def baseline_columns(d: Data, bl: Baseline) -> tuple[list, list]:
    """The 25 baseline columns (n, 6) each: per channel the triad's true
    vector (3) and a constant; the dip."""
    cols, names = [], []
    for ti, tri in enumerate(TRIADS):
        v = bl.G if tri == "acc" else bl.B
        for ax in range(3):
            ch = 3 * ti + ax
            for k in range(3):
                c = np.zeros((d.n, 6))
                c[:, ch] = v[:, k]
                cols.append(c)
                names.append(f"{tri} {'xyz'[ax]} gain on the true {'xyz'[k]}")
            c = np.zeros((d.n, 6))
            c[:, ch] = 1.0
            cols.append(c)
            names.append(f"{tri} {'xyz'[ax]} offset")
    cols.append(dip_column(d, bl.A["mag"], bl.dip))
    names.append("dip")
    return cols, names


def _tau(d: Data):
    """Time about the run's mean: the drift candidates are trends, the mean
    value being the baseline's (F: the scale, dip: the fitted dip) or the
    azimuth-offset candidate's (declination: a declination that differs
    from the header's on average is the same rotation as the turntable's
    north reference being off)."""
    return d.t - d.t.mean()


def regressor(d: Data, bl: Baseline, cand: Candidate) -> np.ndarray:
    """(n, 6): the change of the readings per unit of the candidate's
    parameter (in cand.units), from the library's model."""
    n = d.n
    out = np.zeros((n, 6))
    if cand.sensor in TRIADS and cand.axis in AXES:
        tri, i = cand.sensor, AXES.index(cand.axis)
        off = 0 if tri == "acc" else 3
        e = np.zeros(3)
        e[i] = 1.0
        x = bl.signal(tri)
        tm = float(np.mean(d.temp)) if d.temp is not None else 25.0
        if cand.name == "temperature-bias":
            r = fx.BiasTempco(e, t_ref_c=tm).apply(np.zeros((n, 3)), d.temp)
        elif cand.name == "temperature-scale":
            r = fx.ScaleTempco(e, t_ref_c=tm).apply(x, d.temp) - x
        elif cand.name == "scale-nonlinearity":
            r = fx.ScaleNonlinearity(e).apply(x) - x
        else:
            raise KeyError(cand.key)
        out[:, off:off + 3] = r
        return out
    if cand.name == "turntable-inclination-offset":
        return bl.Jpose[:, :, 0].copy()
    if cand.name == "turntable-azimuth-offset":
        return bl.Jpose[:, :, 1].copy()
    if cand.name == "field-drift":
        tau = _tau(d)
        span = max(float(np.abs(tau).max()), 1e-9)
        if cand.axis == "total":
            unit = 1.0  # exact: F is linear in the rate
            drifts = [fx.FieldDrift(rate_nT_per_s=unit), fx.FieldDrift(rate_nT_per_s=-unit)]
        else:
            unit = 1e-3 / span  # 1e-3 deg over the run
            kw = "dip_rate_deg_per_s" if cand.axis == "dip" else "declination_rate_deg_per_s"
            drifts = [fx.FieldDrift(**{kw: unit}), fx.FieldDrift(**{kw: -unit})]
        bs = [_truth(d, d.inc, d.azi, d.tf, bl.dip,
                     dr.apply(d.field_nT, bl.dip, d.declination_deg, tau))[1] for dr in drifts]
        out[:, 3:] = _map(bl.A["mag"], (bs[0] - bs[1]) / (2 * unit))
        return out
    if cand.name in ("turntable-azimuth-axis-tilt", "turntable-inclination-axis-skew"):
        kw = {"north": "tilt_north_deg", "east": "tilt_east_deg", "inc": "skew_deg"}[cand.axis]
        vs = []
        for sgn in (1.0, -1.0):
            C = TurntableGeometry(**{kw: sgn * POSE_STEP_DEG}).pose_matrix(d.inc, d.azi, d.tf)
            vs.append((C @ ref.gravity_ned(d.gravity_g),
                       (C @ ref.field_ned(d.field_nT, bl.dip, d.declination_deg)[:, None])[..., 0]))
        out[:, :3] = _map(bl.A["acc"], (vs[0][0] - vs[1][0]) / (2 * POSE_STEP_DEG))
        out[:, 3:] = _map(bl.A["mag"], (vs[0][1] - vs[1][1]) / (2 * POSE_STEP_DEG))
        return out
    if cand.name == "sample-skew":
        h = 1e-4
        bs = []
        for s in (h, -h):
            tm = fx.SamplingSkew(s).apply(d.t)
            dt = (tm - d.t)[:, None]
            p = np.column_stack([d.inc, d.azi, d.tf]) + d.rates * dt  # the pose at the fluxgate's instant
            bs.append(_truth(d, p[:, 0], p[:, 1], p[:, 2], bl.dip)[1])
        out[:, 3:] = _map(bl.A["mag"], (bs[0] - bs[1]) / (2 * h))
        return out
    raise KeyError(cand.key)


def untestable_reason(d: Data, cand: Candidate) -> str | None:
    if cand.name.startswith("temperature-"):
        if d.temp is None:
            return "the data have no temperature column (temp_c)"
        if not diagnose_tests(d.temp):
            return (f"the temperature never changes ({np.nanmin(d.temp):.1f} to {np.nanmax(d.temp):.1f} degC; "
                    f"needs a range of at least {DIAGNOSE_MIN_SPAN_C:g} degC)")
    if cand.name in ("field-drift", "sample-skew"):
        if d.t is None:
            return "the data have no time column (t_s)"
        if float(d.t.max() - d.t.min()) <= 0:
            return "every reading has the same time stamp"
    if cand.name == "rig-field":
        phi = {"azi": d.azi, "inc": d.inc, "tf": d.tf}[cand.axis]
        span = float(np.ptp(np.unwrap(np.radians(phi))) if cand.axis != "inc" else np.radians(np.ptp(phi)))
        if np.degrees(span) < RIG_MIN_SPAN_DEG:
            return (f"the turntable's {cand.axis} axis hardly turns in the data ({np.degrees(span):.1f} deg; a field "
                    f"that moves with it needs {RIG_MIN_SPAN_DEG:g} deg or more)")
    if cand.name == "sample-skew" and d.moving.sum() < 10:
        return ("no continuous rotation in the data (a skew shows only while the probe turns: "
                f"consecutive readings <= {MOVING_MAX_STEP_DEG:g} deg apart at >= {MOVING_MIN_RATE_DEG_S:g} deg/s)")
    return None


# --------------------------------------------------------------------------
# noise model
class Design:
    """Whitened stacked model y = X beta + e, kept as Gram matrices of the
    whole data and of each cross-validation fold."""

    ROW_CHUNK = 2048  # rows whitened at a time when the Gram matrices are built

    def __init__(self, y, X, Linv, folds, K, rows=None):
        """rows: (n,) bool, the rows the fit uses (outliers excluded: their
        whitened equations are zero); default all.

        The whitened design (n x 6 x p, ~90 columns on a chamber run: the
        largest array of a diagnosis) is not kept: the Gram matrices are
        summed a chunk of rows at a time, the columns scaled to unit norm
        afterwards; `whitened(S)` (and `Xw`) compute it again from the raw
        design and the whiteners where a row-level figure needs it."""
        n, _, p = X.shape
        self.Xraw, self.yraw = X, y
        if rows is not None and not np.all(rows):
            Linv = Linv * np.asarray(rows, float)[:, None, None]
        self.rows = np.ones(n, bool) if rows is None else np.asarray(rows, bool)
        self.Linv = Linv
        yw = np.einsum("nij,nj->ni", Linv, y)
        self.yw = yw
        self.N = X.shape[1] * int(self.rows.sum())
        # serially correlated rows (a log read while the probe moves): how much a smooth regressor's
        # apparent gain is inflated, (1 + rho) / (1 - rho) for a lag-1 correlation rho; 1 for independent rows
        self.inflation = 1.0
        # per test, the Bartlett inflation of serially correlated rows (diagnose.serial), where the caller
        # asks for it (the posed diagnosis)
        self.serial = False
        # heavy-tailed noise (diagnose.tails): where the caller asks for it (the posed diagnosis) and the
        # residual's kurtosis test passes its gate, a test's p-value is also the sandwich test's
        self.tails = False
        self._records = {}  # (function, S[, extra]) -> its record, computed once per design
        self.K = K
        self.folds = folds
        self.Gf = np.zeros((K, p, p))
        self.bf = np.zeros((K, p))
        self.yyf = np.zeros(K)
        for f in range(K):
            idx = np.flatnonzero(folds == f)
            for lo in range(0, len(idx), self.ROW_CHUNK):
                ix = idx[lo:lo + self.ROW_CHUNK]
                A = np.einsum("nij,njp->nip", Linv[ix], X[ix]).reshape(-1, p)
                yy = yw[ix].ravel()
                self.Gf[f] += A.T @ A
                self.bf[f] += A.T @ yy
                self.yyf[f] += yy @ yy
        s = np.sqrt(np.maximum(np.diagonal(self.Gf.sum(0)).copy(), 0.0))
        s[s == 0] = 1.0
        self.colscale = s
        self.Gf /= np.outer(s, s)[None]
        self.bf /= s[None]
        self.G = self.Gf.sum(0)
        self.b = self.bf.sum(0)
        self.yy = self.yyf.sum()

    def whitened(self, S=None, rows=None) -> np.ndarray:
        """The whitened design, columns scaled to unit norm: (n, 6, len(S))
        for the columns S (default all), of the rows `rows` (default all)."""
        X, L = self.Xraw, self.Linv
        if rows is not None:
            X, L = X[rows], L[rows]
        if S is None:
            return np.einsum("nij,njp->nip", L, X) / self.colscale
        S = np.asarray(S)
        return np.einsum("nij,njp->nip", L, X[:, :, S]) / self.colscale[S]

    @property
    def Xw(self) -> np.ndarray:
        """The whole whitened, scaled design (computed on each use)."""
        return self.whitened()

    @staticmethod
    def _solve(G, b):
        try:
            L = np.linalg.cholesky(G)
            return np.linalg.solve(L.T, np.linalg.solve(L, b))
        except np.linalg.LinAlgError:
            return np.linalg.lstsq(G, b, rcond=None)[0]

    def fit(self, S):
        S = np.asarray(S)
        beta = self._solve(self.G[np.ix_(S, S)], self.b[S])
        rss = float(self.yy - beta @ self.b[S])
        return beta, max(rss, 0.0)

    def cv(self, S) -> float:
        S = np.asarray(S)
        tot = 0.0
        for f in range(self.K):
            G = self.G[np.ix_(S, S)] - self.Gf[f][np.ix_(S, S)]
            beta = self._solve(G, self.b[S] - self.bf[f][S])
            Gf = self.Gf[f][np.ix_(S, S)]
            tot += self.yyf[f] - 2 * beta @ self.bf[f][S] + beta @ Gf @ beta
        return float(tot) / self.N

    def ftest(self, S, extra):
        """p-value of adding the columns `extra` to S."""
        _, r0 = self.fit(S)
        _, r1 = self.fit(list(S) + list(extra))
        q = len(extra)
        dof = self.N - len(S) - q
        if r1 <= 0 or dof <= 0:
            return 0.0, np.inf
        infl = max(self.inflation, self.serial_factor(S, extra))
        F = ((r0 - r1) / q) / (r1 / dof) / infl
        p = float(stats.f.sf(F, q, dof / infl))
        if self.tails and self.tail_gate(S)["gated"]:
            p = max(p, self.tail_test(S, extra)["p"])
        return p, float(F)

    def _record(self, fn, *cols) -> dict:
        """fn(self, *cols) for these column lists, computed once per design."""
        key = (fn,) + tuple(tuple(int(i) for i in c) for c in cols)
        if key not in self._records:
            self._records[key] = fn(self, *cols)
        return self._records[key]

    def tail_gate(self, S) -> dict:
        """tails.gate's record of the residual of the model S."""
        return self._record(tails.gate, S)

    def tail_test(self, S, extra) -> dict:
        """tails.sandwich's record of the test of `extra` against S."""
        return self._record(tails.sandwich, S, extra)

    def serial_record(self, S, extra) -> dict:
        """serial.factor's record of the test of `extra` against S."""
        return self._record(serial.factor, S, extra)

    def serial_factor(self, S, extra) -> float:
        """The serial-correlation inflation of the test of `extra` against S,
        1 unless `serial` is set."""
        return self.serial_record(S, extra)["f"] if self.serial else 1.0

    def coef(self, S):
        """Estimates and standard errors of the columns S (unscaled)."""
        S = np.asarray(S)
        beta, rss = self.fit(S)
        s2 = rss / max(self.N - len(S), 1)
        cov = s2 * np.linalg.pinv(self.G[np.ix_(S, S)])
        return beta / self.colscale[S], np.sqrt(np.diag(cov)) / self.colscale[S], s2

    def raw_residuals(self, S, train=None) -> np.ndarray:
        """Residuals (n, 6) in raw units for the model S, fitted on all rows
        or on the training rows of fold `train` (held out)."""
        S = np.asarray(S)
        if train is None:
            beta, _ = self.fit(S)
        else:
            beta = self._solve(self.G[np.ix_(S, S)] - self.Gf[train][np.ix_(S, S)],
                               self.b[S] - self.bf[train][S])
        return self.yraw - np.einsum("nip,p->ni", self.Xraw[:, :, S], beta / self.colscale[S])

    def leverage(self, S) -> np.ndarray:
        """Each whitened value's leverage (n, 6) under the model S: the
        diagonal of the hat matrix, Xw G^-1 Xw^T per row and channel (what
        the fit leans on that value; its residual's variance is s2 (1 - h))."""
        Xs = self.whitened(S)
        return np.einsum("nip,pq,niq->ni", Xs, np.linalg.pinv(self.G[np.ix_(S, S)]), Xs)

    def heldout_factor(self, S) -> np.ndarray:
        """(n, m): the variance of each whitened value's held-out residual
        (its fold left out of the fit) over the noise's, 1 + x^T G_-f^-1 x
        with G_-f the Gram matrix without the value's fold: the diagonal of
        (I - H_ff)^-1 (Woodbury), what the fold's own values lean on one
        another included (1 / (1 - h) only when a fold is one value)."""
        S = np.asarray(S)
        out = np.zeros(self.Xraw.shape[:2])
        for f in range(self.K):
            m = self.folds == f
            Gi = np.linalg.pinv(self.G[np.ix_(S, S)] - self.Gf[f][np.ix_(S, S)])
            Xs = self.whitened(S, m)
            out[m] = 1.0 + np.einsum("nip,pq,niq->ni", Xs, Gi, Xs)
        return out

    def cv_residuals(self, S) -> np.ndarray:
        R = np.zeros_like(self.yraw)
        for f in range(self.K):
            m = self.folds == f
            R[m] = self.raw_residuals(S, train=f)[m]
        return R

    def separability(self, base, k) -> float:
        """Fraction of column k's (whitened) norm outside the span of `base`."""
        base = np.asarray(base)
        Gbb = self.G[np.ix_(base, base)]
        gbk = self.G[base, k]
        proj = gbk @ self._solve(Gbb, gbk)
        return float(np.sqrt(max(self.G[k, k] - proj, 0.0) / self.G[k, k]))

    def coef_cov(self, S) -> np.ndarray:
        """Covariance of the (unscaled) estimates of the columns S."""
        S = np.asarray(S)
        _, rss = self.fit(S)
        s2 = rss / max(self.N - len(S), 1)
        C = s2 * np.linalg.pinv(self.G[np.ix_(S, S)])
        return C / np.outer(self.colscale[S], self.colscale[S])

    def canon_corr(self, base, a, b) -> float:
        """The largest canonical correlation between the spans of the columns
        a and b (lists) once the columns `base` are projected out (whitened):
        for one column each, the absolute partial correlation; for a group,
        how well the best combination of one matches the other."""
        base, a, b = np.asarray(base), list(a), list(b)
        Gbb = self.G[np.ix_(base, base)]

        def res(x, y):
            return self.G[np.ix_(x, y)] - self.G[np.ix_(base, x)].T @ self._solve(Gbb, self.G[np.ix_(base, y)])
        Raa, Rbb, Rab = res(a, a), res(b, b), res(a, b)

        def inv_sqrt(M):
            w, V = np.linalg.eigh((M + M.T) / 2)
            keep = w > 1e-12 * max(w.max(), 1e-300)
            return (V[:, keep] / np.sqrt(w[keep])) @ V[:, keep].T
        K = inv_sqrt(Raa) @ Rab @ inv_sqrt(Rbb)
        sv = np.linalg.svd(K, compute_uv=False)
        return float(min(sv.max(), 1.0)) if len(sv) else 0.0

    def signal_corr(self, base, a, w, b) -> float:
        """How much of one signal -- the columns a combined with the
        (unscaled) coefficients w, e.g. an effect's fitted signature -- the
        columns b can reproduce once `base` is projected out: the multiple
        correlation of that signal with the span of b (whitened)."""
        base, a, b = np.asarray(base), list(a), list(b)
        ws = np.asarray(w, float) * self.colscale[a]
        Gbb = self.G[np.ix_(base, base)]

        def res(x, y):
            return self.G[np.ix_(x, y)] - self.G[np.ix_(base, x)].T @ self._solve(Gbb, self.G[np.ix_(base, y)])
        Raa, Rbb, Rab = res(a, a), res(b, b), res(a, b)
        vv = float(ws @ Raa @ ws)
        if vv <= 0:
            return 0.0
        g = Rab.T @ ws
        return float(np.sqrt(min(max(g @ np.linalg.pinv(Rbb) @ g / vv, 0.0), 1.0)))

    def partial_corr(self, base, j, k) -> float:
        base = np.asarray(base)
        Gbb = self.G[np.ix_(base, base)]
        def res(a, b):
            return self.G[a, b] - self.G[base, a] @ self._solve(Gbb, self.G[base, b])
        den = np.sqrt(max(res(j, j), 1e-300) * max(res(k, k), 1e-300))
        return float(res(j, k) / den)


def make_folds(n: int, K: int) -> np.ndarray:
    """Fold of each (time-ordered) row: interleaved blocks of consecutive
    rows, so that every fold spans the whole run and repeated readings at a
    pose stay together."""
    nb = min(n, 10 * K)
    block = (np.arange(n) * nb) // n
    return block % K


# --------------------------------------------------------------------------
# the fit
def fit_baseline(d: Data, iterations: int = 3) -> tuple[Baseline, Noise]:
    """Start from calib.joint (with poses), then re-fit the 25 baseline
    parameters by generalised least squares under the noise estimated from
    the residuals."""
    from inclino.calib import joint

    # the start needs no more than a couple of hundred rows spread over the run
    rows = np.arange(d.n) if d.n <= JOINT_START_ROWS else np.linspace(0, d.n - 1, JOINT_START_ROWS).astype(int)
    ds = RawDataset({"inc_deg": d.inc[rows], "azi_deg": d.azi[rows], "tf_deg": d.tf[rows],
                     "ax_g": d.Y[rows, 0], "ay_g": d.Y[rows, 1], "az_g": d.Y[rows, 2],
                     "mx_nT": d.Y[rows, 3], "my_nT": d.Y[rows, 4], "mz_nT": d.Y[rows, 5]},
                    {k: v for k, v in d.meta.items()})
    ds.meta["field_nT"] = d.field_nT
    try:
        with np.errstate(all="ignore"):
            cal, info = joint.fit(ds, use_poses=True)
    except joint.SingularFit as e:
        raise DataError(f"poses cannot separate the baseline's 12 parameters per triad: {e}")
    except CalibrationError as e:
        raise DataError(f"the baseline fit failed on these poses ({e})")
    except (np.linalg.LinAlgError, ValueError) as e:
        raise DataError(f"the baseline fit failed on these poses ({e})")
    A = {"acc": np.linalg.inv(np.asarray(cal.acc_m)), "mag": np.linalg.inv(np.asarray(cal.mag_m))}
    c = {"acc": np.asarray(cal.acc_b, float), "mag": np.asarray(cal.mag_b, float)}
    dip = float(info["dip_deg"])
    from . import robust

    noise, out = None, np.zeros(d.n, bool)
    for it in range(iterations):
        G, Bv = _truth(d, d.inc, d.azi, d.tf, dip)
        J = pose_jacobian(d, A["acc"], A["mag"], dip)
        bl = Baseline(A, c, dip, G, Bv, J)
        R = d.Y - bl.predict()
        cols, names = baseline_columns(d, bl)
        X = np.stack(cols, -1)
        if noise is None:
            noise, out = robust.robust_noise(R, J, dof_frac=1.0 - 4.5 / d.n, ml=False)
        folds = np.zeros(d.n, int)
        des = Design(R, X, noise.whitener(J), folds, 1, rows=~out)
        rank = np.linalg.matrix_rank(des.G, tol=1e-9 * np.abs(des.G).max())
        if rank < X.shape[-1]:
            w, V = np.linalg.eigh(des.G)
            v = np.abs(V[:, 0])
            worst = [names[i] for i in np.argsort(v)[::-1] if v[i] >= 0.3 * v.max()][:3]
            raise DataError("poses cannot separate the baseline's 12 parameters per triad: the gravity or "
                            f"field directions do not span three dimensions ({' / '.join(worst)} "
                            f"{'is' if len(worst) == 1 else 'are'} undetermined)")
        beta, _ = des.fit(np.arange(X.shape[-1]))
        beta = beta / des.colscale
        for ti, tri in enumerate(TRIADS):
            blk = beta[12 * ti: 12 * ti + 12].reshape(3, 4)
            A[tri] = A[tri] + blk[:, :3]
            c[tri] = c[tri] + blk[:, 3]
        dip = dip + float(beta[24])
        G, Bv = _truth(d, d.inc, d.azi, d.tf, dip)
        J = pose_jacobian(d, A["acc"], A["mag"], dip)
        bl = Baseline(A, c, dip, G, Bv, J)
        noise, out = robust.robust_noise(d.Y - bl.predict(), J, dof_frac=1.0 - 4.5 / d.n, start=noise,
                                         ml=it == iterations - 1)
    bl.outliers = out
    return bl, noise
