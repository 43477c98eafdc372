"""The baseline plus any set of library effects at any size, as one
nonlinear forward model of the six readings, and its Jacobian.

The diagnosis fits effects from the noise floor up to large sizes (a
turntable offset of 2 deg, a sample skew of 50 ms at 90 deg/s: a 4.5 deg
pose error).  A regressor taken at zero effect (the change of the readings
per unit) is then not enough: the second-order part of a 2 deg rotation of
a 50 000 nT field is 30 nT, six times the fluxgate's noise, and it would be
read as a second effect.  So the model is re-linearised at the current
estimate (Gauss-Newton): every column, baseline and candidate, is the
derivative of `readings(state)` at the current state, and the pseudo-
observation y - readings(state) + X_eff theta makes the linear fit return
the effects' total values (not corrections), so the F-tests, the
cross-validation and the standard errors of core.Design apply unchanged.

The state is (A, c per triad, dip, theta); theta maps a candidate key
(core.Candidate.key) to its value in the candidate's units.  The models are
the emulator's (inclino.model.world.EncoderErrors, TurntableGeometry,
effects.FieldDrift, SamplingSkew, ScaleTempco, ScaleNonlinearity,
BiasTempco), in the emulator's order: the turntable's encoder errors then its
axis geometry; the fluxgate read at t + skew sees the pose the turntable
reaches then; per axis the triad's signal u = A true is scaled by the
temperature (1 + 1e-6 ppm dT), then bent (v + k2 v^2), then offset (c + c_T
dT), dT about the run's mean temperature."""
from __future__ import annotations

import numpy as np

from inclino.engines import reference as ref
from inclino.model.effects import rig_frame_to_body
from inclino.model.world import EncoderErrors, TurntableGeometry

from .names import AXES, RIG_AXES, TRIADS

RIG_HARMONICS = 2  # the rig field's harmonics of its axis angle: 0 (where not absorbed), 1, 2


def rig_terms(axis: str) -> list:
    """(h, 'cos'|'sin') of the rig field's full parameter vector, 3
    components (x, y, z of the axis' stator frame) each.  A constant field
    in the world frame (h = 0 on the azimuth axis) is the Earth field's
    business (its size the scale, its direction the dip and the azimuth
    offset), so that axis starts at h = 1."""
    h0 = 1 if axis == "azi" else 0
    out = []
    for h in range(h0, RIG_HARMONICS + 1):
        out.append((h, "cos"))
        if h > 0:
            out.append((h, "sin"))
    return out


def rig_key(axis: str) -> str:
    return f"rig-field:rig:{axis}"


def _true_angles(d, theta, pose_offset=(0.0, 0.0, 0.0)):
    off = [_val(theta, "turntable-inclination-offset:turntable:inc") + pose_offset[0],
           _val(theta, "turntable-azimuth-offset:turntable:azi") + pose_offset[1], pose_offset[2]]
    return EncoderErrors(off).true_pose(d.inc, d.azi, d.tf)


def rig_full(d, axis, theta=None, pose_offset=(0.0, 0.0, 0.0)) -> np.ndarray:
    """(n, 3, P): the body-frame field per unit (nT) of each entry of the
    axis' full rig-field parameter vector (rig_terms x 3 components)."""
    I, A, T = _true_angles(d, theta or {}, pose_offset)
    C = rig_frame_to_body(axis, I, A, T)  # (n, 3, 3)
    phi = np.radians({"azi": A, "inc": I, "tf": T}[axis])
    cols = []
    for h, kind in rig_terms(axis):
        trig = np.cos(h * phi) if kind == "cos" else np.sin(h * phi)
        for j in range(3):
            cols.append(C[:, :, j] * trig[:, None])
    return np.stack(cols, -1)


def rig_body(d, theta, pose_offset=(0.0, 0.0, 0.0)) -> np.ndarray | None:
    """(n, 3) nT: the rig fields of theta in the body frame (None without)."""
    basis = d.__dict__.get("rig_basis", {})
    out = None
    for axis in RIG_AXES:
        v = theta.get(rig_key(axis)) if theta else None
        if v is None or axis not in basis:
            continue
        f = rig_full(d, axis, theta, pose_offset) @ (basis[axis] @ np.asarray(v, float))
        out = f if out is None else out + f
    return out

STEP = {"deg": 1e-3, "g/degC": 1e-6, "nT/degC": 1e-2, "ppm/degC": 1.0, "1/g": 1e-4, "1/nT": 1e-9,
        "nT/s": 1e-3, "s": 1e-4}


def _val(theta, key):
    return float(theta.get(key, 0.0))


