"""Scenarios: a world plus a probe's sensor truth, read from TOML, and the
raw datasets they generate.

A scenario file (host/inclino/model/scenarios/*.toml) looks like::

    name = "typical"
    seed = 1234                      # every random draw derives from it
    [world]
    field_nT = 50000.0               # or lat_deg/lon_deg/date[/alt_km] -> IGRF
    dip_deg = 60.0
    declination_deg = 0.0
    gravity_g = 1.0
    temperature_c = 25.0
    temperature_rate_c_per_s = 0.0
    [world.chamber]                  # optional thermal chamber (world.Chamber)
    temperature_c = 25.0             # air and probe at the start
    tau_s = 300.0                    # the probe's thermal time constant
    profile = [[60.0, 55.0, 1.0]]    # [t_s, setpoint_c, rate_c_per_min (absent: step)]
    [world.turntable]                # optional: how long a move takes (world.TurntableMotion;
    rate_deg_s = 10.0                # default instantaneous); each axis, all three together,
    settle_s = 3.0                   # then at rest
    [world.encoder]                  # optional turntable encoder errors
    offset_deg = [0.0, 0.0, 0.0]     # inc, azi, tf
    scale = [0.0, 0.0, 0.0]
    [world.field_drift]              # optional (effects.FieldDrift)
    rate_nT_per_s = 0.0
    [world.rig_field]                # optional (effects.RigField; [[world.rig_field]] for several)
    axis = "inc"                     # the turntable axis it moves with: azi, inc, tf
    cos_nT = [[0.0, 0.0, 0.0], [300.0, 0.0, -150.0]]   # per harmonic 0, 1, ... in that axis' frame
    sin_nT = [[0.0, 0.0, 0.0], [0.0, 120.0, 0.0]]
    [acc.bias]                       # one table per effect, any subset
    value = [0.001, 0.0, 0.0]        # g
    [mag.hard_iron]
    value = [200.0, 0.0, 0.0]        # nT
    [timing]
    mag_skew_s = 0.0                 # effects.SamplingSkew

Effect tables of a triad (units: g for acc, nT for mag):
bias.value, scale.value, misalignment.matrix | misalignment.angles_rad
(rx, ry, rz) + misalignment.nonorth_rad (nxy, nxz, nyz), hard_iron.value,
soft_iron.matrix, bias_tempco.value (+ value2 per degC^2, t_ref_c,
spread, spread2), scale_tempco.ppm (+ ppm2, t_ref_c, spread, spread2),
nonlinearity.k2, noise.sigma (+ n_ref), saturation.limit,
li2021 {K, B_counts, e} (effects.from_li2021).  Quantisation is always on
(nominal LSB and register rails of the part); `quantise = false` in the
triad table turns it off.
"""
from __future__ import annotations

import tomllib
from dataclasses import dataclass, field
from importlib import resources
from pathlib import Path
from typing import Optional

import numpy as np

from inclino.engines import reference as ref
from inclino.formats.dataset import RawDataset

from inclino.model import effects as fx
from inclino.model.world import (Chamber, EarthField, EncoderErrors, Temperature, Trajectory, Turntable,
                                 TurntableMotion, World)

ACC_RANGE_G = 1.7  # ADIS16210 specified measurement range
MAG_RANGE_NT = 100000.0  # fluxgate range (Ren 2014)
DEFAULT_TAU_S = 300.0  # the probe's thermal time constant when the scenario gives none (model)


def default_quantisation(kind):
    if kind == "acc":
        return fx.Quantisation(ref.ACC_LSB_G, ref.ACC_RAW_MIN, ref.ACC_RAW_MAX)
    return fx.Quantisation(ref.MAG_LSB_NT, ref.MAG_RAW_MIN, ref.MAG_RAW_MAX)


