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
from dataclasses import dataclass, field
from typing import Optional

import numpy as np

from inclino import reference as ref

from .effects import FieldDrift


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
class Turntable:
    """Non-magnetic three-axis turntable: inclination 0-180 deg, azimuth and
    toolface 0-360 deg (checked on the indicated pose; a trajectory may
    unwrap azimuth/toolface beyond 360 for continuous rotation)."""
    encoder: EncoderErrors = field(default_factory=EncoderErrors)
    geometry: Optional[TurntableGeometry] = None

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


@dataclass
class World:
    turntable: Turntable = field(default_factory=Turntable)
    earth: EarthField = field(default_factory=EarthField)
    gravity_g: float = 1.0
    temperature: Temperature = field(default_factory=Temperature)
    drift: Optional[FieldDrift] = None

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
        return g, b
