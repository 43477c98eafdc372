"""Acquisition plans a real bench could run, and emulated datasets with one
effect hidden in them (for the tests and `bench diagnose`).

* `oven_plan`: a few hundred static poses -- 48 quasi-uniform orientations,
  visited six times in a fresh order each pass, one reading a minute --
  while an oven cycles the probe between -5 and 55 degC (2.5 cycles over the
  run, so temperature and time are not confounded).
* `rotation_plan`: continuous rotations with time stamps -- at three
  inclinations and two azimuths the toolface turns once clockwise and once
  back, and at two inclinations the azimuth does the same, at 45 or 90
  deg/s, read at 10 Hz; room temperature.

The probe (`PROBE`) is the emulator's typical uncalibrated probe without the
effects the library can hide (its biases, scales, misalignment, hard and soft
iron, ADIS16210-level accelerometer noise 1.5e-4 g, fluxgate noise 5 nT,
quantisation), so that a null dataset is exactly the 12-parameter model plus
noise.  The turntable's readout error is 0.05 deg (1 sigma) on each of
inclination, azimuth and toolface, as in the calibration bench: the probe
sits at the indicated pose plus that error while the dataset records the
indicated pose (at a vertical pose a tilt either way:
`model.world.pose_in_range`; clipped at 0 instead, it was a real
inclination offset, which the diagnosis found in 3 of 54 nulls on Ren
2014's poses, 39 of whose 138 readings are vertical).

`hide(effect, sensor, axis, value)` puts one library effect into the
scenario through the emulator's own scenario tables (host/inclino/model/scenario.py),
with the emulator's parameter (the one the diagnosis estimates).  A field
drift (effects.FieldDrift, linear from t = 0) is set so that the field at
the run's mean time is the header's: the dataset's header holds the field a
reference measurement or model gives for the session, the drift is a trend
about it (a declination off the header's on average is the turntable's
azimuth offset: the two are one rotation)."""
from __future__ import annotations

import copy

import numpy as np

from inclino.calib import runs
from inclino.formats.dataset import RawDataset
from inclino.model.world import pose_in_range

from . import core

TURNTABLE_SIGMA_DEG = 0.05
ACC_SIGMA_G = 1.5e-4
MAG_SIGMA_NT = 5.0

PROBE = {
    "name": "diagnose-bench",
    "seed": 0,
    "world": {"field_nT": 50000.0, "dip_deg": 60.0, "declination_deg": 0.0, "gravity_g": 1.0,
              "temperature_c": 25.0},
    "acc": {"bias": {"value": [1.5e-3, -1.0e-3, 2.0e-3]}, "scale": {"value": [1.002, 0.998, 1.001]},
            "misalignment": {"angles_rad": [1.0e-3, -2.0e-3, 1.5e-3], "nonorth_rad": [0.5e-3, -0.8e-3, 0.3e-3]},
            "noise": {"sigma": [ACC_SIGMA_G] * 3}, "saturation": {"limit": 1.7}},
    "mag": {"bias": {"value": [150.0, -120.0, 300.0]}, "scale": {"value": [0.99, 1.01, 0.985]},
            "misalignment": {"angles_rad": [3.0e-3, -4.0e-3, 5.0e-3], "nonorth_rad": [2.0e-3, -1.5e-3, 2.5e-3]},
            "hard_iron": {"value": [200.0, -150.0, 80.0]},
            "soft_iron": {"matrix": [[1.005, 0.002, -0.001], [0.002, 0.997, 0.0015], [-0.001, 0.0015, 1.003]]},
            "noise": {"sigma": [MAG_SIGMA_NT] * 3}, "saturation": {"limit": 100000.0}},
}


def oven_plan(orientations: int = 48, passes: int = 6, dwell_s: float = 60.0, t_mean: float = 25.0,
              t_amp: float = 30.0, cycles: float = 2.5, seed: int = 0) -> dict:
    I, A, T = runs.multi_position(orientations)
    rng = np.random.default_rng([seed, 11])
    order = np.concatenate([rng.permutation(orientations) for _ in range(passes)])
    n = len(order)
    t = np.arange(n) * dwell_s
    temp = t_mean + t_amp * np.sin(2 * np.pi * cycles * t / (n * dwell_s))
    return {"kind": "static", "inc": I[order], "azi": A[order], "tf": T[order], "t_s": t, "temp_c": temp}


