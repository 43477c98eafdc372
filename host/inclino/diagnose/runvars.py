"""The run's own variables (time, temperature, reading order, the angle of
each turntable or rig axis) set beside each other: what a drift, a
temperature effect and a rig effect could stand in for.  Read by the
pose-based diagnosis (analysis.py) and the pose-free one (posefree.py)."""
from __future__ import annotations

import numpy as np


def run_variable_confounds(d, min_r: float = 0.7) -> list:
    """The run's own variables set beside each other: time, temperature,
    reading order and the angle of each turntable axis that turns (as
    harmonics 1-2).  Pairs whose correlation (multiple correlation against
    an angle's harmonics) reaches min_r: what a time trend, a temperature
    effect and a rig effect would stand in for."""
    def z(x):
        x = np.asarray(x, float)
        s = x.std()
        return None if s <= 0 else (x - x.mean()) / s
    scal = {}
    if d.t is not None and np.ptp(d.t) > 0:
        scal["time"] = z(d.t)
    else:
        scal["reading order"] = z(np.arange(d.n))
    if d.temp is not None and np.ptp(d.temp) > 0:
        scal["temperature"] = z(d.temp)
    angles = {}
    for name, a in (("inclination axis", d.inc), ("azimuth axis", d.azi), ("toolface axis", d.tf)):
        if np.ptp(a) >= 1.0:
            r = np.radians(a)
            angles[name] = np.column_stack([np.cos(r), np.sin(r), np.cos(2 * r), np.sin(2 * r)])
    out = []
    names_ = list(scal)
    for i, a in enumerate(names_):
        for b in names_[i + 1:]:
            r = float(np.mean(scal[a] * scal[b]))
            if abs(r) >= min_r:
                out.append({"a": a, "b": b, "correlation": r})
    for a, x in scal.items():
        for b, H in angles.items():
            X = np.column_stack([np.ones(d.n), H])
            beta = np.linalg.lstsq(X, x, rcond=None)[0]
            r2 = 1.0 - float(np.sum((x - X @ beta) ** 2)) / float(np.sum(x ** 2))
            if r2 >= min_r ** 2:
                out.append({"a": a, "b": b + " angle", "correlation": float(np.sqrt(max(r2, 0.0)))})
    return out