@dataclass
class Scenario:
    name: str
    seed: int
    world: World
    acc: fx.TriadModel
    mag: fx.TriadModel
    mag_skew: fx.SamplingSkew = field(default_factory=fx.SamplingSkew)
    description: str = ""
    serial: int = 1
    meta: dict = field(default_factory=dict)  # lat/lon/date for the dataset header
    # triad -> {"bias_tempco" | "scale_tempco": (spread (3,), spread2 (3,))}: the
    # standard deviations over probes of the tempco coefficients (draw_tempcos)
    tempco_spread: dict = field(default_factory=dict)

    def probe(self, seed: Optional[int] = None) -> "Probe":
        return Probe(self, self.seed if seed is None else seed)

    def draw_tempcos(self, seed: int) -> "Scenario":
        """A copy whose tempcos are one probe drawn from the scenario's
        spread: each coefficient = the scenario's value + spread x N(0, 1)
        (first and second order, per axis; numpy.random.default_rng([seed,
        7])).  Triads or tempcos without a spread keep their values; a
        tempco with a spread but absent from the scenario is drawn about 0."""
        import copy

        out = copy.deepcopy(self)
        rng = np.random.default_rng([int(seed), 7])
        for tri in ("acc", "mag"):
            model = getattr(out, tri)
            for name, (s1, s2) in sorted(self.tempco_spread.get(tri, {}).items()):
                z1, z2 = rng.standard_normal(3), rng.standard_normal(3)
                if name == "bias_tempco":
                    e = model.bias_tempco or fx.BiasTempco()
                    model.bias_tempco = fx.BiasTempco(e.c + s1 * z1, e.t_ref_c, e.c2 + s2 * z2)
                else:
                    e = model.scale_tempco or fx.ScaleTempco()
                    model.scale_tempco = fx.ScaleTempco(e.ppm + s1 * z1, e.t_ref_c, e.ppm2 + s2 * z2)
        out.description = f"{self.description} (tempcos drawn, seed {int(seed)})".strip()
        return out