def rotation_plan(rates=(90.0, 45.0), sample_hz: float = 10.0, tf_poses=((45, 30), (90, 200), (135, 30)),
                  azi_incs=(60, 120), move_s: float = 3.0) -> dict:
    """Keyframes of a continuous run and its sample times (only while a
    rotation is under way)."""
    from inclino.model.world import Trajectory

    key = [(0.0, 45.0, 30.0, 0.0)]
    samples = []
    t = 0.0
    segs = [("tf", i, a) for i, a in tf_poses] + [("azi", i, 0.0) for i in azi_incs]
    for j, (what, inc, azi) in enumerate(segs):
        rate = rates[j % len(rates)]
        t += move_s  # move to the start pose (not read)
        key.append((t, inc, azi, 0.0))
        dur = 360.0 / rate
        for sgn in (1.0, -1.0):
            t0 = t
            t += dur
            if what == "tf":
                key.append((t, inc, azi, 360.0 if sgn > 0 else 0.0))
            else:
                key.append((t, inc, azi + (360.0 if sgn > 0 else 0.0), 0.0))
            k = np.arange(1, int(dur * sample_hz))
            samples.append(t0 + k / sample_hz)
    ts, inc, azi, tf = (np.array(c, float) for c in zip(*key))
    return {"kind": "continuous", "trajectory": Trajectory(ts, inc, azi, tf), "t_s": np.concatenate(samples),
            "temp_c": 25.0}


PLANS = {"static": oven_plan, "continuous": rotation_plan}


def rig_pattern(rng, axis: str) -> dict:
    """A random rig field of the axis (effects.RigField): N(0, 1) nT
    coefficients for harmonics 0-2 in the axis' frame (none at h = 0 for the
    azimuth axis: a constant world field is the Earth field's)."""
    from .forward import RIG_HARMONICS

    cos = rng.standard_normal((RIG_HARMONICS + 1, 3))
    sin = rng.standard_normal((RIG_HARMONICS + 1, 3))
    sin[0] = 0.0
    if axis == "azi":
        cos[0] = 0.0
    return {"axis": axis, "cos_nT": cos, "sin_nT": sin}


def rig_unabsorbed_rms(probe: dict, plan: dict, pattern: dict) -> float:
    """The RMS (nT, over the rows and fluxgate axes) of the pattern's reading
    change that the baseline cannot absorb on this plan (forward.unabsorbed):
    what the diagnosis reports as the rig field's size."""
    from inclino.model import effects as fx
    from inclino.model.scenario import scenario_from_dict

    from . import forward

    ds = generate(probe, plan, seed=0, sigma_pose_deg=0.0, noise=False)
    d = core.prepare(ds)
    s = scenario_from_dict(probe)
    A_mag, _ = s.mag.linear()
    rf = fx.RigField(pattern["axis"], pattern["cos_nT"], pattern["sin_nT"])
    Z = rf.apply(d.inc, d.azi, d.tf) @ A_mag.T
    return float(np.sqrt(np.mean(forward.unabsorbed(d, A_mag, s.world.earth.dip_deg, Z) ** 2)))


def unit_rig_pattern(probe: dict, plan: dict, axis: str, rng) -> dict:
    """A random rig field (rig_pattern) scaled so that what the baseline
    cannot absorb of it on this plan is 1 nT RMS: hide(..., value, pattern)
    then hides a field the diagnosis should report as `value` nT RMS."""
    pattern = rig_pattern(rng, axis)
    u = rig_unabsorbed_rms(probe, plan, pattern)
    return {k: (np.asarray(v) / u if k != "axis" else v) for k, v in pattern.items()}


