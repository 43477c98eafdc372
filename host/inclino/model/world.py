"""The world around the probe: a non-magnetic three-axis turntable, gravity,
the Earth field and the probe temperature.

Frames and conventions are reference.py's (docs/conventions.md): world NED;
body = pose_matrix(I, A, T) @ world; the accelerometer reads +1 g on an axis
pointing down; field_ned(F, dip, dec).

The turntable is *commanded* to an indicated pose (what its encoders show
and what a dataset's inc_deg/azi_deg/tf_deg columns record).  With encoder
errors the probe sits at the true pose

    true_k = offset_k + (1 + scale_k) * indicated_k,   k = inc, azi, tf

Azimuth is measured from the turntable's north reference; with a non-zero
declination that is true north, with declination 0 magnetic north.
"""
from __future__ import annotations

import datetime as _dt
import math
from dataclasses import dataclass, field
from typing import Optional

import numpy as np

from inclino.engines import reference as ref

from inclino.model.effects import FieldDrift, RigField


@dataclass
class EncoderErrors:
    """Turntable encoder errors per axis (inc, azi, tf).

        true = offset_deg + (1 + scale) * indicated

    offset_deg: (3,) degrees; scale: (3,) dimensionless (1e-4 = 100 ppm)."""
    offset_deg: np.ndarray = field(default_factory=lambda: np.zeros(3))
    scale: np.ndarray = field(default_factory=lambda: np.zeros(3))

    def __post_init__(self):
        self.offset_deg = np.broadcast_to(np.asarray(self.offset_deg, float), (3,)).copy()
        self.scale = np.broadcast_to(np.asarray(self.scale, float), (3,)).copy()

    def true_pose(self, inc, azi, tf):
        return tuple(self.offset_deg[k] + (1.0 + self.scale[k]) * np.asarray(a, float)
                     for k, a in enumerate((inc, azi, tf)))


def _rx(a_deg):
    a = np.radians(np.asarray(a_deg, float))
    c, s = np.cos(a), np.sin(a)
    z, o = np.zeros_like(a), np.ones_like(a)
    return np.stack([np.stack([o, z, z], -1), np.stack([z, c, s], -1), np.stack([z, -s, c], -1)], -2)


@dataclass
class TurntableGeometry:
    """Errors of the turntable's axes themselves (degrees), beyond the
    encoders (added for inclino diagnose: Li 2021's checks ask for them).

        C = Rz(T) Rx(-skew) Ry(I) Rx(skew) Rz(A) Rx(-tilt_east) Ry(tilt_north)

    tilt_north_deg, tilt_east_deg: the azimuth axis is off the vertical, its
    downward direction displaced toward north / east (inclination error
    ~ tilt_north cos A + tilt_east sin A, azimuth error ~ cot I times the
    crossed term).  skew_deg: the inclination axis is out of square with the
    azimuth axis; the tool axis is vertical at I = 0 and swings sideways as
    it tilts, its azimuth off by ~ skew tan(I/2) (skew at I = 90)."""
    tilt_north_deg: float = 0.0
    tilt_east_deg: float = 0.0
    skew_deg: float = 0.0

    def pose_matrix(self, I, A, T):
        """body = C @ world for the (encoder-corrected) axis angles."""
        W = _rx(-self.tilt_east_deg) @ ref.ry(self.tilt_north_deg)
        return (ref.rz(T) @ _rx(-self.skew_deg) @ ref.ry(I) @ _rx(self.skew_deg) @ ref.rz(A)) @ W


@dataclass
class TurntableMotion:
    """How long the turntable takes to go from one indicated pose to
    another: its three axes turn together at rate_deg_s (azimuth and
    toolface the short way round, inclination within 0-180 deg), then it
    waits settle_s for the mechanics to come to rest (seconds).

        duration = max(|dI|, |dA|, |dT|) / rate_deg_s + settle_s   (0 when the pose does not change)

    The bench's time between two readings at different poses (the control
    channel's `move` runs the emulated clock through it).  The default is
    the instantaneous table (rate_deg_s = inf, settle_s = 0), as the
    emulator always had; MOTORISED (10 deg/s per axis, 3 s to settle: an
    assumption for a motorised non-magnetic three-axis table, not a
    datasheet figure) is what the bench-time figures use
    (`[world.turntable]` in a scenario, benchmarks/calibration_time.py)."""
    rate_deg_s: float = math.inf
    settle_s: float = 0.0

    def __post_init__(self):
        self.rate_deg_s, self.settle_s = float(self.rate_deg_s), float(self.settle_s)
        if not (self.rate_deg_s > 0.0) or math.isnan(self.rate_deg_s):
            raise ValueError("turntable rate_deg_s must be > 0 (inf: instantaneous)")
        if not (math.isfinite(self.settle_s) and self.settle_s >= 0.0):
            raise ValueError("turntable settle_s must be a finite number >= 0")

    @staticmethod
    def turn_deg(a, b):
        """The largest axis turn from pose a to pose b (each (inc, azi, tf),
        deg; arrays broadcast): azimuth and toolface the short way round."""
        a = [np.asarray(x, float) for x in a]
        b = [np.asarray(x, float) for x in b]
        d_inc = np.abs(b[0] - a[0])
        d_azi = np.abs((b[1] - a[1] + 180.0) % 360.0 - 180.0)
        d_tf = np.abs((b[2] - a[2] + 180.0) % 360.0 - 180.0)
        return np.maximum(d_inc, np.maximum(d_azi, d_tf))

    def duration(self, a, b):
        """Seconds from indicated pose a to b (arrays broadcast)."""
        turn = self.turn_deg(a, b)
        return np.where(turn > 1e-9, turn / self.rate_deg_s + self.settle_s, 0.0)