# pose matrices (n x 3 x 3 each) kept: a model's build asks for about 15 world states (the state, its
# pose-Jacobian and turntable-candidate perturbations), so two builds' worth; the cache used to grow to 65
# before it was cleared (190 MB on 40 000 rows)
POSE_CACHE_SIZE = 32


def truth(d, dip, theta, pose_offset=(0.0, 0.0, 0.0)):
    """(G, B): the true gravity and field in the body frame at every row,
    (n, 3) each, with the world effects of theta (and an extra encoder
    offset on inc, azi, tf: for the pose Jacobian)."""
    off = [_val(theta, "turntable-inclination-offset:turntable:inc") + pose_offset[0],
           _val(theta, "turntable-azimuth-offset:turntable:azi") + pose_offset[1], pose_offset[2]]
    geo = TurntableGeometry(_val(theta, "turntable-azimuth-axis-tilt:turntable:north"),
                            _val(theta, "turntable-azimuth-axis-tilt:turntable:east"),
                            _val(theta, "turntable-inclination-axis-skew:turntable:inc"))
    plain = geo.tilt_north_deg == 0 and geo.tilt_east_deg == 0 and geo.skew_deg == 0
    enc = EncoderErrors(off)
    cache = d.__dict__.setdefault("_forward_cache", {})  # the pose matrices of the last few world states

    def C_of(inc, azi, tf, skew=0.0):
        key = (tuple(off), geo.tilt_north_deg, geo.tilt_east_deg, geo.skew_deg, skew)
        C = cache.pop(key, None)
        if C is None:
            I, A, T = enc.true_pose(inc, azi, tf)
            C = ref.pose_matrix(I, A, T) if plain else geo.pose_matrix(I, A, T)
            while len(cache) >= POSE_CACHE_SIZE:  # the least recently used goes
                cache.pop(next(iter(cache)))
        cache[key] = C  # (re)inserted: the most recently used
        return C

    C = C_of(d.inc, d.azi, d.tf)
    G = C @ ref.gravity_ned(d.gravity_g)
    skew = _val(theta, "sample-skew:mag:xyz")
    if skew != 0.0:
        p = np.column_stack([d.inc, d.azi, d.tf]) + d.rates * skew
        Cm = C_of(p[:, 0], p[:, 1], p[:, 2], skew)
    else:
        Cm = C
    rates = [_val(theta, f"field-drift:field:{a}") for a in ("total", "dip", "declination")]
    if any(rates) and d.t is not None:
        tau = d.t - d.t.mean()
        F = d.field_nT + rates[0] * tau
        dp = np.radians(dip + rates[1] * tau)
        dc = np.radians(d.declination_deg + rates[2] * tau)
        ned = np.stack([F * np.cos(dp) * np.cos(dc), F * np.cos(dp) * np.sin(dc), F * np.sin(dp)], -1)
        B = (Cm @ ned[..., None])[..., 0]
    else:
        B = Cm @ ref.field_ned(d.field_nT, dip, d.declination_deg)
    rb = rig_body(d, theta, pose_offset)
    if rb is not None:
        B = B + rb
    return G, B


def _dT(d):
    return (d.temp - float(np.mean(d.temp))) if d.temp is not None else np.zeros(d.n)


def sensor_terms(d, theta, tri):
    """(ppm, k2, cT) vectors of the triad's sensor effects in theta."""
    out = []
    for name in ("temperature-scale", "scale-nonlinearity", "temperature-bias"):
        out.append(np.array([_val(theta, f"{name}:{tri}:{a}") for a in AXES]))
    return out


SCALE_T_REF_C = 25.0  # the temperature scale is per unit of the scale at 25 degC (the datasheets' reference)


def chain(d, theta, tri, u):
    """(reading without the offset c, d reading / d u) for the triad's
    signal u = A true (n, 3).  The scale's temperature term is about 25
    degC, so that A is the scale at 25 degC and ppm the emulator's (and the
    datasheets') parameter; about the run's mean temperature it would be
    ppm / (1 + ppm (T_mean - 25)), 0.8 % off at 2000 ppm/degC and a mean 4
    degC away.  The bias term is about the run's mean (its reference is
    absorbed by the offset c exactly)."""
    ppm, k2, cT = sensor_terms(d, theta, tri)
    dT = _dT(d)[:, None]
    dTs = ((d.temp - SCALE_T_REF_C) if d.temp is not None else np.zeros(d.n))[:, None]
    s = 1.0 + 1e-6 * ppm * dTs
    v = u * s
    return v + k2 * v * v + cT * dT, s * (1.0 + 2.0 * k2 * v)


