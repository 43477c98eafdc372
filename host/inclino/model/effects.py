"""The one library of sensor-error effects.

Both the emulator (to make readings) and the model-discrepancy ("diagnose")
tool (to fit readings) import these classes, so an effect has exactly one
definition.  Every effect is a plain dataclass holding its parameters (units
in the field comments) with an ``apply`` method working on NumPy arrays of
shape (..., 3) (one row per sample, columns = sensor x, y, z) and a docstring
giving its equation.  Each can be used alone; `TriadModel` chains them in the
documented order.

Units: a triad works in its *nominal* unit -- g for the accelerometer, nT
for the fluxgate.  Temperatures in degrees C, times in seconds.

Order of the chain (TriadModel.apply), v = true body-frame vector::

    v1 = SoftIron.S @ v + HardIron.h              (fluxgate only; body frame)
    v2 = Misalignment.M @ v1                       (sensor axes)
    v3 = diag(Scale.k) diag(1 + ScaleTempco(T)) @ v2
    v4 = v3 + ScaleNonlinearity.k2 * v3**2
    v5 = v4 + Bias.b + BiasTempco(T)

ScaleTempco(T) and BiasTempco(T) are per-axis polynomials of order <= 2 in
T - T_ref (temp_poly).
    v6 = v5 + WhiteNoise                           (seeded Generator)
    v7 = Saturation(v6)                            (analog range)
    out = Quantisation(v7)                         (optional; the register
                                                    models quantise themselves)

SamplingSkew, FieldDrift and RigField act on time and on the world, not on
a sensor's vector; they live here so that the same parameters are fitted and
simulated.
"""
from __future__ import annotations

from dataclasses import dataclass, field
from typing import Optional

import numpy as np


def _vec3(x, name="value"):
    a = np.asarray(x, dtype=float)
    if a.shape == ():
        a = np.full(3, float(a))
    if a.shape != (3,):
        raise ValueError(f"{name} must be a scalar or 3 numbers, got shape {a.shape}")
    return a


def _mat3(x, name="matrix"):
    a = np.asarray(x, dtype=float)
    if a.shape != (3, 3):
        raise ValueError(f"{name} must be 3x3, got shape {a.shape}")
    return a


def _temp(temp_c, v):
    """Temperature as an array broadcastable against v[..., 0]."""
    t = np.asarray(temp_c, dtype=float)
    return np.broadcast_to(t, np.shape(v)[:-1])[..., None]


# --------------------------------------------------------------------------
# Additive / multiplicative per-axis effects
@dataclass
class Bias:
    """Constant zero offset per sensor axis.

        y_i = x_i + b_i

    b: (3,) in the triad unit (g or nT)."""
    b: np.ndarray = field(default_factory=lambda: np.zeros(3))

    def __post_init__(self):
        self.b = _vec3(self.b, "Bias.b")

    def apply(self, v):
        return np.asarray(v, dtype=float) + self.b


@dataclass
class Scale:
    """Scale factor (sensitivity) per sensor axis, 1 = nominal.

        y_i = k_i x_i

    k: (3,) dimensionless."""
    k: np.ndarray = field(default_factory=lambda: np.ones(3))

    def __post_init__(self):
        self.k = _vec3(self.k, "Scale.k")

    def apply(self, v):
        return np.asarray(v, dtype=float) * self.k


@dataclass
class Misalignment:
    """Misalignment and non-orthogonality of the sensor axes: a full 3x3.

        y = M x,   M = I + E

    Row i of M is the direction (in the body frame, not necessarily unit
    length once scale is folded in) along which sensor axis i measures.  A
    small rotation by angles (rx, ry, rz) rad is M = I + [[0, rz, -ry],
    [-rz, 0, rx], [ry, -rx, 0]] (frame rotation, the same sign convention as
    reference.rz / ry); a non-orthogonality leaves M non-orthogonal.
    M: (3, 3) dimensionless."""
    M: np.ndarray = field(default_factory=lambda: np.eye(3))

    def __post_init__(self):
        self.M = _mat3(self.M, "Misalignment.M")

    def apply(self, v):
        return np.asarray(v, dtype=float) @ self.M.T

    @classmethod
    def from_small_angles(cls, rx, ry, rz, nonorth=(0.0, 0.0, 0.0)):
        """Small frame rotation (rx, ry, rz rad) plus non-orthogonality
        (nxy, nxz, nyz rad): sensor y leans by nxy towards x, sensor z by
        nxz towards x and nyz towards y (lower-triangular terms)."""
        nxy, nxz, nyz = nonorth
        M = np.array([[1.0, rz, -ry],
                      [-rz + nxy, 1.0, rx],
                      [ry + nxz, -rx + nyz, 1.0]])
        return cls(M)