MOTORISED = {"rate_deg_s": 10.0, "settle_s": 3.0}


def pose_in_range(inc, azi, tf):
    """(inc, azi, tf) written inside the turntable's ranges (inclination
    0-180 deg, azimuth and toolface 0-360 deg), the orientation unchanged:
    C(-I, A, T) = C(I, A + 180, T + 180) and C(I, A, T) = C(360 - I, A + 180,
    T + 180).  A readout error at a vertical pose is a tilt in any
    direction; clipping the inclination at 0 instead would leave the probe
    at the pose half the time and tilted toward the indicated azimuth the
    other half (a mean inclination error of 0.4 sigma at every vertical
    pose)."""
    inc, azi, tf = (np.array(v, float) for v in (inc, azi, tf))
    lo, hi = inc < 0.0, inc > 180.0
    inc[lo] = -inc[lo]
    inc[hi] = 360.0 - inc[hi]
    flip = lo | hi
    azi[flip] += 180.0
    tf[flip] += 180.0
    return inc, np.mod(azi, 360.0), np.mod(tf, 360.0)


@dataclass
class Turntable:
    """Non-magnetic three-axis turntable: inclination 0-180 deg, azimuth and
    toolface 0-360 deg (checked on the indicated pose; a trajectory may
    unwrap azimuth/toolface beyond 360 for continuous rotation).  `motion`:
    how long it takes to move (TurntableMotion; the emulator's control
    channel, not the instantaneous `move_to` of the physics)."""
    encoder: EncoderErrors = field(default_factory=EncoderErrors)
    geometry: Optional[TurntableGeometry] = None
    motion: TurntableMotion = field(default_factory=TurntableMotion)

    INC_RANGE = (0.0, 180.0)

    def check(self, inc, azi, tf, unwrapped=False):
        inc = np.asarray(inc, float)
        if np.any(inc < self.INC_RANGE[0]) or np.any(inc > self.INC_RANGE[1]):
            raise ValueError("turntable inclination must be within 0-180 deg")
        if not unwrapped:
            for name, a in (("azimuth", azi), ("toolface", tf)):
                a = np.asarray(a, float)
                if np.any(a < 0.0) or np.any(a > 360.0):
                    raise ValueError(f"turntable {name} must be within 0-360 deg")

    def true_pose(self, inc, azi, tf):
        return self.encoder.true_pose(inc, azi, tf)

    def pose_matrix(self, inc, azi, tf):
        """body = C @ world at an indicated pose: encoder errors, then the axes' geometry."""
        I, A, T = self.true_pose(inc, azi, tf)
        return ref.pose_matrix(I, A, T) if self.geometry is None else self.geometry.pose_matrix(I, A, T)


@dataclass
class Trajectory:
    """Indicated pose as a function of time: piecewise-linear between
    keyframes (t_s, inc, azi, tf), held constant outside them.  Azimuth and
    toolface are interpolated unwrapped, so keyframes tf 0 -> 3600 over 10 s
    are ten turns at 360 deg/s."""
    t_s: np.ndarray
    inc_deg: np.ndarray
    azi_deg: np.ndarray
    tf_deg: np.ndarray

    def __post_init__(self):
        self.t_s = np.atleast_1d(np.asarray(self.t_s, float))
        n = len(self.t_s)
        self.inc_deg, self.azi_deg, self.tf_deg = (
            np.broadcast_to(np.asarray(a, float), (n,)).copy()
            for a in (self.inc_deg, self.azi_deg, self.tf_deg))
        if np.any(np.diff(self.t_s) <= 0):
            raise ValueError("trajectory times must increase")

    @classmethod
    def static(cls, inc, azi, tf):
        return cls([0.0], [inc], [azi], [tf])

    def __call__(self, t):
        t = np.asarray(t, float)
        return tuple(np.interp(t, self.t_s, a) for a in (self.inc_deg, self.azi_deg, self.tf_deg))