class Probe:
    """The physical probe in the world: sensor truth for the register-level
    models and the dataset generator.

    Two independent random streams (accelerometer, fluxgate) are derived
    from the seed, so the order in which a driver reads the parts does not
    change either part's noise sequence.  Both are `effects.NormalStream`s
    over `np.random.default_rng([seed, 0])` / `([seed, 1])`: the same draws
    as the generators, taken in blocks.

    Single samples (`acc_sample`, `mag_sample`: scalar time, tuples of
    floats) are what the register models read; they give the same numbers
    as `acc_analog` / `mag_analog`, cheaply: while the turntable is static
    (a one-keyframe trajectory, e.g. after `move_to`) the true vectors are
    computed once, and the deterministic part of each triad's chain (up to
    the bias tempco) is kept for the last temperature; only the noise and
    the saturation are evaluated per sample, as plain floats.  The cache
    follows `move_to`, `trajectory` assignments and the temperature (a
    temperature ramp re-evaluates the chain at every sample); a field drift
    or a moving trajectory re-evaluates the truth at every sample.  After
    changing the scenario's world or effect parameters in place, call
    `invalidate()`."""

    def __init__(self, scenario: Scenario, seed: int):
        self.scenario = scenario
        self.seed = int(seed)
        self.rng_acc = fx.NormalStream(np.random.default_rng([self.seed, 0]))
        self.rng_mag = fx.NormalStream(np.random.default_rng([self.seed, 1]))
        self.trajectory = Trajectory.static(0.0, 0.0, 0.0)
        self.temp_override: Optional[float] = None

    # ---- control ----------------------------------------------------------
    @property
    def trajectory(self) -> Trajectory:
        return self._trajectory

    @trajectory.setter
    def trajectory(self, tr: Trajectory):
        self._trajectory = tr
        self.invalidate()

    def invalidate(self):
        """Forget the cached truth and chain values (see the class doc)."""
        self._g_static = None        # true g (3,) array while static
        self._b_static = None        # true b (3,) array while static and drift-free
        self._acc_det = (None, None)  # (temperature, 3 floats): deterministic chain output
        self._mag_det = (None, None)
        self._acc_head = self._mag_head = None  # TriadModel.head of the static truth, 3 floats
        self._acc_tail = self._mag_tail = None  # TriadModel.tail3 of each chain
        self._acc_rand = {}           # n_avg -> TriadModel.sampler (noise, saturation)
        self._mag_rand = None

    def move_to(self, inc, azi, tf):
        """Put the turntable at an indicated pose (instantaneous move)."""
        self.scenario.world.turntable.check(inc, azi, tf)
        self.trajectory = Trajectory.static(inc, azi, tf)

    def set_temperature(self, temp_c: Optional[float]):
        """Hold the probe at temp_c (None: back to the scenario's model)."""
        self.temp_override = temp_c

    def chamber(self, t_now: float, tau_s: Optional[float] = None) -> Chamber:
        """The thermal chamber around the probe.  A scenario without one
        ([world.chamber]) gets one now, at the probe's temperature at t_now,
        with tau_s (default DEFAULT_TAU_S); a held temperature
        (set_temperature) is released, the chamber drives the probe."""
        w = self.scenario.world
        if not isinstance(w.temperature, Chamber):
            w.temperature = Chamber(self.temperature(float(t_now)),
                                    DEFAULT_TAU_S if tau_s is None else tau_s, t0_s=float(t_now))
        self.temp_override = None
        return w.temperature

    def temperature(self, t):
        """Probe temperature at t (degC); a float for a float t."""
        if type(t) is float:
            if self.temp_override is not None:
                return float(self.temp_override)
            return self.scenario.world.temperature.at(t)   # the same operations as __call__
        if self.temp_override is not None:
            return np.broadcast_to(float(self.temp_override), np.shape(t)).astype(float)
        return self.scenario.world.temperature(t)

    # ---- truth ------------------------------------------------------------
    def true_acc(self, t):
        g, _ = self.scenario.world.truth(*self.trajectory(t), t)
        return g

    def true_mag(self, t):
        """True field at the fluxgate's sampling instant (t + skew)."""
        ts = self.scenario.mag_skew.apply(t)
        _, b = self.scenario.world.truth(*self.trajectory(ts), ts)
        return b

    def _static(self) -> bool:
        return len(self._trajectory.t_s) == 1

    def _acc_chain(self, t, temp):
        """Deterministic accelerometer chain output at t, 3 floats: the
        chain's head (TriadModel.head) on NumPy, kept while static, and its
        temperature-dependent tail on floats (TriadModel.tail3)."""
        key, y = self._acc_det
        if key is not None and key == temp:
            return y
        if self._acc_tail is None:
            self._acc_tail = self.scenario.acc.tail3()
        if self._static():
            if self._acc_head is None:
                self._g_static = self.true_acc(t)
                self._acc_head = tuple(self.scenario.acc.head(self._g_static).tolist())
            y = self._acc_tail(self._acc_head, temp)
            self._acc_det = (temp, y)
            return y
        return self._acc_tail(tuple(self.scenario.acc.head(self.true_acc(t)).tolist()), temp)

    def _mag_chain(self, t, temp):
        key, y = self._mag_det
        if key is not None and key == temp:
            return y
        if self._mag_tail is None:
            self._mag_tail = self.scenario.mag.tail3()
        if self._static() and self.scenario.world.drift is None:
            if self._mag_head is None:
                self._b_static = self.true_mag(t)
                self._mag_head = tuple(self.scenario.mag.head(self._b_static).tolist())
            y = self._mag_tail(self._mag_head, temp)
            self._mag_det = (temp, y)
            return y
        return self._mag_tail(tuple(self.scenario.mag.head(self.true_mag(t)).tolist()), temp)

    # ---- analog sensor outputs (all effects but quantisation) -------------
    def _sample_temp(self, t: float, temp_c=None) -> float:
        """The temperature a single sample sees: the caller's, else the held
        one, else the scenario's ramp at t."""
        if temp_c is not None:
            return temp_c
        if self.temp_override is not None:
            return float(self.temp_override)
        return self.scenario.world.temperature.at(float(t))

    def acc_sample(self, t: float, n_avg=None, temp_c=None):
        """One accelerometer sample at time t (float seconds): 3 floats, g."""
        temp = self._sample_temp(t, temp_c)
        key, y = self._acc_det
        if key is None or key != temp:
            y = self._acc_chain(t, temp)
        f = self._acc_rand.get(n_avg)
        if f is None:
            f = self._acc_rand[n_avg] = self.scenario.acc.sampler(self.rng_acc, n_avg)
        return f(y)

    def mag_sample(self, t: float, temp_c=None):
        """One fluxgate sample at time t (the skew applied inside): 3 floats, nT."""
        temp = self._sample_temp(t, temp_c)
        key, y = self._mag_det
        if key is None or key != temp:
            y = self._mag_chain(t, temp)
        f = self._mag_rand
        if f is None:
            f = self._mag_rand = self.scenario.mag.sampler(self.rng_mag, None)
        return f(y)

    def acc_analog(self, t, n_avg=None, temp_c=None):
        if np.ndim(t) == 0 and np.ndim(temp_c) == 0:
            return np.array(self.acc_sample(float(t), n_avg, temp_c))
        temp = self.temperature(t) if temp_c is None else temp_c
        return self.scenario.acc.apply(self.true_acc(t), temp, self.rng_acc, n_avg, quantise=False)

    def mag_analog(self, t, temp_c=None):
        if np.ndim(t) == 0 and np.ndim(temp_c) == 0:
            return np.array(self.mag_sample(float(t), temp_c))
        temp = self.temperature(t) if temp_c is None else temp_c
        return self.scenario.mag.apply(self.true_mag(t), temp, self.rng_mag, None, quantise=False)


