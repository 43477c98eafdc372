"""`inclino bench diagnose --json` (for now `python -m inclino.diagnose.bench
[--json]`): how often the diagnosis finds an effect hidden in emulated data,
how often it names one on data that have none, how well it estimates it and
how long it takes.

Each dataset is one of the acquisition plans of `plans` (static poses with
the oven cycling the temperature, or continuous rotations) for the bench
probe (plans.PROBE: the typical probe's 12-parameter errors, sensor noise,
quantisation, 0.05 deg turntable readout error), seeded.  An effect dataset
hides one library effect at a random sensor and axis with a random sign and
a magnitude near the detection limit: its signature, once the baseline has
absorbed what it can, is z = 6 to 9 noise standard deviations
(`plans.signature_z`, uniform in that range), against a detection threshold
of about 3.6 (alpha = 0.01 shared by two dozen candidates).  A null dataset
hides nothing.

Figures: per effect the detection rate (the right name, sensor and axis),
the rate of naming the right effect on a wrong axis, of naming anything else
as well, the estimate's error in its own standard errors (coverage: the
fraction within 2 stderr) and relative to the truth; on nulls the
false-alarm rate (any effect named) and the `unexplained` rate; run time per
dataset (generation excluded).  Targets: >= 95 % detection for every
effect, <= 5 % false alarms, < 5 s per dataset."""
from __future__ import annotations

import argparse
import json
import sys
import time
from dataclasses import dataclass, field

import numpy as np

from . import core, plans
from ._blas import one_blas_thread
from .result import clean

EFFECT_PLANS = {
    "temperature-bias": ("static",),
    "temperature-scale": ("static",),
    "scale-nonlinearity": ("static", "continuous"),
    "turntable-inclination-offset": ("static", "continuous"),
    "turntable-azimuth-offset": ("static", "continuous"),
    "field-drift": ("static",),
    "sample-skew": ("continuous",),
    "turntable-azimuth-axis-tilt": ("static", "continuous"),
    "turntable-inclination-axis-skew": ("static", "continuous"),
}
Z_RANGE = (6.0, 9.0)
TARGETS = {"detection_min": 0.95, "false_alarm_max": 0.05, "seconds_per_dataset_max": 5.0, "datasets_min": 200}


@dataclass
class DiagnoseBench:
    datasets: int
    per_effect: int
    nulls: int
    z_range: list
    alpha: float
    probe: str
    plans: dict
    effects: dict = field(default_factory=dict)
    null: dict = field(default_factory=dict)
    time_s: dict = field(default_factory=dict)
    targets: dict = field(default_factory=lambda: dict(TARGETS))
    met: dict = field(default_factory=dict)
    passed: bool = False
    cases: list = field(default_factory=list, repr=False)

    def to_dict(self, cases=False) -> dict:
        d = {k: getattr(self, k) for k in ("datasets", "per_effect", "nulls", "z_range", "alpha", "probe", "plans",
                                           "effects", "null", "time_s", "targets", "met", "passed")}
        if cases:
            d["cases"] = self.cases
        return clean(d)

    def to_json(self, cases=False) -> str:
        return json.dumps(self.to_dict(cases), indent=2)

    def summary(self) -> str:
        lines = [f"diagnose bench: {self.datasets} datasets ({self.per_effect} per effect, {self.nulls} nulls), "
                 f"hidden at z = {self.z_range[0]:g}-{self.z_range[1]:g}, alpha = {self.alpha:g}"]
        for name, e in self.effects.items():
            lines.append(f"  {name:30s} detected {e['detection_rate']:.3f}  wrong axis {e['wrong_axis_rate']:.3f}  "
                         f"extra {e['extra_rate']:.3f}  |err|/stderr rms {e['z_rms']:.2f}  within 2 stderr "
                         f"{e['within_2_stderr']:.2f}  rel. err median {e['rel_error_median']:.3f}")
        n = self.null
        lines.append(f"  nulls: false alarms {n['false_alarm_rate']:.3f} ({n['false_alarms']}/{n['datasets']}), "
                     f"unexplained {n['unexplained_rate']:.3f}")
        lines.append(f"  time per dataset: mean {self.time_s['mean']:.2f} s, max {self.time_s['max']:.2f} s")
        lines.append("  targets: " + ", ".join(f"{k} {'met' if v else 'NOT met'}" for k, v in self.met.items()))
        return "\n".join(lines)