def hide(probe: dict, effect: str, sensor: str, axis: str, value: float, pattern: dict | None = None) -> dict:
    """A copy of the scenario dict with one library effect of the given
    size (the emulator's parameter, in the diagnosis's units).  A rig field
    is `pattern` (rig_pattern) scaled by `value`."""
    d = copy.deepcopy(probe)
    if effect == "rig-field":
        if pattern is None:
            pattern = rig_pattern(np.random.default_rng(0), axis)
        d["world"].setdefault("rig_field", [])
        if isinstance(d["world"]["rig_field"], dict):
            d["world"]["rig_field"] = [d["world"]["rig_field"]]
        d["world"]["rig_field"].append({"axis": axis, "cos_nT": (value * np.asarray(pattern["cos_nT"])).tolist(),
                                        "sin_nT": (value * np.asarray(pattern["sin_nT"])).tolist()})
        return d
    if sensor in core.TRIADS:
        e = [0.0, 0.0, 0.0]
        if axis in core.AXES:
            e[core.AXES.index(axis)] = float(value)
        tab = d.setdefault(sensor, {})
        if effect == "temperature-bias":
            tab["bias_tempco"] = {"value": e, "t_ref_c": 25.0}
        elif effect == "temperature-scale":
            tab["scale_tempco"] = {"ppm": e, "t_ref_c": 25.0}
        elif effect == "scale-nonlinearity":
            tab["nonlinearity"] = {"k2": e}
        elif effect == "sample-skew":
            d.setdefault("timing", {})["mag_skew_s"] = float(value)
        else:
            raise KeyError(effect)
    elif effect in ("turntable-inclination-offset", "turntable-azimuth-offset"):
        # merged into the encoder table: both offsets can be hidden at once
        off = list(d["world"].setdefault("encoder", {}).get("offset_deg", [0.0, 0.0, 0.0]))
        off[0 if effect == "turntable-inclination-offset" else 1] = float(value)
        d["world"]["encoder"]["offset_deg"] = off
    elif effect in ("turntable-azimuth-axis-tilt", "turntable-inclination-axis-skew"):
        # world.TurntableGeometry: not (yet) a scenario-file table; generate() sets it
        kw = {"north": "tilt_north_deg", "east": "tilt_east_deg", "inc": "skew_deg"}[axis]
        d["world"].setdefault("turntable_geometry", {})[kw] = float(value)
    elif effect == "field-drift":
        kw = {"total": "rate_nT_per_s", "dip": "dip_rate_deg_per_s", "declination": "declination_rate_deg_per_s"}
        d["world"]["field_drift"] = {kw[axis]: float(value)}
    else:
        raise KeyError(effect)
    return d


def generate(probe: dict, plan: dict, seed: int, sigma_pose_deg: float = TURNTABLE_SIGMA_DEG,
             noise: bool = True) -> RawDataset:
    """The emulated dataset of `plan` for the scenario dict `probe`: the
    probe sits at the indicated pose plus the readout error, the pose
    columns record the indicated pose."""
    from inclino.model.scenario import generate_raw, scenario_from_dict

    p = copy.deepcopy(probe)
    p["seed"] = int(seed)
    if not noise:
        for tri in core.TRIADS:
            p[tri].pop("noise", None)
            p[tri]["quantise"] = False
    drift = p["world"].get("field_drift", {})
    t_mid = float(np.mean(plan["t_s"]))
    if drift:
        # the header holds the field at the run's mean time (what a reference
        # measurement or model for the session gives), the drift is about it
        w = p["world"]
        w["field_nT"] = w["field_nT"] - drift.get("rate_nT_per_s", 0.0) * t_mid
        w["dip_deg"] = w["dip_deg"] - drift.get("dip_rate_deg_per_s", 0.0) * t_mid
        w["declination_deg"] = w["declination_deg"] - drift.get("declination_rate_deg_per_s", 0.0) * t_mid
    geometry = p["world"].pop("turntable_geometry", None)
    s = scenario_from_dict(p)
    if geometry:
        from inclino.model.world import TurntableGeometry

        s.world.turntable.geometry = TurntableGeometry(**geometry)
    rng = np.random.default_rng([int(seed), 7])
    if plan["kind"] == "static":
        I, A, T = (np.asarray(plan[k], float) for k in ("inc", "azi", "tf"))
        e = rng.normal(0.0, sigma_pose_deg, (3, len(I))) if sigma_pose_deg > 0 else np.zeros((3, len(I)))
        # the true pose: indicated + readout error, written inside the turntable's range
        Ti, Ta, Tt = pose_in_range(I + e[0], A + e[1], T + e[2])
        ds = generate_raw(s, Ti, Ta, Tt, t_s=plan["t_s"], temp_c=plan["temp_c"], seed=int(seed))
        ds.columns["inc_deg"], ds.columns["azi_deg"], ds.columns["tf_deg"] = I.copy(), A.copy(), T.copy()
        ds.meta.update({k: probe["world"][k] for k in ("field_nT", "dip_deg", "declination_deg")})
        return ds
    ds = generate_raw(s, trajectory=plan["trajectory"], t_s=plan["t_s"], temp_c=plan["temp_c"], seed=int(seed))
    ds.meta.update({k: probe["world"][k] for k in ("field_nT", "dip_deg", "declination_deg")})
    n = len(ds)
    if sigma_pose_deg > 0:
        e = rng.normal(0.0, sigma_pose_deg, (3, n))
        ds.columns["inc_deg"] = np.clip(ds.columns["inc_deg"] - e[0], 0.0, 180.0)
        ds.columns["azi_deg"] = np.mod(ds.columns["azi_deg"] - e[1], 360.0)
        ds.columns["tf_deg"] = np.mod(ds.columns["tf_deg"] - e[2], 360.0)
    return ds