@dataclass
class HardIron:
    """Fluxgate hard iron: a constant field from magnetised parts of the
    probe, fixed in the body frame.

        b' = b + h

    h: (3,) nT, body frame (added before misalignment/scale)."""
    h: np.ndarray = field(default_factory=lambda: np.zeros(3))

    def __post_init__(self):
        self.h = _vec3(self.h, "HardIron.h")

    def apply(self, v):
        return np.asarray(v, dtype=float) + self.h


@dataclass
class SoftIron:
    """Fluxgate soft iron: induced magnetisation of permeable parts of the
    probe, linear in the ambient field, fixed in the body frame.

        b' = S b,   S = I + D  (D usually small and symmetric)

    S: (3, 3) dimensionless."""
    S: np.ndarray = field(default_factory=lambda: np.eye(3))

    def __post_init__(self):
        self.S = _mat3(self.S, "SoftIron.S")

    def apply(self, v):
        return np.asarray(v, dtype=float) @ self.S.T


def temp_poly(coef1, coef2, temp_c, t_ref_c, v):
    """The temperature polynomial of the tempco effects, per axis:

        p_i(T) = coef1_i (T - T_ref) + coef2_i (T - T_ref)^2

    coef1, coef2: (3,); temp_c broadcastable against v[..., 0].  Returns
    (..., 3).  The one definition of the temperature model (issue: bias and
    scale as polynomials of order <= 2 about a reference temperature) that
    the emulator's chain, the calibration's temperature fit
    (inclino.calib.thermal) and diagnose use."""
    dT = _temp(temp_c, v) - t_ref_c
    p = coef1 * dT
    if np.any(coef2 != 0.0):
        p = p + coef2 * (dT * dT)
    return p


@dataclass
class BiasTempco:
    """Temperature dependence of the bias, a polynomial of order <= 2.

        y_i = x_i + c_i (T - T_ref) + c2_i (T - T_ref)^2

    c: (3,) triad unit per degree C; c2: (3,) triad unit per degree C^2
    (default 0: linear); t_ref_c: degrees C."""
    c: np.ndarray = field(default_factory=lambda: np.zeros(3))
    t_ref_c: float = 25.0
    c2: np.ndarray = field(default_factory=lambda: np.zeros(3))

    def __post_init__(self):
        self.c = _vec3(self.c, "BiasTempco.c")
        self.c2 = _vec3(self.c2, "BiasTempco.c2")

    def offset(self, temp_c, v=np.zeros(3)):
        """c (T - T_ref) + c2 (T - T_ref)^2, shaped like v."""
        return temp_poly(self.c, self.c2, temp_c, self.t_ref_c, np.asarray(v, dtype=float))

    def apply(self, v, temp_c):
        v = np.asarray(v, dtype=float)
        return v + self.offset(temp_c, v)


@dataclass
class ScaleTempco:
    """Temperature dependence of the scale factor, a polynomial of order <= 2.

        y_i = x_i (1 + 1e-6 (ppm_i (T - T_ref) + ppm2_i (T - T_ref)^2))

    ppm: (3,) parts per million per degree C; ppm2: (3,) ppm per degree C^2
    (default 0: linear); t_ref_c: degrees C."""
    ppm: np.ndarray = field(default_factory=lambda: np.zeros(3))
    t_ref_c: float = 25.0
    ppm2: np.ndarray = field(default_factory=lambda: np.zeros(3))

    def __post_init__(self):
        self.ppm = _vec3(self.ppm, "ScaleTempco.ppm")
        self.ppm2 = _vec3(self.ppm2, "ScaleTempco.ppm2")

    def factor(self, temp_c, v=np.zeros(3)):
        """1 + 1e-6 (ppm (T - T_ref) + ppm2 (T - T_ref)^2), shaped like v."""
        return 1.0 + temp_poly(1e-6 * self.ppm, 1e-6 * self.ppm2, temp_c, self.t_ref_c,
                               np.asarray(v, dtype=float))

    def apply(self, v, temp_c):
        v = np.asarray(v, dtype=float)
        return v * self.factor(temp_c, v)