# --------------------------------------------------------------------------
# TOML loading
def _tempco_spread(sub: dict, n1: str, n2: str):
    """(spread of the first-order coefficient, of the second-order one), or None."""
    if "spread" not in sub and "spread2" not in sub:
        return None
    s1, s2 = fx._vec3(sub.get("spread", 0.0), n1), fx._vec3(sub.get("spread2", 0.0), n2)
    if np.any(s1 < 0) or np.any(s2 < 0) or not np.all(np.isfinite(np.r_[s1, s2])):
        raise ValueError(f"tempco spreads must be finite and >= 0 ({n1}, {n2})")
    return s1, s2


def _triad(kind, tab: dict, spreads: Optional[dict] = None) -> fx.TriadModel:
    tab = dict(tab or {})
    spreads = {} if spreads is None else spreads
    kw = {}
    quantise = tab.pop("quantise", True)
    if "li2021" in tab:
        li = tab.pop("li2021")
        lsb = ref.ACC_LSB_G if kind == "acc" else ref.MAG_LSB_NT
        base = fx.from_li2021(li["K"], li["B_counts"], li["e"], lsb)
        kw.update(misalignment=base.misalignment, scale=base.scale, bias=base.bias)
    for key, sub in tab.items():
        if key == "bias":
            kw["bias"] = fx.Bias(sub["value"])
        elif key == "scale":
            kw["scale"] = fx.Scale(sub["value"])
        elif key == "misalignment":
            if "matrix" in sub:
                kw["misalignment"] = fx.Misalignment(sub["matrix"])
            else:
                kw["misalignment"] = fx.Misalignment.from_small_angles(
                    *sub.get("angles_rad", (0.0, 0.0, 0.0)), nonorth=sub.get("nonorth_rad", (0.0, 0.0, 0.0)))
        elif key == "hard_iron":
            kw["hard_iron"] = fx.HardIron(sub["value"])
        elif key == "soft_iron":
            kw["soft_iron"] = fx.SoftIron(sub["matrix"])
        elif key == "bias_tempco":
            kw["bias_tempco"] = fx.BiasTempco(sub.get("value", 0.0), sub.get("t_ref_c", 25.0),
                                              sub.get("value2", 0.0))
            sp = _tempco_spread(sub, f"{kind}.bias_tempco.spread", f"{kind}.bias_tempco.spread2")
            if sp is not None:
                spreads["bias_tempco"] = sp
        elif key == "scale_tempco":
            kw["scale_tempco"] = fx.ScaleTempco(sub.get("ppm", 0.0), sub.get("t_ref_c", 25.0),
                                                sub.get("ppm2", 0.0))
            sp = _tempco_spread(sub, f"{kind}.scale_tempco.spread", f"{kind}.scale_tempco.spread2")
            if sp is not None:
                spreads["scale_tempco"] = sp
        elif key == "nonlinearity":
            kw["nonlinearity"] = fx.ScaleNonlinearity(sub["k2"])
        elif key == "noise":
            kw["noise"] = fx.WhiteNoise(sub["sigma"], int(sub.get("n_ref", 1)))
        elif key == "saturation":
            kw["saturation"] = fx.Saturation.symmetric(sub["limit"])
        else:
            raise ValueError(f"unknown {kind} effect [{kind}.{key}]")
    if kind == "acc" and ("soft_iron" in kw or "hard_iron" in kw):
        raise ValueError("hard/soft iron are fluxgate effects")
    if quantise:
        kw["quantisation"] = default_quantisation(kind)
    return fx.TriadModel(**kw)