@dataclass
class EarthField:
    """Total field (nT), dip (deg, positive down) and declination (deg, east
    of true north).  `from_igrf` fills them from the IGRF model (ppigrf)."""
    field_nT: float = 50000.0
    dip_deg: float = 60.0
    declination_deg: float = 0.0
    source: str = "explicit"

    @classmethod
    def from_igrf(cls, lat_deg, lon_deg, date, alt_km=0.0):
        """IGRF main field at a geodetic position and date (ppigrf, pure
        Python IGRF).  date: datetime.date/datetime or ISO string."""
        import ppigrf  # imported here: only IGRF scenarios need it

        if isinstance(date, str):
            date = _dt.date.fromisoformat(date)
        if not isinstance(date, _dt.datetime):
            date = _dt.datetime(date.year, date.month, date.day)
        be, bn, bu = ppigrf.igrf(lon_deg, lat_deg, alt_km, date)
        be, bn, bd = float(np.ravel(be)[0]), float(np.ravel(bn)[0]), -float(np.ravel(bu)[0])
        h = np.hypot(bn, be)
        return cls(field_nT=float(np.sqrt(h * h + bd * bd)),
                   dip_deg=float(np.degrees(np.arctan2(bd, h))),
                   declination_deg=float(np.degrees(np.arctan2(be, bn))),
                   source=f"IGRF (ppigrf) lat={lat_deg} lon={lon_deg} date={date.date()} alt_km={alt_km}")


@dataclass
class Temperature:
    """Probe temperature: t0_c + rate_c_per_s * t (degrees C)."""
    t0_c: float = 25.0
    rate_c_per_s: float = 0.0

    def __call__(self, t):
        return self.t0_c + self.rate_c_per_s * np.asarray(t, float)


    def at(self, t: float) -> float:
        """The temperature at one time (float), the same operations as __call__."""
        return self.t0_c + self.rate_c_per_s * t


CHAMBER_RANGE_C = (-70.0, 180.0)   # set points a climatic chamber reaches
CHAMBER_MAX_RATE_C_PER_MIN = 30.0