def to_reference_temperature(y, temp_c, bias, bias_tempco: Optional[BiasTempco] = None,
                             scale_tempco: Optional[ScaleTempco] = None):
    """The inverse of the chain's temperature effects: the reading y (...,
    3) taken at temp_c, brought to the reference temperature.  With the
    chain's order (the scale tempco acts on the signal before the bias is
    added, the bias tempco after it) and bias b (3,):

        y_ref = b + (y - b - bias_tempco(T)) / scale_tempco_factor(T)

    (exact when the nonlinearity is absent; with it, the error is the
    nonlinearity's change over the scale change, k2 x^2 s(T)).  Used by the
    calibration's temperature terms (inclino.calib.thermal)."""
    y = np.asarray(y, dtype=float)
    b = np.asarray(bias, dtype=float)
    u = y - b
    if bias_tempco is not None:
        u = u - bias_tempco.offset(temp_c, y)
    if scale_tempco is not None:
        u = u / scale_tempco.factor(temp_c, y)
    return b + u


def from_reference_temperature(y_ref, temp_c, bias, bias_tempco: Optional[BiasTempco] = None,
                               scale_tempco: Optional[ScaleTempco] = None):
    """to_reference_temperature's forward direction: the reading at temp_c
    of a sensor that reads y_ref at the reference temperature,

        y = b + (y_ref - b) scale_tempco_factor(T) + bias_tempco(T)."""
    y_ref = np.asarray(y_ref, dtype=float)
    b = np.asarray(bias, dtype=float)
    u = y_ref - b
    if scale_tempco is not None:
        u = u * scale_tempco.factor(temp_c, y_ref)
    if bias_tempco is not None:
        u = u + bias_tempco.offset(temp_c, y_ref)
    return b + u


@dataclass
class ScaleNonlinearity:
    """Second-order scale nonlinearity per axis.

        y_i = x_i + k2_i x_i^2

    k2: (3,) per triad unit (1/g or 1/nT).  A reading of full-scale X is off
    by k2 X^2 (e.g. k2 = 1e-9 /nT gives +10 nT at 100 000 nT)."""
    k2: np.ndarray = field(default_factory=lambda: np.zeros(3))

    def __post_init__(self):
        self.k2 = _vec3(self.k2, "ScaleNonlinearity.k2")

    def apply(self, v):
        v = np.asarray(v, dtype=float)
        return v + self.k2 * v * v


@dataclass
class WhiteNoise:
    """Zero-mean Gaussian white noise, independent per axis and sample.

        y_i = x_i + sigma_i sqrt(n_ref / n_avg) N(0, 1)

    sigma: (3,) triad unit, the standard deviation of one output sample
    when the part averages n_ref internal samples; a part averaging n_avg
    samples instead (ADIS16210 AVG_CNT) sees it scaled by sqrt(n_ref/n_avg).
    Draws come from the caller's seeded numpy Generator, so runs repeat."""
    sigma: np.ndarray = field(default_factory=lambda: np.zeros(3))
    n_ref: int = 1

    def __post_init__(self):
        self.sigma = _vec3(self.sigma, "WhiteNoise.sigma")

    def apply(self, v, rng: np.random.Generator, n_avg: int = None):
        v = np.asarray(v, dtype=float)
        s = self.sigma * (np.sqrt(self.n_ref / n_avg) if n_avg else 1.0)
        return v + rng.standard_normal(v.shape) * s

    def scale3(self, n_avg: int = None):
        """sigma_i sqrt(n_ref / n_avg) as 3 floats (the factor `apply` uses),
        cached per n_avg; the cache follows a reassigned sigma or n_ref (not
        an in-place edit of the sigma array)."""
        c = self.__dict__.get("_scale3")
        if c is None or c[0] is not self.sigma or c[1] != self.n_ref:
            c = self._scale3 = (self.sigma, self.n_ref, {})
        s = c[2].get(n_avg)
        if s is None:
            s = c[2][n_avg] = tuple((self.sigma * (np.sqrt(self.n_ref / n_avg) if n_avg else 1.0)).tolist())
        return s