def _pick(effect, rng):
    """(sensor, axis, candidate) of a hidden effect."""
    cands = [c for c in core.all_candidates() if c.name == effect]
    return cands[int(rng.integers(len(cands)))]


def run_case(effect, kind, seed, z=None, alpha=core.DEFAULT_ALPHA, sigma_pose_deg=plans.TURNTABLE_SIGMA_DEG):
    """One dataset: hide `effect` (None: a null) on plan `kind`; returns a
    dict of what was hidden and what the diagnosis said."""
    from .analysis import diagnose

    rng = np.random.default_rng([int(seed), 4242])
    plan = plans.PLANS[kind](seed=seed) if kind == "static" else plans.PLANS[kind]()
    case = {"seed": int(seed), "plan": kind, "hidden": None}
    probe = plans.PROBE
    if effect is not None:
        cand = _pick(effect, rng)
        if z is None:
            z = float(rng.uniform(*Z_RANGE))
        sign = 1.0 if rng.random() < 0.5 else -1.0
        zu, peak = plans.signature_z(probe, plan, cand, sigma_pose_deg, with_peak=True)
        value = sign * z / zu
        probe = plans.hide(probe, cand.name, cand.sensor, cand.axis, value)
        case["hidden"] = {"name": cand.name, "sensor": cand.sensor, "axis": cand.axis, "value": value,
                          "units": cand.units, "z": z, "peak_over_noise": abs(value) * peak}
    ds = plans.generate(probe, plan, seed, sigma_pose_deg)
    t0 = time.perf_counter()
    r = diagnose(ds, alpha=alpha)
    case["time_s"] = time.perf_counter() - t0
    case["rows"] = len(ds)
    case["found"] = [{"name": e.name, "sensor": e.sensor, "axis": e.axis, "estimate": e.estimate, "stderr": e.stderr}
                     for e in r.effects]
    case["unexplained"] = r.unexplained
    h = case["hidden"]
    if h is not None:
        hit = [f for f in case["found"] if (f["name"], f["sensor"], f["axis"]) == (h["name"], h["sensor"], h["axis"])]
        case["detected"] = bool(hit)
        case["wrong_axis"] = (not hit) and any(f["name"] == h["name"] for f in case["found"])
        case["extra"] = len(case["found"]) - len(hit) > (1 if case["wrong_axis"] else 0)
        if hit:
            f = hit[0]
            case["error"] = f["estimate"] - h["value"]
            case["z_error"] = case["error"] / f["stderr"] if f["stderr"] > 0 else np.inf
            case["rel_error"] = abs(case["error"]) / abs(h["value"])
    return case


def bench_diagnose(per_effect: int = 30, nulls: int = 60, seed0: int = 1000, alpha: float = core.DEFAULT_ALPHA,
                   progress=None) -> DiagnoseBench:
    with one_blas_thread():
        return _bench(per_effect, nulls, seed0, alpha, progress)