def _motion(t: dict) -> TurntableMotion:
    bad = set(t) - {"rate_deg_s", "settle_s"}
    if bad:
        raise ValueError(f"unknown [world.turntable] key(s) {', '.join(sorted(bad))} (rate_deg_s, settle_s)")
    return TurntableMotion(**{k: float(v) for k, v in t.items()})


def _rig_tables(v) -> list:
    """[world.rig_field] (one table) or [[world.rig_field]] (several): each
    axis = "azi" | "inc" | "tf", cos_nT = [[x, y, z], ...] and sin_nT the
    same, nT per harmonic 0, 1, ... (effects.RigField)."""
    if v is None:
        return []
    return [v] if isinstance(v, dict) else list(v)


def scenario_from_dict(d: dict, name: str = "") -> Scenario:
    w = dict(d.get("world", {}))
    if "lat_deg" in w and "lon_deg" in w and "date" in w:
        earth = EarthField.from_igrf(w["lat_deg"], w["lon_deg"], str(w["date"]), w.get("alt_km", 0.0))
        # explicit values still win (e.g. Li 2021's measured dip)
        for k in ("field_nT", "dip_deg", "declination_deg"):
            if k in w:
                setattr(earth, k, float(w[k]))
                earth.source += f"; {k} overridden"
    else:
        earth = EarthField(float(w.get("field_nT", 50000.0)), float(w.get("dip_deg", 60.0)),
                           float(w.get("declination_deg", 0.0)))
    enc = w.get("encoder", {})
    drift = w.get("field_drift")
    ch = w.get("chamber")
    if ch is not None:
        temperature = Chamber(float(ch.get("temperature_c", w.get("temperature_c", 25.0))),
                              float(ch.get("tau_s", DEFAULT_TAU_S)))
        for item in ch.get("profile", []):
            if len(item) not in (2, 3):
                raise ValueError("[world.chamber] profile items are [t_s, setpoint_c] or "
                                 "[t_s, setpoint_c, rate_c_per_min]")
            temperature.set(float(item[0]), float(item[1]), None if len(item) == 2 else float(item[2]))
    else:
        temperature = Temperature(float(w.get("temperature_c", 25.0)), float(w.get("temperature_rate_c_per_s", 0.0)))
    world = World(
        turntable=Turntable(EncoderErrors(enc.get("offset_deg", [0.0] * 3), enc.get("scale", [0.0] * 3)),
                            motion=_motion(w.get("turntable", {}))),
        earth=earth,
        gravity_g=float(w.get("gravity_g", 1.0)),
        temperature=temperature,
        drift=fx.FieldDrift(**drift) if drift else None,
        rig_fields=[fx.RigField(str(r.get("axis", "inc")), r.get("cos_nT", [[0.0] * 3]), r.get("sin_nT", [[0.0] * 3]))
                    for r in _rig_tables(w.get("rig_field"))],
    )
    spreads = {"acc": {}, "mag": {}}
    meta = {k: w[k] for k in ("lat_deg", "lon_deg") if k in w}
    if "date" in w:
        meta["date"] = str(w["date"])
    return Scenario(
        name=d.get("name", name),
        seed=int(d.get("seed", 0)),
        world=world,
        acc=_triad("acc", d.get("acc"), spreads["acc"]),
        mag=_triad("mag", d.get("mag"), spreads["mag"]),
        mag_skew=fx.SamplingSkew(float(d.get("timing", {}).get("mag_skew_s", 0.0))),
        description=d.get("description", ""),
        serial=int(d.get("serial", 1)),
        meta=meta,
        tempco_spread={k: v for k, v in spreads.items() if v},
    )


def builtin_scenarios():
    """Names of the scenarios shipped in host/inclino/model/scenarios/."""
    return sorted(p.name[:-5] for p in resources.files("inclino.model").joinpath("scenarios").iterdir()
                  if p.name.endswith(".toml"))