class NormalStream:
    """N(0, 1) draws of a seeded numpy Generator, taken from blocks.

    `standard_normal(shape)` (what WhiteNoise.apply calls) and `take3()`
    (one sample of a triad, as floats) hand out the generator's
    standard-normal sequence in order, exactly as one call per sample would:
    numpy's Generator draws standard normals one after another with no
    state carried between calls, so a block of n is the same n numbers as n
    single draws.  The generator itself runs up to `block` draws ahead."""

    def __init__(self, generator: np.random.Generator, block: int = 3 * 512):
        self.generator = generator
        self.block = int(block)
        self._buf: list = []
        self._i = 0

    def _refill(self, need: int):
        rest = self._buf[self._i:]
        self._buf = rest + self.generator.standard_normal(max(self.block, need - len(rest))).tolist()
        self._i = 0

    def take(self, n: int) -> list:
        """The next n draws (floats)."""
        if self._i + n > len(self._buf):
            self._refill(n)
        i = self._i
        self._i = i + n
        return self._buf[i:i + n]

    def take3(self):
        i = self._i
        if i + 3 > len(self._buf):
            self._refill(3)
            i = 0
        self._i = i + 3
        b = self._buf
        return b[i], b[i + 1], b[i + 2]

    def standard_normal(self, size=None):
        if size is None:
            return self.take(1)[0]
        shape = (size,) if isinstance(size, (int, np.integer)) else tuple(size)
        n = int(np.prod(shape, dtype=np.int64))
        return np.array(self.take(n), dtype=float).reshape(shape)


@dataclass
class Saturation:
    """Range saturation of the analog signal chain.

        y_i = clip(x_i, lo_i, hi_i)

    lo, hi: (3,) triad unit (ADIS16210: +-1.7 g specified range; fluxgate:
    +-100 000 nT)."""
    lo: np.ndarray = field(default_factory=lambda: np.full(3, -np.inf))
    hi: np.ndarray = field(default_factory=lambda: np.full(3, np.inf))

    def __post_init__(self):
        self.lo = _vec3(self.lo, "Saturation.lo")
        self.hi = _vec3(self.hi, "Saturation.hi")

    @classmethod
    def symmetric(cls, limit):
        lim = _vec3(limit, "limit")
        return cls(-lim, lim)

    def apply(self, v):
        return np.clip(np.asarray(v, dtype=float), self.lo, self.hi)

    def bounds6(self):
        """(lo_x, lo_y, lo_z, hi_x, hi_y, hi_z) as floats (cached; follows a
        reassigned lo/hi, not an in-place edit)."""
        c = self.__dict__.get("_bounds6")
        if c is None or c[0] is not self.lo or c[1] is not self.hi:
            c = self._bounds6 = (self.lo, self.hi, tuple(self.lo.tolist() + self.hi.tolist()))
        return c[2]


@dataclass
class Quantisation:
    """Quantisation to the converter's LSB with its integer rails.

        counts_i = clip(round(x_i / lsb), cmin, cmax);  y_i = counts_i lsb

    lsb: triad unit per count (ADIS16210: 1/16384 g; fluxgate ADC: 1 nT);
    cmin, cmax: the register rails (int16; signed 24-bit).  Rounding is
    round-half-to-even (numpy), as in reference.quantise_acc/_mag."""
    lsb: float = 1.0
    cmin: int = -(2**23)
    cmax: int = 2**23 - 1

    def counts(self, v):
        return np.clip(np.round(np.asarray(v, dtype=float) / self.lsb),
                       self.cmin, self.cmax).astype(np.int64)

    def apply(self, v):
        return self.counts(v) * self.lsb


# --------------------------------------------------------------------------
# Effects on time and on the world
@dataclass
class SamplingSkew:
    """Sampling-time skew of a triad relative to the accelerometer.

        t_sample = t + skew_s

    While the probe rotates, a triad sampled skew_s later sees the pose at
    t + skew_s: for a toolface rate w (deg/s) its reading equals the
    skew-free reading at toolface T + w skew_s.  skew_s: seconds."""
    skew_s: float = 0.0

    def apply(self, t):
        return np.asarray(t, dtype=float) + self.skew_s


