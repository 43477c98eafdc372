"""The rules of a scenario file (TOML, docs/emulator.md "Scenarios"): every
table and field known, every value of the right type and within its range,
checked before the scenario is built -- one error line naming the field.

Ranges are what the sensors and the bench can hold, with margin: a
scenario describes a probe that could exist (a scale of zero, an infinite
noise, a serial beyond the probe's 32 bits are refused, never truncated or
simulated into NaN).
"""
from __future__ import annotations

import math

from inclino.errors import DataError
from inclino.formats.fields import Fields, check_array, check_number, show
from inclino.model.world import CHAMBER_MAX_RATE_C_PER_MIN, CHAMBER_RANGE_C

INF = math.inf
# per triad: (bias, hard iron, noise sigma, saturation limit, k2) ranges in the triad's unit (g or nT)
UNIT = {"acc": {"bias": 2.0, "noise": 1.0, "limit": (0.1, 20.0), "k2": 0.5, "tempco": 0.1, "tempco2": 1e-2},
        "mag": {"bias": 2e5, "noise": 1e4, "limit": (1e3, 1e6), "k2": 1e-5, "tempco": 1e3, "tempco2": 10.0}}
EFFECTS = ("bias", "scale", "misalignment", "hard_iron", "soft_iron", "bias_tempco", "scale_tempco",
           "nonlinearity", "noise", "saturation", "li2021", "quantise")


def _vec(f: Fields, key, lo, hi, required=True, default=None):
    """A scalar or 3 numbers (the effects take either)."""
    if not f.has(key):
        if required:
            raise DataError(f"{f.where}: {key} is missing")
        return default
    v = f.d[key]
    if isinstance(v, list):
        return check_array(v, f"{f.where}: {key}", (3,), lo, hi)
    return check_number(v, f"{f.where}: {key}", lo, hi)


def _matrix(f: Fields, key, lo=-2.0, hi=2.0):
    import numpy as np

    m = f.numbers(key, (3, 3), lo, hi)
    if abs(np.linalg.det(m)) < 1e-6:
        raise DataError(f"{f.where}: {key} is singular (a sensor that cannot see one direction)")
    return m


def check_triad(kind: str, tab, where: str) -> None:
    u = UNIT[kind]
    t = Fields(tab, where)
    t.known(*EFFECTS)
    if t.has("quantise"):
        t.boolean("quantise")
    sub = {k: t.obj(k) for k in EFFECTS if k != "quantise" and t.has(k)}
    if "bias" in sub:
        sub["bias"].known("value")
        _vec(sub["bias"], "value", -u["bias"], u["bias"])
    if "scale" in sub:
        sub["scale"].known("value")
        _vec(sub["scale"], "value", 0.5, 2.0)  # a scale of 0 (or a sign flip) is no sensor
    if "misalignment" in sub:
        m = sub["misalignment"]
        m.known("matrix", "angles_rad", "nonorth_rad")
        if m.has("matrix"):
            _matrix(m, "matrix")
        for k in ("angles_rad", "nonorth_rad"):
            if m.has(k):
                m.numbers(k, (3,), -0.5, 0.5)
    if "hard_iron" in sub:
        if kind == "acc":
            raise DataError(f"{where}: hard_iron is a fluxgate effect")
        sub["hard_iron"].known("value")
        _vec(sub["hard_iron"], "value", -u["bias"], u["bias"])
    if "soft_iron" in sub:
        if kind == "acc":
            raise DataError(f"{where}: soft_iron is a fluxgate effect")
        sub["soft_iron"].known("matrix")
        _matrix(sub["soft_iron"], "matrix")
    if "bias_tempco" in sub:
        b = sub["bias_tempco"]
        b.known("value", "value2", "t_ref_c", "spread", "spread2")
        _vec(b, "value", -u["tempco"], u["tempco"], required=False)
        _vec(b, "value2", -u["tempco2"], u["tempco2"], required=False)
        b.number("t_ref_c", *CHAMBER_RANGE_C, required=False)
        _vec(b, "spread", 0.0, u["tempco"], required=False)
        _vec(b, "spread2", 0.0, u["tempco2"], required=False)
    if "scale_tempco" in sub:
        s = sub["scale_tempco"]
        s.known("ppm", "ppm2", "t_ref_c", "spread", "spread2")
        _vec(s, "ppm", -1e4, 1e4, required=False)
        _vec(s, "ppm2", -100.0, 100.0, required=False)
        s.number("t_ref_c", *CHAMBER_RANGE_C, required=False)
        _vec(s, "spread", 0.0, 1e4, required=False)
        _vec(s, "spread2", 0.0, 100.0, required=False)
    if "nonlinearity" in sub:
        sub["nonlinearity"].known("k2")
        _vec(sub["nonlinearity"], "k2", -u["k2"], u["k2"])
    if "noise" in sub:
        n = sub["noise"]
        n.known("sigma", "n_ref")
        _vec(n, "sigma", 0.0, u["noise"])
        n.integer("n_ref", 1, 1 << 20, required=False)
    if "saturation" in sub:
        sub["saturation"].known("limit")
        sub["saturation"].number("limit", *u["limit"])
    if "li2021" in sub:
        li = sub["li2021"]
        li.known("K", "B_counts", "e")
        li.numbers("K", (3,), 0.5, 2.0)
        li.numbers("B_counts", (3,), -1e6, 1e6)
        li.numbers("e", (3, 2), -0.5, 0.5)