def true_baseline(probe: dict, plan: dict):
    """The plan's noise-free dataset under the probe's true linear
    calibration, and the diagnosis' baseline built at the truth:
    (prepared data, the triads' linear matrices, dip in degrees, the
    Baseline, its columns).  signature_z, rig_rms_stderr and the
    adaptive procedure's diagnosability floor all start here."""
    from inclino.model.scenario import scenario_from_dict

    ds = generate(probe, plan, seed=0, sigma_pose_deg=0.0, noise=False)
    d = core.prepare(ds)
    s = scenario_from_dict(probe)
    A, c = {}, {}
    for tri in core.TRIADS:
        A[tri], c[tri] = getattr(s, tri).linear()
    dip = s.world.earth.dip_deg
    G, B = core._truth(d, d.inc, d.azi, d.tf, dip)
    bl = core.Baseline(A, c, dip, G, B, core.pose_jacobian(d, A["acc"], A["mag"], dip))
    cols, _ = core.baseline_columns(d, bl)
    return d, A, dip, bl, cols


def true_noise(sigma_pose_deg: float = TURNTABLE_SIGMA_DEG):
    """The emulated probe's noise: each sensor's sigma with its LSB's
    quantisation (LSB^2/12) added, and the turntable's readout error."""
    return core.Noise(np.array([ACC_SIGMA_G] * 3 + [MAG_SIGMA_NT] * 3) * np.sqrt(1 + 1 / (12 * np.array(
        [(ACC_SIGMA_G * 16384) ** 2] * 3 + [MAG_SIGMA_NT ** 2] * 3))), np.full(3, sigma_pose_deg))

def signature_z(probe: dict, plan: dict, cand: core.Candidate, sigma_pose_deg: float = TURNTABLE_SIGMA_DEG,
                with_peak: bool = False, pattern: dict | None = None):
    """How many noise standard deviations one unit of the candidate's
    parameter is on this plan, once the baseline has absorbed what it can:
    the norm of its whitened regressor outside the baseline's span, under the
    true noise (the probe's sensor noise and the turntable's readout error).
    with_peak: also the largest change of any reading per unit, in that
    channel's sensor noise sigmas."""
    d, A, dip, bl, cols = true_baseline(probe, plan)
    if cand.name == "rig-field":  # the pattern's reading change per unit of the pattern
        from inclino.model import effects as fx

        pattern = pattern or rig_pattern(np.random.default_rng(0), cand.axis)
        reg = np.zeros((d.n, 6))
        reg[:, 3:] = fx.RigField(cand.axis, pattern["cos_nT"], pattern["sin_nT"]).apply(d.inc, d.azi, d.tf) @ A["mag"].T
    else:
        reg = core.regressor(d, bl, cand)
    X = np.stack(cols + [reg], -1)
    noise = true_noise(sigma_pose_deg)
    des = core.Design(np.zeros((d.n, 6)), X, noise.whitener(bl.Jpose), np.zeros(d.n, int), 1)
    k = X.shape[-1] - 1
    z = float(des.colscale[k] * des.separability(list(range(k)), k))
    if with_peak:
        return z, float(np.abs(X[:, :, k] / noise.sigma).max())
    return z


def rig_rms_stderr(probe: dict, plan: dict, pattern: dict, value: float,
                   sigma_pose_deg: float = TURNTABLE_SIGMA_DEG) -> float:
    """The standard error (nT) of a rig field's unabsorbed RMS
    (rig_unabsorbed_rms) that the plan allows, from the truth: the
    delta method on the RMS of `value` x `pattern`, with the covariance of
    the field's full harmonic coefficients fitted beside the 12-parameter
    baseline under the true noise (sensor noise and the turntable's readout
    error).  signature_z says how far the field is above the detection
    limit; this says how well its size in nT can be known, which is worse
    by up to the ratio of the noise across the magnetic meridian (an
    azimuth readout error of 0.05 deg moves the field ~20 nT) to the
    fluxgate's own (5 nT) when the field lies there."""
    from . import forward

    d, A, dip, bl, cols = true_baseline(probe, plan)
    axis = pattern["axis"]
    F = np.einsum("ij,njp->nip", A["mag"], forward.rig_full(d, axis))  # (n, 3, P)
    theta = np.concatenate([value * np.asarray(pattern[f"{kind}_nT"], float)[h]
                            for h, kind in forward.rig_terms(axis)])
    Fr = forward.unabsorbed(d, A["mag"], dip, F)
    Q = np.einsum("nip,niq->pq", Fr, Fr) / (3 * d.n)
    a = float(np.sqrt(theta @ Q @ theta))
    Xf = np.zeros((d.n, 6, F.shape[-1]))
    Xf[:, 3:] = F
    X = np.concatenate([np.stack(cols, -1), Xf], -1)
    noise = true_noise(sigma_pose_deg)
    Xw = np.einsum("nij,njp->nip", noise.whitener(bl.Jpose), X).reshape(-1, X.shape[-1])
    sc = np.sqrt((Xw ** 2).sum(0))
    sc[sc == 0] = 1.0
    cov = np.linalg.pinv((Xw / sc).T @ (Xw / sc), rcond=1e-12, hermitian=True) / np.outer(sc, sc)
    nb = len(cols)
    S = cov[nb:, nb:]
    QS = Q @ S
    # RMS^2 = theta' Q theta: its variance 4 theta'QSQ theta + 2 tr(QSQS) (Gaussian), through d RMS = d RMS^2 / 2a
    return float(np.sqrt(max(theta @ QS @ Q @ theta + 0.5 * float(np.trace(QS @ QS)), 0.0)) / a)