@dataclass
class FieldDrift:
    """Slow drift of the Earth field (secular/diurnal variation, a magnetic
    storm) as linear rates from t = 0.

        F(t)   = F0   + rate_nT_per_s t
        dip(t) = dip0 + dip_rate_deg_per_s t
        dec(t) = dec0 + declination_rate_deg_per_s t
    """
    rate_nT_per_s: float = 0.0
    dip_rate_deg_per_s: float = 0.0
    declination_rate_deg_per_s: float = 0.0

    def apply(self, field_nT, dip_deg, declination_deg, t):
        t = np.asarray(t, dtype=float)
        return (field_nT + self.rate_nT_per_s * t,
                dip_deg + self.dip_rate_deg_per_s * t,
                declination_deg + self.declination_rate_deg_per_s * t)


RIG_AXES = ("azi", "inc", "tf")


def rig_frame_to_body(axis: str, inc, azi, tf):
    """(..., 3, 3): the matrix taking a vector in the frame that turntable
    axis `axis` turns in (its stator) to the body frame, at the true axis
    angles (deg).  C = Rz(T) Ry(I) Rz(A) (docs/conventions.md): the azimuth
    axis turns in the world (NED) frame, the inclination axis in the azimuth
    platform's frame Rz(A) W, the toolface axis in the inclination arm's
    frame Ry(I) Rz(A) W."""
    from inclino.engines import reference as ref

    if axis == "azi":
        return ref.pose_matrix(inc, azi, tf)
    if axis == "inc":
        return ref.rz(tf) @ ref.ry(inc)
    if axis == "tf":
        return ref.rz(tf) + 0.0 * np.asarray(inc, float)[..., None, None]
    raise ValueError(f"rig axis must be one of {', '.join(RIG_AXES)}, not {axis!r}")


@dataclass
class RigField:
    """A field disturbance that moves with one turntable axis: a stepper
    motor, a steel bearing or a clamp on the rig (a turntable that is not
    non-magnetic).  In the frame that axis turns in (rig_frame_to_body), the
    field at the probe is a low-order harmonic function of the axis angle phi:

        b_s(phi) = sum_h [ cos(h phi) cos_nT[h] + sin(h phi) sin_nT[h] ]   (nT)

    h = 0, 1, ... len(cos_nT) - 1 (sin_nT[0] is unused).  A part fixed to
    the axis' stator (the stage it turns in) is the h = 0 term; a part on
    its rotor, or one whose distance to the probe changes as the axis
    turns, gives the h >= 1 terms.  The fluxgate reads b_body += C_s->body
    b_s(phi); the accelerometer is not affected.  axis: "azi", "inc" or
    "tf"; cos_nT, sin_nT: (H+1, 3) nT."""
    axis: str = "inc"
    cos_nT: np.ndarray = field(default_factory=lambda: np.zeros((1, 3)))
    sin_nT: np.ndarray = field(default_factory=lambda: np.zeros((1, 3)))

    def __post_init__(self):
        if self.axis not in RIG_AXES:
            raise ValueError(f"RigField.axis must be one of {', '.join(RIG_AXES)}, not {self.axis!r}")
        self.cos_nT = np.atleast_2d(np.asarray(self.cos_nT, float))
        self.sin_nT = np.atleast_2d(np.asarray(self.sin_nT, float))
        H = max(len(self.cos_nT), len(self.sin_nT))
        pad = lambda a: np.vstack([a, np.zeros((H - len(a), 3))])  # noqa: E731
        self.cos_nT, self.sin_nT = pad(self.cos_nT), pad(self.sin_nT)
        if self.cos_nT.shape[1] != 3:
            raise ValueError("RigField.cos_nT and sin_nT are (H+1, 3) nT")

    def angle(self, inc, azi, tf):
        return {"azi": azi, "inc": inc, "tf": tf}[self.axis]

    def field_stator(self, phi_deg) -> np.ndarray:
        """(..., 3) nT in the axis' stator frame."""
        ph = np.radians(np.asarray(phi_deg, float))[..., None]
        out = np.zeros(np.shape(ph)[:-1] + (3,))
        for h in range(len(self.cos_nT)):
            out = out + np.cos(h * ph) * self.cos_nT[h] + np.sin(h * ph) * self.sin_nT[h]
        return out

    def apply(self, inc, azi, tf) -> np.ndarray:
        """(..., 3) nT: the disturbance in the body frame at the true pose."""
        C = rig_frame_to_body(self.axis, inc, azi, tf)
        return (C @ self.field_stator(self.angle(inc, azi, tf))[..., None])[..., 0]