def check_scenario(d, where: str) -> None:
    """DataError (one line) for the first field that breaks its rule."""
    f = Fields(d, where)
    f.known("name", "description", "seed", "serial", "world", "acc", "mag", "timing")
    f.string("name", required=False)
    f.string("description", required=False)
    f.integer("seed", 0, 2**63 - 1, required=False)
    f.integer("serial", 0, 2**32 - 1, required=False)  # the probe's identity record holds 32 bits
    w = f.obj("world", required=False)
    if w is not None:
        w.known("field_nT", "dip_deg", "declination_deg", "gravity_g", "temperature_c", "temperature_rate_c_per_s",
                "lat_deg", "lon_deg", "date", "alt_km", "chamber", "encoder", "field_drift")
        w.number("field_nT", 0.0, 2e5, lo_open=True, required=False)
        w.number("dip_deg", -90.0, 90.0, required=False)
        w.number("declination_deg", -180.0, 180.0, required=False)
        w.number("gravity_g", 0.0, 2.0, lo_open=True, required=False)
        w.number("temperature_c", *CHAMBER_RANGE_C, required=False)
        w.number("temperature_rate_c_per_s", -1.0, 1.0, required=False)
        w.number("lat_deg", -89.99, 89.99, required=False)
        w.number("lon_deg", -180.0, 360.0, required=False)
        w.number("alt_km", -12.0, 1000.0, required=False)
        if w.has("date"):
            import datetime as _dt

            v = w.d["date"]
            if not isinstance(v, (str, _dt.date)):
                raise DataError(f"{where}: world: date must be a date (YYYY-MM-DD), not {show(v)}")
            if isinstance(v, str):
                try:
                    _dt.date.fromisoformat(v)
                except ValueError:
                    raise DataError(f"{where}: world: date must be a date (YYYY-MM-DD), not {show(v)}") from None
        ch = w.obj("chamber", required=False)
        if ch is not None:
            ch.known("temperature_c", "tau_s", "profile")
            ch.number("temperature_c", *CHAMBER_RANGE_C, required=False)
            ch.number("tau_s", 0.0, 86400.0, lo_open=True, required=False)
            prof = ch.d.get("profile", [])
            if not isinstance(prof, list) or len(prof) > 10000:
                raise DataError(f"{where}: world: chamber: profile must be a list of [t_s, setpoint_c(, rate)]")
            for i, item in enumerate(prof):
                if not isinstance(item, list) or len(item) not in (2, 3):
                    raise DataError(f"{where}: world: chamber: profile[{i}] must be [t_s, setpoint_c] or "
                                    "[t_s, setpoint_c, rate_c_per_min]")
                check_number(item[0], f"{where}: world: chamber: profile[{i}] t_s", 0.0, 1e9)
                check_number(item[1], f"{where}: world: chamber: profile[{i}] setpoint_c", *CHAMBER_RANGE_C)
                if len(item) == 3:
                    check_number(item[2], f"{where}: world: chamber: profile[{i}] rate_c_per_min", 0.0,
                                 CHAMBER_MAX_RATE_C_PER_MIN)
        enc = w.obj("encoder", required=False)
        if enc is not None:
            enc.known("offset_deg", "scale")
            _vec(enc, "offset_deg", -10.0, 10.0, required=False)
            _vec(enc, "scale", -0.1, 0.1, required=False)
        dr = w.obj("field_drift", required=False)
        if dr is not None:
            dr.known("rate_nT_per_s", "dip_rate_deg_per_s", "declination_rate_deg_per_s")
            dr.number("rate_nT_per_s", -100.0, 100.0, required=False)
            dr.number("dip_rate_deg_per_s", -0.1, 0.1, required=False)
            dr.number("declination_rate_deg_per_s", -0.1, 0.1, required=False)
    for kind in ("acc", "mag"):
        if f.has(kind):
            check_triad(kind, f.d[kind], f"{where}: {kind}")
    t = f.obj("timing", required=False)
    if t is not None:
        t.known("mag_skew_s")
        t.number("mag_skew_s", -1.0, 1.0, required=False)