def _bench(per_effect, nulls, seed0, alpha, progress) -> DiagnoseBench:
    cases = []
    s = seed0
    for name in core.EFFECT_NAMES:
        kinds = EFFECT_PLANS[name]
        for i in range(per_effect):
            cases.append(run_case(name, kinds[i % len(kinds)], s, alpha=alpha))
            s += 1
            if progress:
                progress(cases[-1])
    for i in range(nulls):
        cases.append(run_case(None, ("static", "continuous")[i % 2], s, alpha=alpha))
        s += 1
        if progress:
            progress(cases[-1])
    out = DiagnoseBench(datasets=len(cases), per_effect=per_effect, nulls=nulls, z_range=list(Z_RANGE), alpha=alpha,
                        probe="plans.PROBE (typical probe's 12-parameter errors; noise 1.5e-4 g, 5 nT; turntable "
                              f"readout {plans.TURNTABLE_SIGMA_DEG} deg)",
                        plans={"static": "oven_plan: 48 orientations x 6 passes, 1/min, -5..55 degC",
                               "continuous": "rotation_plan: toolface/azimuth turns both ways at 45 and 90 deg/s, "
                                             "10 Hz"},
                        cases=cases)
    for name in core.EFFECT_NAMES:
        cs = [c for c in cases if c["hidden"] and c["hidden"]["name"] == name]
        hits = [c for c in cs if c["detected"]]
        zs = np.array([c["z_error"] for c in hits]) if hits else np.array([np.nan])
        rel = np.array([c["rel_error"] for c in hits]) if hits else np.array([np.nan])
        out.effects[name] = {
            "datasets": len(cs), "plans": list(EFFECT_PLANS[name]),
            "detection_rate": len(hits) / len(cs),
            "wrong_axis_rate": sum(c["wrong_axis"] for c in cs) / len(cs),
            "extra_rate": sum(c["extra"] for c in cs) / len(cs),
            "z_rms": float(np.sqrt(np.mean(zs ** 2))), "within_2_stderr": float(np.mean(np.abs(zs) <= 2)),
            "rel_error_median": float(np.median(rel)), "rel_error_rms": float(np.sqrt(np.mean(rel ** 2))),
            "peak_over_noise": [float(min(c["hidden"]["peak_over_noise"] for c in cs)),
                                float(max(c["hidden"]["peak_over_noise"] for c in cs))],
            "missed_seeds": [c["seed"] for c in cs if not c["detected"]],
        }
    ns = [c for c in cases if c["hidden"] is None]
    fa = [c for c in ns if c["found"]]
    out.null = {"datasets": len(ns), "false_alarms": len(fa), "false_alarm_rate": len(fa) / max(len(ns), 1),
                "unexplained_rate": sum(c["unexplained"] for c in ns) / max(len(ns), 1),
                "false_alarm_effects": [[(f["name"], f["sensor"], f["axis"]) for f in c["found"]] for c in fa],
                "by_plan": {k: sum(1 for c in fa if c["plan"] == k) for k in ("static", "continuous")}}
    eff_cases = [c for c in cases if c["hidden"]]
    out.null["unexplained_rate_with_effect"] = sum(c["unexplained"] for c in eff_cases) / max(len(eff_cases), 1)
    ts = np.array([c["time_s"] for c in cases])
    out.time_s = {"mean": float(ts.mean()), "max": float(ts.max()),
                  "mean_static": float(np.mean([c["time_s"] for c in cases if c["plan"] == "static"])),
                  "mean_continuous": float(np.mean([c["time_s"] for c in cases if c["plan"] == "continuous"]))}
    out.met = {"detection": all(e["detection_rate"] >= TARGETS["detection_min"] for e in out.effects.values()),
               "false_alarms": out.null["false_alarm_rate"] <= TARGETS["false_alarm_max"],
               "time": out.time_s["max"] < TARGETS["seconds_per_dataset_max"],
               "datasets": out.datasets >= TARGETS["datasets_min"]}
    out.passed = all(out.met.values())
    return out


def bench_command(args) -> int:
    """What `inclino bench diagnose [--json]` runs (args.json)."""
    r = bench_diagnose()
    print(r.to_json() if getattr(args, "json", False) else r.summary())
    return 0 if r.passed else 1


def main(argv=None) -> int:
    p = argparse.ArgumentParser(prog="python -m inclino.diagnose.bench", description=__doc__.split("\n\n")[0])
    p.add_argument("--json", action="store_true", help="print one JSON object")
    p.add_argument("--per-effect", type=int, default=30, help="datasets per effect (default 30)")
    p.add_argument("--nulls", type=int, default=60, help="null datasets (default 60)")
    p.add_argument("--seed", type=int, default=1000, help="first seed (default 1000)")
    p.add_argument("--cases", action="store_true", help="with --json: every dataset's record too")
    a = p.parse_args(argv)
    r = bench_diagnose(a.per_effect, a.nulls, a.seed)
    print(r.to_json(cases=a.cases) if a.json else r.summary())
    return 0 if r.passed else 1


if __name__ == "__main__":  # pragma: no cover
    sys.exit(main())