# --------------------------------------------------------------------------
# A triad's chain
@dataclass
class TriadModel:
    """All the effects of one triad; any of them may be None (= absent).

    apply(v, temp_c, rng, n_avg, quantise) runs the chain in the order given
    in the module docstring.  `linear()` gives the equivalent y = A x + c of
    the linear part (soft iron, hard iron, misalignment, scale, bias) at the
    reference temperature."""
    soft_iron: Optional[SoftIron] = None
    hard_iron: Optional[HardIron] = None
    misalignment: Optional[Misalignment] = None
    scale: Optional[Scale] = None
    scale_tempco: Optional[ScaleTempco] = None
    nonlinearity: Optional[ScaleNonlinearity] = None
    bias: Optional[Bias] = None
    bias_tempco: Optional[BiasTempco] = None
    noise: Optional[WhiteNoise] = None
    saturation: Optional[Saturation] = None
    quantisation: Optional[Quantisation] = None

    EFFECTS = ("soft_iron", "hard_iron", "misalignment", "scale", "scale_tempco",
               "nonlinearity", "bias", "bias_tempco", "noise", "saturation",
               "quantisation")

    def apply(self, v, temp_c=25.0, rng: np.random.Generator = None, n_avg=None,
              quantise=True):
        return self.random_part(self.deterministic(v, temp_c), rng, n_avg, quantise)

    def deterministic(self, v, temp_c=25.0):
        """The chain up to the bias tempco (v1..v5): everything that does not
        draw noise.  apply = random_part(deterministic(v, T), ...)."""
        y = self.head(v)
        if self.scale_tempco is not None:
            y = self.scale_tempco.apply(y, temp_c)
        if self.nonlinearity is not None:
            y = self.nonlinearity.apply(y)
        if self.bias is not None:
            y = self.bias.apply(y)
        if self.bias_tempco is not None:
            y = self.bias_tempco.apply(y, temp_c)
        return y

    def head(self, v):
        """The start of `deterministic` that the temperature does not touch:
        soft iron, hard iron, misalignment, scale (for a static pose, the same
        at every sample)."""
        y = np.asarray(v, dtype=float)
        if self.soft_iron is not None:
            y = self.soft_iron.apply(y)
        if self.hard_iron is not None:
            y = self.hard_iron.apply(y)
        if self.misalignment is not None:
            y = self.misalignment.apply(y)
        if self.scale is not None:
            y = self.scale.apply(y)
        return y

    def tail3(self):
        """A function (y, temp_c) -> the rest of `deterministic` (scale
        tempco, nonlinearity, bias, bias tempco) for one sample as plain
        floats: y the 3 floats of `head`, temp_c a float; returns a tuple of
        3 floats.  It does the NumPy chain's operations in the same order on
        floats -- temp_poly's dT = T - T_ref, c1 dT, + c2 (dT dT) when any c2
        is non-zero; y (1 + p); y + (k2 y) y; y + b; y + p -- so the same bits
        (build it once, call it per sample: a chamber run's temperature
        changes at every sample, so the chain cannot be cached)."""
        steps = []
        st = self.scale_tempco
        if st is not None:
            c1, c2 = 1e-6 * st.ppm, 1e-6 * st.ppm2
            steps.append(("scale_tempco", c1.tolist(), c2.tolist(), bool(np.any(c2 != 0.0)), float(st.t_ref_c)))
        if self.nonlinearity is not None:
            steps.append(("nonlinearity", self.nonlinearity.k2.tolist()))
        if self.bias is not None:
            steps.append(("bias", self.bias.b.tolist()))
        bt = self.bias_tempco
        if bt is not None:
            steps.append(("bias_tempco", bt.c.tolist(), bt.c2.tolist(), bool(np.any(bt.c2 != 0.0)), float(bt.t_ref_c)))

        def f(y, temp_c):
            y0, y1, y2 = y
            for step in steps:
                kind = step[0]
                if kind == "scale_tempco" or kind == "bias_tempco":
                    _, (a0, a1, a2), (b0, b1, b2), second, t_ref = step
                    dT = float(temp_c) - t_ref
                    p0, p1, p2 = a0 * dT, a1 * dT, a2 * dT
                    if second:
                        dT2 = dT * dT
                        p0, p1, p2 = p0 + b0 * dT2, p1 + b1 * dT2, p2 + b2 * dT2
                    if kind == "scale_tempco":
                        y0, y1, y2 = y0 * (1.0 + p0), y1 * (1.0 + p1), y2 * (1.0 + p2)
                    else:
                        y0, y1, y2 = y0 + p0, y1 + p1, y2 + p2
                elif kind == "nonlinearity":
                    k0, k1, k2 = step[1]
                    y0, y1, y2 = y0 + k0 * y0 * y0, y1 + k1 * y1 * y1, y2 + k2 * y2 * y2
                else:
                    b0, b1, b2 = step[1]
                    y0, y1, y2 = y0 + b0, y1 + b1, y2 + b2
            return y0, y1, y2
        return f

    def random_part(self, y, rng: np.random.Generator = None, n_avg=None, quantise=True):
        """The rest of the chain (v6, v7, out): noise, saturation, quantisation."""
        y = np.asarray(y, dtype=float)
        if self.noise is not None:
            if rng is None:
                raise ValueError("WhiteNoise needs a seeded numpy Generator (rng)")
            y = self.noise.apply(y, rng, n_avg)
        if self.saturation is not None:
            y = self.saturation.apply(y)
        if quantise and self.quantisation is not None:
            y = self.quantisation.apply(y)
        return y

    def random_part3(self, y, normals, n_avg=None):
        """random_part for one sample as plain floats, without quantisation:
        y: 3 floats (from `deterministic`), normals: a NormalStream.
        Returns a tuple of 3 floats."""
        return self.sampler(normals, n_avg)(y)

    def sampler(self, normals: "NormalStream", n_avg=None):
        """A function y -> random_part3(y, normals, n_avg) with the noise
        factors and saturation bounds bound in (build it once, call it per
        sample).  It does the NumPy chain's operations in the same order --
        y + z * s, then min(max(y, lo), hi) -- on floats, so the same bits,
        and takes the draws from the stream's block in line (take3)."""
        nz, sat = self.noise, self.saturation
        if nz is None:
            s0 = s1 = s2 = None
        else:
            s0, s1, s2 = nz.scale3(n_avg)
        if sat is None:
            l0 = l1 = l2 = -np.inf
            h0 = h1 = h2 = np.inf
        else:
            l0, l1, l2, h0, h1, h2 = sat.bounds6()
        st = normals

        def f(y):
            y0, y1, y2 = y
            if s0 is not None:
                i = st._i                   # NormalStream.take3, in line
                b = st._buf
                if i + 3 > len(b):
                    st._refill(3)
                    i = 0
                    b = st._buf
                st._i = i + 3
                y0 = y0 + b[i] * s0
                y1 = y1 + b[i + 1] * s1
                y2 = y2 + b[i + 2] * s2
            if y0 < l0:                     # np.clip: min(max(y, lo), hi)
                y0 = l0
            if y0 > h0:
                y0 = h0
            if y1 < l1:
                y1 = l1
            if y1 > h1:
                y1 = h1
            if y2 < l2:
                y2 = l2
            if y2 > h2:
                y2 = h2
            return y0, y1, y2
        return f

    def linear(self):
        """(A, c) with y = A x + c for the linear effects (no temperature,
        nonlinearity, noise, saturation or quantisation)."""
        A = np.eye(3)
        c = np.zeros(3)
        if self.soft_iron is not None:
            A = self.soft_iron.S @ A
        if self.hard_iron is not None:
            c = c + self.hard_iron.h
        if self.misalignment is not None:
            A = self.misalignment.M @ A
            c = self.misalignment.M @ c
        if self.scale is not None:
            A = self.scale.k[:, None] * A
            c = self.scale.k * c
        if self.bias is not None:
            c = c + self.bias.b
        return A, c

    def only(self, name):
        """A copy keeping only the named effect (for one-at-a-time studies)."""
        if name not in self.EFFECTS:
            raise KeyError(name)
        return TriadModel(**{name: getattr(self, name)})