def readings(d, A, c, dip, theta):
    """(n, 6): the predicted readings of the state."""
    G, B = truth(d, dip, theta)
    out = []
    for tri, v in zip(TRIADS, (G, B)):
        y, _ = chain(d, theta, tri, v @ A[tri].T)
        out.append(y + c[tri])
    return np.column_stack(out)


def _readings_from(d, A, c, G, B, theta):
    out = []
    for tri, v in zip(TRIADS, (G, B)):
        y, _ = chain(d, theta, tri, v @ A[tri].T)
        out.append(y + c[tri])
    return np.column_stack(out)


def column(d, A, c, dip, theta, cand) -> np.ndarray:
    """(n, 6): d readings / d theta[cand] at the state, central differences
    (exact for the effects that are linear in their parameter)."""
    h = STEP.get(cand.units, 1e-3)
    if cand.name == "field-drift" and cand.axis != "total" and d.t is not None:
        h = 1e-3 / max(float(np.abs(d.t - d.t.mean()).max()), 1e-9)
    k = cand.key
    ys = []
    for s in (h, -h):
        th = dict(theta)
        th[k] = th.get(k, 0.0) + s
        ys.append(readings(d, A, c, dip, th))
    return (ys[0] - ys[1]) / (2 * h)


def unabsorbed(d, A_mag, dip, Z) -> np.ndarray:
    """Z (n, 3, ...) : fluxgate reading changes (nT) with what the baseline's
    fluxgate part (a 3x3 on the true field, an offset, the dip) can absorb
    removed by least squares: the part of a rig field that shows in the
    readings as itself, the rest being taken into the probe's calibration."""
    _, B = truth(d, dip, {})
    h = 1e-3
    dipcol = (truth(d, dip + h, {})[1] - truth(d, dip - h, {})[1]) @ A_mag.T / (2 * h)
    X = np.zeros((d.n, 3, 13))
    for i in range(3):
        X[:, i, 4 * i:4 * i + 3] = B
        X[:, i, 4 * i + 3] = 1.0
    X[:, :, 12] = dipcol
    Xf = X.reshape(-1, 13)
    Zf = np.asarray(Z, float).reshape(d.n * 3, -1)
    coef = np.linalg.lstsq(Xf, Zf, rcond=None)[0]
    return (Zf - Xf @ coef).reshape(np.shape(Z))


def columns(d, A, c, dip, theta, cand) -> list:
    """The candidate's columns (n, 6) at the state: one for a one-parameter
    effect (`column`); for the rig field one per direction of its basis
    (d.rig_basis, set when the diagnosis screens it), exact (the field is
    linear in its parameters) through the fluxgate chain's slope."""
    if cand.name != "rig-field":
        return [column(d, A, c, dip, theta, cand)]
    V = d.rig_basis[cand.axis]
    G, B = truth(d, dip, theta)
    _, slope = chain(d, theta, "mag", B @ A["mag"].T)
    F = np.einsum("ij,njp->nip", A["mag"], rig_full(d, cand.axis, theta) @ V)  # (n, 3, r)
    out = []
    for k in range(V.shape[1]):
        col = np.zeros((d.n, 6))
        col[:, 3:] = slope * F[:, :, k]
        out.append(col)
    return out


def pose_jacobian(d, A, c, dip, theta, h=1e-3) -> np.ndarray:
    """(n, 6, 3): readings per degree of turntable readout error on inc, azi,
    tf at the state."""
    out = np.zeros((d.n, 6, 3))
    for k in range(3):
        ys = []
        for s in (h, -h):
            off = [0.0, 0.0, 0.0]
            off[k] = s
            G, B = truth(d, dip, theta, off)
            ys.append(_readings_from(d, A, c, G, B, theta))
        out[:, :, k] = (ys[0] - ys[1]) / (2 * h)
    return out


def baseline_columns(d, A, c, dip, theta, G, B) -> list:
    """The 25 baseline columns at the state: per channel d reading / d A_ij
    (the true vector through the chain's slope), d / d c_i, and the dip."""
    cols = []
    for ti, tri in enumerate(TRIADS):
        v = G if tri == "acc" else B
        _, slope = chain(d, theta, tri, v @ A[tri].T)
        for ax in range(3):
            ch = 3 * ti + ax
            for k in range(3):
                col = np.zeros((d.n, 6))
                col[:, ch] = v[:, k] * slope[:, ax]
                cols.append(col)
            col = np.zeros((d.n, 6))
            col[:, ch] = 1.0
            cols.append(col)
    h = 1e-3
    cols.append((readings(d, A, c, dip + h, theta) - readings(d, A, c, dip - h, theta)) / (2 * h))
    return cols