class Chamber:
    """A thermal chamber around the probe (and its turntable).

    The chamber air follows its set points: each `set` starts, at time t, a
    linear ramp from the air temperature then to the new set point at
    rate_c_per_min (None or 0: a step), after which the air holds the set
    point.  The probe's temperature lags the air by a first-order time
    constant tau_s (the probe's heat capacity over its thermal conductance
    to the air):

        dTp/dt = (Tc(t) - Tp) / tau_s

    solved exactly on each piece of the air's piecewise-linear profile: on a
    piece starting at t_k with air Tc_k, slope r_k and probe Tp_k,

        Tc(t) = Tc_k + r_k (t - t_k)
        Tp(t) = Tc(t) - r_k tau + (Tp_k - Tc_k + r_k tau) exp(-(t - t_k) / tau)

    (tau_s = 0: the probe follows the air).  Before the first piece both are
    temp_c.  Times are the emulator's seconds; `set` at a time before the
    last piece's start is refused (time only runs forward)."""

    def __init__(self, temp_c: float = 25.0, tau_s: float = 300.0, t0_s: float = 0.0):
        temp_c, tau_s = float(temp_c), float(tau_s)
        if not (math.isfinite(temp_c) and CHAMBER_RANGE_C[0] <= temp_c <= CHAMBER_RANGE_C[1]):
            raise ValueError(f"chamber temperature must be within {CHAMBER_RANGE_C[0]:g} to "
                             f"{CHAMBER_RANGE_C[1]:g} degC")
        if not (math.isfinite(tau_s) and 0.0 <= tau_s <= 86400.0):
            raise ValueError("the probe's thermal time constant tau_s must be within 0-86400 s")
        self.tau_s = tau_s
        self.setpoint_c = temp_c
        # pieces: (t_k, Tc_k, r_k per second, Tp_k)
        self._pieces = [(float(t0_s), temp_c, 0.0, temp_c)]
        self._last_set_s = float(t0_s)

    # ---- evaluation ------------------------------------------------------
    def _piece(self, t: float):
        ps = self._pieces
        k = len(ps) - 1
        while k > 0 and ps[k][0] > t:
            k -= 1
        return ps[k]

    def _eval(self, t: float):
        tk, ck, rk, pk = self._piece(t)
        dt = t - tk
        if dt < 0.0:   # before the first piece: the initial temperature
            return ck, pk
        tc = ck + rk * dt
        if self.tau_s == 0.0:
            return tc, tc
        lag = rk * self.tau_s
        return tc, tc - lag + (pk - ck + lag) * math.exp(-dt / self.tau_s)

    def chamber_c(self, t: float) -> float:
        """The air temperature at t (degC)."""
        return self._eval(float(t))[0]

    def at(self, t: float) -> float:
        """The probe's temperature at t (degC).  Fast path (the sensor models
        ask at every sample): on a last piece that holds with the probe at
        the air's temperature, that temperature (the same bits as _eval)."""
        tk, ck, rk, pk = self._pieces[-1]
        if t >= tk and rk == 0.0 and pk == ck:
            return ck
        return self._eval(t)[1]

    def __call__(self, t):
        t = np.asarray(t, float)
        if t.ndim == 0:
            return self.at(float(t))
        return np.array([self.at(float(x)) for x in t.ravel()]).reshape(t.shape)

    # ---- control ---------------------------------------------------------
    def set(self, t_s: float, setpoint_c: float, rate_c_per_min: Optional[float] = None) -> None:
        """From t_s, ramp the air to setpoint_c at rate_c_per_min (None or
        0: a step) and hold it there."""
        t_s, setpoint_c = float(t_s), float(setpoint_c)
        if not math.isfinite(t_s) or t_s < self._last_set_s:
            raise ValueError("a chamber set point cannot start before the last one")
        if not (math.isfinite(setpoint_c) and CHAMBER_RANGE_C[0] <= setpoint_c <= CHAMBER_RANGE_C[1]):
            raise ValueError(f"setpoint_c must be within {CHAMBER_RANGE_C[0]:g} to {CHAMBER_RANGE_C[1]:g} degC")
        if rate_c_per_min is not None:
            rate_c_per_min = float(rate_c_per_min)
            if not (math.isfinite(rate_c_per_min) and 0.0 <= rate_c_per_min <= CHAMBER_MAX_RATE_C_PER_MIN):
                raise ValueError(f"rate_c_per_min must be within 0-{CHAMBER_MAX_RATE_C_PER_MIN:g} degC/min "
                                 "(0: a step)")
        tc, tp = self._eval(t_s)
        self._pieces = [p for p in self._pieces if p[0] < t_s] or [self._pieces[0]]
        r = math.copysign(rate_c_per_min / 60.0, setpoint_c - tc) if rate_c_per_min else 0.0
        if r == 0.0 or setpoint_c == tc:  # a rate too small to count per second (1e-320 degC/min) is a step
            self._pieces.append((t_s, setpoint_c, 0.0, tp))
        else:
            self._pieces.append((t_s, tc, r, tp))
            t_end = t_s + (setpoint_c - tc) / r
            _, tp_end = self._eval(t_end)
            self._pieces.append((t_end, setpoint_c, 0.0, tp_end))
        self.setpoint_c = setpoint_c
        self._last_set_s = t_s

    def state(self, t: float) -> dict:
        tc, tp = self._eval(float(t))
        return {"chamber_c": tc, "probe_c": tp, "setpoint_c": self.setpoint_c, "tau_s": self.tau_s}


@dataclass
class World:
    turntable: Turntable = field(default_factory=Turntable)
    earth: EarthField = field(default_factory=EarthField)
    gravity_g: float = 1.0
    temperature: Temperature = field(default_factory=Temperature)  # or a Chamber
    drift: Optional[FieldDrift] = None
    rig_fields: list = field(default_factory=list)  # effects.RigField: fields that move with the turntable's axes

    def field_params(self, t=0.0):
        """(F nT, dip deg, declination deg) at time t, drift included."""
        F, dip, dec = self.earth.field_nT, self.earth.dip_deg, self.earth.declination_deg
        if self.drift is not None:
            return self.drift.apply(F, dip, dec, t)
        t = np.asarray(t, float)
        return F + 0 * t, dip + 0 * t, dec + 0 * t

    def field_ned(self, t=0.0):
        """Earth field in NED, (..., 3) nT."""
        F, dip, dec = (np.asarray(a, float) for a in self.field_params(t))
        d, c = np.radians(dip), np.radians(dec)
        return np.stack([F * np.cos(d) * np.cos(c), F * np.cos(d) * np.sin(c), F * np.sin(d)], -1)

    def truth(self, inc, azi, tf, t=0.0):
        """True body-frame gravity reading (g) and field (nT) for an
        *indicated* pose at time t: (g (..., 3), b (..., 3))."""
        C = self.turntable.pose_matrix(inc, azi, tf)
        g = C @ ref.gravity_ned(self.gravity_g)
        b = (C @ self.field_ned(t)[..., None])[..., 0]
        if self.rig_fields:
            I, A, T = self.turntable.true_pose(inc, azi, tf)
            for rf in self.rig_fields:
                b = b + rf.apply(I, A, T)
        return g, b