# --------------------------------------------------------------------------
# Li 2021 (Drilling Engineering 48(5):76-82), error model (3)/(4), Table 2
def li2021_matrix(K, e):
    """The 3x3 A = diag(K) (I + E) of Li 2021 eq. (3)/(4).

    Li 2021 eq. (3):  H_x = K_x (M_x + e_yx M_y + e_zx M_z) + B_x
                      H_y = K_y (e_xy M_x + M_y + e_zy M_z) + B_y
                      H_z = K_z (e_xz M_x + e_yz M_y + M_z) + B_z
    i.e. H = diag(K) (I + E) M + B with
        I + E = [[1, e_yx, e_zx], [e_xy, 1, e_zy], [e_xz, e_yz, 1]].

    `e` is Table 2's "installation error" block as printed: one row per
    sensor axis X, Y, Z with two numbers each.  The row of axis X holds the
    two coefficients that eqs. (7)/(8) solve from positions 1-4 (X vertical),
    e_xy and e_xz -- the coupling of the X field component into the Y and Z
    sensors, i.e. column x of E; row Y holds (e_yx, e_yz), row Z (e_zx,
    e_zy).  This reading is checked, not assumed: inverting A with Table 2's
    magnetometer numbers reproduces Table 3's printed correction
    coefficients A_i, B_i, C_i, D_i to their last digit, while the transposed
    reading does not (tests/test_emulator_effects.py)."""
    K = _vec3(K, "K")
    e = np.asarray(e, dtype=float)
    if e.shape != (3, 2):
        raise ValueError("e must be Table 2's 3x2 block (rows X, Y, Z)")
    IE = np.eye(3)
    (exy, exz), (eyx, eyz), (ezx, ezy) = e
    IE[1, 0], IE[2, 0] = exy, exz
    IE[0, 1], IE[2, 1] = eyx, eyz
    IE[0, 2], IE[1, 2] = ezx, ezy
    return K[:, None] * IE