def load_scenario(path_or_name) -> Scenario:
    """Load a scenario from a TOML path, or a built-in one by name
    ("ideal", "typical", "li2021").  The file is read with bounds
    (inclino.formats.safeio) and every table and field checked by its rule
    (inclino.model.scenario_rules) before the scenario is built: one
    DataError line naming the file and the field."""
    from inclino.errors import DataError
    from inclino.formats import safeio
    from inclino.model.scenario_rules import check_scenario

    p = Path(str(path_or_name))
    if p.suffix == ".toml" or p.exists():
        where = f"scenario {p}"
        text = safeio.read_text(str(p), "scenario", 4 * 2**20)
        name = p.stem
    else:
        res = resources.files("inclino.model").joinpath("scenarios", f"{path_or_name}.toml")
        if not res.is_file():
            raise FileNotFoundError(f"no scenario {path_or_name!r} (built-in: {', '.join(builtin_scenarios())})")
        text = res.read_text(encoding="utf-8")
        name = str(path_or_name)
        where = f"scenario {name}"
    try:
        d = tomllib.loads(text)
    except tomllib.TOMLDecodeError as e:
        raise DataError(f"{where}: not TOML ({str(e)[:80]})") from None
    except ValueError:  # a number tomllib cannot convert (an integer of thousands of digits)
        raise DataError(f"{where}: not TOML (a number out of range)") from None
    except RecursionError:
        raise DataError(f"{where}: nests too deep") from None
    check_scenario(d, where)
    try:
        return scenario_from_dict(d, name)
    except (ValueError, TypeError, KeyError, ArithmeticError) as e:  # a rule the checks above do not state
        raise DataError(f"{where}: {str(e)[:100]}") from None


# --------------------------------------------------------------------------
# Raw datasets
def generate_raw(scenario: Scenario, inc=None, azi=None, tf=None, t_s=None, temp_c=None,
                 trajectory: Optional[Trajectory] = None, seed: Optional[int] = None,
                 acc_n_avg=None) -> RawDataset:
    """A raw dataset (inclino.formats.dataset format) for a list of indicated poses.

    Either give the poses (inc, azi, tf arrays; each row a static pose,
    t_s default 0, 1, 2... s) or a `trajectory` plus the sample times t_s
    (continuous rotation; the fluxgate samples at t + mag_skew_s).  temp_c
    (per row or scalar) overrides the scenario's temperature model.  Sensor
    columns are quantised counts x nominal LSB, as the firmware reports.
    The same scenario, seed and inputs give the same dataset, bit for bit."""
    probe = scenario.probe(seed)
    if trajectory is None:
        inc, azi, tf = (np.atleast_1d(np.asarray(a, float)) for a in (inc, azi, tf))
        n = len(inc)
        t = np.arange(n, dtype=float) if t_s is None else np.broadcast_to(np.asarray(t_s, float), (n,))
        scenario.world.turntable.check(inc, azi, tf)
        ts_mag = scenario.mag_skew.apply(t)
        g, _ = scenario.world.truth(inc, azi, tf, t)
        _, b = scenario.world.truth(inc, azi, tf, ts_mag)
    else:
        if t_s is None:
            raise ValueError("a trajectory needs sample times t_s")
        t = np.atleast_1d(np.asarray(t_s, float))
        inc, azi, tf = trajectory(t)
        ts_mag = scenario.mag_skew.apply(t)
        g, _ = scenario.world.truth(inc, azi, tf, t)
        _, b = scenario.world.truth(*trajectory(ts_mag), ts_mag)
        azi, tf = np.mod(azi, 360.0), np.mod(tf, 360.0)
    n = len(t)
    temp = probe.temperature(t) if temp_c is None else np.broadcast_to(np.asarray(temp_c, float), (n,))
    acc = scenario.acc.apply(g, temp, probe.rng_acc, acc_n_avg)
    mag = scenario.mag.apply(b, temp, probe.rng_mag)
    cols = {"t_s": t.copy(), "inc_deg": np.asarray(inc, float).copy(), "azi_deg": np.asarray(azi, float).copy(),
            "tf_deg": np.asarray(tf, float).copy(), "temp_c": np.asarray(temp, float).copy()}
    for k, c in enumerate(("ax_g", "ay_g", "az_g")):
        cols[c] = acc[:, k].copy()
    for k, c in enumerate(("mx_nT", "my_nT", "mz_nT")):
        cols[c] = mag[:, k].copy()
    e = scenario.world.earth
    meta = {"field_nT": e.field_nT, "dip_deg": e.dip_deg, "declination_deg": e.declination_deg,
            "gravity_g": scenario.world.gravity_g, "probe_serial": str(scenario.serial),
            "source": f"inclino_emu scenario={scenario.name} seed={probe.seed}"}
    meta.update(scenario.meta)
    return RawDataset(cols, meta)
