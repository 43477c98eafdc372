"""The run's own variables (time, temperature, reading order, the angle of
each turntable or rig axis) set beside each other: what a drift, a
temperature effect and a rig effect could stand in for.  Read by the
pose-based diagnosis (analysis.py) and the pose-free one (posefree.py)."""
from __future__ import annotations

import numpy as np

from inclino.holds import setting_starts


# each turntable axis (a rig field's axis key) and the run variable its angle is named as
AXIS_VARIABLES = {"inc": "inclination axis angle", "azi": "azimuth axis angle", "tf": "toolface axis angle"}


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
    for axis, name in AXIS_VARIABLES.items():
        a = getattr(d, axis)
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
                out.append({"a": a, "b": b, "correlation": float(np.sqrt(max(r2, 0.0)))})
    return out


class _PoseRunVars:
    """The run's variables per setting of the pose (consecutive rows at one
    indicated pose, calib.covariance's clusters; partial poses such as a
    face label count too): what run_variable_confounds reads."""

    def __init__(self, ds):
        cols = ds.columns
        self.new = new = setting_starts(ds)
        self.lab = lab = np.cumsum(new) - 1
        self.n = int(lab.max()) + 1
        cnt = np.bincount(lab, minlength=self.n).astype(float)

        def mean(x):
            return np.bincount(lab, weights=np.asarray(x, float), minlength=self.n) / cnt
        t = cols.get("t_s")
        self.t = mean(t) if t is not None and np.ptp(t) > 0 else None
        temp = cols.get("temp_c")
        self.temp = mean(temp) if temp is not None and np.ptp(temp) > 0 else None
        first = np.flatnonzero(new)
        z = np.zeros(self.n)
        self.inc, self.azi, self.tf = (np.asarray(cols[c], float)[first] if c in cols else z
                                       for c in ("inc_deg", "azi_deg", "tf_deg"))


def pose_order_confounds(ds, min_r: float = 0.7) -> list:
    """On a log with poses (or face labels), each setting of the pose once:
    the run's variables against the pose angles (run_variable_confounds).
    Faces recorded one after the other make time a function of the pose:
    a drift over the session and an error that depends on the pose then
    fit the settings' means alike."""
    if not any(c in ds.columns for c in ("inc_deg", "azi_deg", "tf_deg")):
        return []
    d = _PoseRunVars(ds)
    if d.n < 3:
        return []
    return run_variable_confounds(d, min_r)


def drift_pose_confounds(ds, min_settings: int = 3, min_r: float = 0.7) -> list:
    """One triad read at a few settings of the pose, each once (a six-face
    session): per axis, how far a drift of its bias over the session can
    be told from an error that depends on the pose, on the settings' mean
    readings.  The triad's own 12 parameters (a 3x3 and an offset) take
    what they can of each; of the drift's remainder, the correlation with
    the axis's scale nonlinearity (raw += k2 x^2), listed from min_r.  With
    each setting read once, time is a function of the pose: a drift fits
    the settings' means as some pose-dependent error does."""
    if not any(c in ds.columns for c in ("inc_deg", "azi_deg", "tf_deg")) or "t_s" not in ds.columns:
        return []
    d = _PoseRunVars(ds)
    if d.n < min_settings or d.t is None:
        return []
    out = []
    cols = ds.columns
    P = np.stack([np.asarray(cols[c], float) for c in ("inc_deg", "azi_deg", "tf_deg") if c in cols], -1)
    new, lab = d.new, d.lab
    cnt = np.bincount(lab).astype(float)
    # a pose set again later is the same pose: distinct poses against settings
    distinct = len(np.unique(np.round(P[new], 3), axis=0))
    for tri, names in (("acc", ("ax_g", "ay_g", "az_g")), ("mag", ("mx_nT", "my_nT", "mz_nT"))):
        if not all(c in cols for c in names):
            continue
        x = np.column_stack([np.bincount(lab, weights=np.asarray(cols[c], float)) / cnt for c in names])
        u = x / np.linalg.norm(x, axis=1, keepdims=True)
        B = np.column_stack([np.ones(d.n), u])
        Q, _ = np.linalg.qr(B)
        def res(v):
            return v - Q @ (Q.T @ v)
        tau = res(d.t - d.t.mean())
        if np.linalg.norm(tau) <= 1e-9 * max(np.linalg.norm(d.t - d.t.mean()), 1e-300):
            continue
        for j, ax in enumerate("xyz"):
            nl = res((x[:, j] - x[:, j].mean()) ** 2)
            r = float(abs(tau @ nl) / max(np.linalg.norm(tau) * np.linalg.norm(nl), 1e-300))
            if r < min_r:
                continue
            out.append({"effect": f"drift of the {tri} {ax} bias over the session",
                        "with": f"scale-nonlinearity:{tri}:{ax}", "correlation": r,
                        "settings": d.n, "distinct_poses": distinct,
                        "separate_by": "read the poses in a random order, or read the first pose again at the end "
                                       "(time then stops being a function of the pose)"})
        if distinct == d.n:
            out.append({"effect": f"drift of the {tri} biases over the session", "with": "the pose order",
                        "correlation": 1.0, "settings": d.n, "distinct_poses": distinct,
                        "separate_by": "read the first pose again at the end, or the poses in a random order and "
                                       "more than once: with each pose read once, time is a function of the pose"})
    return out