def from_li2021(K, B_counts, e, lsb, **extra) -> TriadModel:
    """TriadModel with Li 2021's scale K, bias B and installation errors e.

    Mapping into our chain: Misalignment.M = I + E (see li2021_matrix),
    Scale.k = K, Bias.b = B_counts * lsb.  Li applies K after the coupling,
    as our chain does (misalignment, then scale, then bias), so the product
    is exactly Li's diag(K)(I + E).

    Axes and signs: Li 2021 section 1 puts X, Y, Z along north, east, down
    at the level, zero-azimuth pose with Z down the tool axis, right-handed
    -- the same body axes as reference.py at I = A = T = 0 -- so no axis is
    permuted or negated.  Li's sensor outputs (gravity +g on the down axis,
    Table 1 position 9 G = (g_n, g_e, g_d)) carry the same sign as ours.
    Table 2's note says the values are "after A/D conversion", i.e. counts:
    the bias becomes B_counts * lsb in nominal units, taking Li's probe LSBs
    to be this probe's (1/16384 g, 1 nT) -- an assumption; Li does not give
    its converters.  K and e are dimensionless and need no conversion.
    `extra` adds further effects (noise, quantisation...) to the model."""
    A = li2021_matrix(K, e)
    K = _vec3(K, "K")
    M = A / K[:, None]
    return TriadModel(misalignment=Misalignment(M), scale=Scale(K),
                      bias=Bias(_vec3(B_counts, "B") * lsb), **extra)


# Li 2021 Table 2, as printed (bias in A/D counts).
LI2021_TABLE2 = {
    "mag": {"B": [-188.795, 129.94, -314.095], "K": [0.9514, 0.9716, 0.9067],
            "e": [[0.0312, 0.0306], [-0.0076, 0.0399], [0.0062, -0.0566]]},
    "acc": {"B": [-17.5863, -46.3725, -6.8975], "K": [0.9998, 0.9977, 0.9977],
            "e": [[0.0046, -0.0013], [-0.0074, -0.0606], [0.0019, 0.0585]]},
}
# Li 2021 Table 3 (inverse coefficients M = [A B C] H + D), for checking.
LI2021_TABLE3 = {
    "mag": {"ABC": [[1.051, 0.0081, -0.0063], [-0.0345, 1.0266, 0.0625],
                    [-0.0308, -0.0412, 1.1006]], "D": [195, -120, 345]},
    "acc": {"ABC": [[1.0002, 0.0072, -0.0023], [-0.0047, 0.9987, -0.0584],
                    [0.001, 0.0605, 0.9988]], "D": [18, 46, 10]},
}