def _oven_temperature(n, dwell_s=60.0, t_mean=25.0, t_amp=30.0, cycles=2.5):
    t = np.arange(n) * dwell_s
    return t, t_mean + t_amp * np.sin(2 * np.pi * cycles * t / (n * dwell_s))


def li_grid_plan(seed: int = 0, toolfaces=(0.0, 90.0, 180.0, 270.0)) -> dict:
    """Li 2021's check grid (inclination 2-90 deg, azimuth every 60 deg) at
    four toolfaces, in a fresh order, one reading a minute in the cycling
    oven: the grid a user of the paper's procedure would have."""
    I, A, T = runs.li2021_grid(toolfaces)
    order = np.random.default_rng([seed, 12]).permutation(len(I))
    t, temp = _oven_temperature(len(I))
    return {"kind": "static", "inc": I[order], "azi": A[order], "tf": T[order], "t_s": t, "temp_c": temp}


def ren_grid_plan(seed: int = 0, passes: int = 3) -> dict:
    """Ren 2014's calibration poses (ten tilts and three circles every 30
    deg), `passes` times in a fresh order, one reading a minute in the
    cycling oven."""
    I, A, T = runs.ren2014()
    rng = np.random.default_rng([seed, 13])
    order = np.concatenate([rng.permutation(len(I)) for _ in range(passes)])
    t, temp = _oven_temperature(len(order))
    return {"kind": "static", "inc": I[order], "azi": A[order], "tf": T[order], "t_s": t, "temp_c": temp}


GRID_PLANS = {"li-grid": li_grid_plan, "ren-grid": ren_grid_plan}


def add_noise(ds: RawDataset, rng, acc_sigma: float, mag_sigma: float, dist: str = "gauss", df: float = 3.0):
    """Add white sensor noise of standard deviation acc_sigma (g) and
    mag_sigma (nT) to a noise-free dataset, Gaussian or Student-t with df
    degrees of freedom (heavy tails, scaled to the same standard
    deviation)."""
    n = len(ds)
    for cols, s in ((("ax_g", "ay_g", "az_g"), acc_sigma), (("mx_nT", "my_nT", "mz_nT"), mag_sigma)):
        for c in cols:
            if dist == "t":
                e = rng.standard_t(df, n) / np.sqrt(df / (df - 2.0))
            else:
                e = rng.standard_normal(n)
            ds.columns[c] = np.asarray(ds.columns[c], float) + s * e
    return ds


def add_outlier_rows(ds: RawDataset, rng, fraction: float = 0.01, size_sigma=(10.0, 40.0),
                     acc_sigma: float = ACC_SIGMA_G, mag_sigma: float = MAG_SIGMA_NT) -> list:
    """Spike `fraction` of the rows (at least one): one random channel each,
    by a random size_sigma x that sensor's noise, random sign (a knock on
    the table, a settling window cut short).  Returns [(row, channel,
    size in the sensor's sigma)]."""
    n = len(ds)
    k = max(1, int(round(fraction * n)))
    rows = rng.choice(n, k, replace=False)
    names = ("ax_g", "ay_g", "az_g", "mx_nT", "my_nT", "mz_nT")
    out = []
    for r in rows:
        ch = int(rng.integers(6))
        z = float(rng.uniform(*size_sigma)) * (1.0 if rng.random() < 0.5 else -1.0)
        col = np.asarray(ds.columns[names[ch]], float).copy()
        col[r] += z * (acc_sigma if ch < 3 else mag_sigma)
        ds.columns[names[ch]] = col
        out.append((int(r), core.CHANNELS[ch], z))
    return out
