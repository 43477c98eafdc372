"""Bench time against accuracy: today's procedures and the adaptive ones
side by side (`inclino bench calibration --section time --json`; the key
`time` of `inclino bench calibration --json`).

Probes: the typical scenario with its tempcos drawn from the scenario's
spread (calibration_temperature.drawn_probe, seeds SEED0...), the same
probes as the temperature section.  For each probe, four runs, each on a
fresh emulated probe of that draw (inclino_emu.runner.Emulator, unthrottled
with hold_idle: the emulated clock stops while the host computes, so it is
the bench's time), unattended on the emulated turntable, whose moves take
the time of world.MOTORISED (10 deg/s per axis, 3 s to settle):

* room, today: `acquire --procedure multi-position` (94 poses, 16 samples
  per reading), `calibrate --method joint`;
* room, adaptive: `acquire --procedure adaptive` (procedures.adaptive, its
  defaults: the auto targets, 16 samples), `calibrate --method joint`;
* temperature, today: `acquire --procedure temperature` (set points -5,
  25, 55 degC, ramps at 1 degC/min and soaks, twelve positions at each, 64
  samples), `calibrate --method joint --temperature-terms on`;
* temperature, adaptive: `acquire --procedure adaptive --temperatures
  -5,55` (a continuous ramp at 5 degC/min, procedures.ramp), `calibrate
  --method joint --temperature-terms on`.

Bench time: the emulator's active clock over the acquisition (turntable
moves, chamber ramps and waits, the probe's readings and the bytes on the
line).  The adaptive runs also report the host's computing between readings
(`planning_s`, wall time on this machine; not part of the emulated clock).

Acceptance (the same probe, the same noise draw for every procedure of one
probe: common random numbers, so that the comparison is of the
calibrations): the Li grid (I 2, 5, 10, 20 ... 90, A 0-300 every 60,
toolfaces 0, 120, 240; 198 positions) read as `inclino accept` reads it
(16-sample readings, three a position, calibration_temperature.REPEATS
takings) through the firmware's correction, at 25 degC for the room runs
and at -5, 25, 55 degC with the temperature terms for the chamber runs
(calibration_temperature.check_probe), and noise-free (the calibration's
own error).  Diagnosability: for each run, what `inclino diagnose` could
test on it (diagnosability: the smallest effect of each candidate named
half the time, from its signature's size on the run's own poses, times and
temperatures).  The prediction at the stop: the fit's predicted acceptance
azimuth RMS for that acceptance (procedures.adaptive.acceptance_prediction,
16 samples per reading) against the acceptance's.

Targets (medians over the probes): temperature bench time cut >= 3x, room
>= 2x; the adaptive Li-grid azimuth RMS at 25 degC within 1.1x of today's
median (room and temperature); with the terms, the ratio at -5 and 55 degC
to 25 degC <= 1.2 on every probe; the adaptive prediction at the stop
achieved / predicted within 0.7-1.4 (median).
"""
from __future__ import annotations

import contextlib
import copy
import os
import tempfile
import time
from dataclasses import asdict, dataclass, field

import numpy as np

N_PROBES = 8
SEED0 = 500
ROOM_C = 25.0
TARGETS = {"temperature_time_cut_min": 3.0, "room_time_cut_min": 2.0, "azi_rms_25c_to_today_max": 1.1,
           "temperature_ratio_max": 1.2, "achieved_to_predicted_band": [0.7, 1.4]}
PROCEDURES = ("room_today", "room_adaptive", "temperature_today", "temperature_adaptive")


@dataclass
class TimeBench:
    probes: int
    seeds: list
    scenario: str
    turntable: dict
    per_probe: list = field(default_factory=list)
    median: dict = field(default_factory=dict)
    diagnosability: dict = field(default_factory=dict)  # what diagnose can test on each run: adaptive against today
    curves: dict = field(default_factory=dict)  # the first probe: predicted accuracy against bench time
    targets: dict = field(default_factory=lambda: dict(TARGETS))
    met: dict = field(default_factory=dict)
    passed: bool = False
    failed: list = field(default_factory=list)
    elapsed_s: float = 0.0
    notes: list = field(default_factory=list)

    def to_dict(self) -> dict:
        return asdict(self)

    def to_json(self) -> str:
        from inclino.formats.jsonout import dumps

        return dumps(self.to_dict())


@contextlib.contextmanager
def emulated_bench(scenario, seed: int):
    """(link, table) of a fresh emulated probe of `scenario` on its turntable,
    the clock held while the host computes."""
    from inclino.link.serial_link import ProbeLink
    from inclino.procedures.turntable_emulated import EmulatedTurntable
    from inclino_emu.runner import Emulator

    from inclino.model.world import MOTORISED, TurntableMotion

    sc = copy.deepcopy(scenario)
    sc.world.turntable.motion = TurntableMotion(**MOTORISED)
    emu = Emulator(sc, seed=seed, control_port=0, realtime=False, hold_idle=True).start()
    table = None
    try:
        table = EmulatedTurntable(f"127.0.0.1:{emu.control_port}")
        with ProbeLink(emu.path, timeout=5.0) as link:
            yield link, table
    finally:
        if table is not None:
            table.close()
        emu.stop()


def _active(table) -> float:
    return float(table.call("status")["active_s"])


def acquire_run(procedure: str, scenario, seed: int, path: str, plan=None) -> dict:
    """One acquisition on a fresh emulated probe: {bench_s, rows, wall_s,
    (adaptive) planning_s, stop, prediction}."""
    from inclino.procedures import acquire as acq, acquire_temp, adaptive, ramp

    w0 = time.monotonic()
    with emulated_bench(scenario, seed) as (link, table):
        a0 = _active(table)
        if procedure == "room_today":
            r = acq.acquire(link, "multi-position", path, table, quiet=True, average=16)
        elif procedure == "temperature_today":
            r = acquire_temp.acquire_temperature(link, path, table, acquire_temp.ThermalPlan(), quiet=True)
        elif procedure == "room_adaptive":
            r = adaptive.acquire_adaptive(link, path, table, plan or adaptive.AdaptivePlan(), quiet=True)
        elif procedure == "temperature_adaptive":
            r = adaptive.acquire_adaptive(link, path, table, plan or adaptive.AdaptivePlan(
                ramp=ramp.RampPlan(), max_poses=800), quiet=True)
        else:
            raise ValueError(procedure)
        bench = _active(table) - a0
    out = {"bench_s": bench, "rows": r.rows, "wall_s": time.monotonic() - w0}
    if procedure.endswith("adaptive"):
        out.update({"planning_s": r.planning_s, "stop": r.stop_reason, "targets": r.targets,
                    "predicted_at_stop": (r.prediction.get("acceptance_grid") or {}).get("azi_rms_deg"),
                    "predicted_inc_at_stop": (r.prediction.get("acceptance_grid") or {}).get("inc_rms_deg"),
                    "predicted_ratios": r.prediction.get("ratios"), "ramp": {k: v for k, v in r.ramp.items()
                                                                               if k != "air_pieces"}})
    return out


def fit_run(path: str, thermal: bool):
    from inclino.calib import common, fit
    from inclino.formats import dataset

    ds = dataset.read_raw(path)
    return fit(ds, "joint", data_hash=common.file_hash(path, ds), temperature="on" if thermal else "off"), ds


def acceptance(scenario, cal, engine, seed: int, thermal: bool) -> dict:
    """The acceptance of `cal` on the true probe (module docstring)."""
    from inclino.benchmarks import calibration_temperature as bt

    dec = float(scenario.world.earth.declination_deg)
    if thermal:
        chk = bt.check_probe(scenario, cal, engine, bt.CHECK_C, ROOM_C, seed=seed)
        rows = {r["setpoint_c"]: r for r in chk["setpoints"]}
        rows0 = {r["setpoint_c"]: r for r in chk["calibration_only"]}
        return {"azi_rms_25c_deg": rows[ROOM_C]["azi_rms_with_deg"], "inc_rms_25c_deg": rows[ROOM_C]["inc_rms_with_deg"],
                "calibration_only_azi_rms_25c_deg": rows0[ROOM_C]["azi_rms_with_deg"],
                "calibration_only_inc_rms_25c_deg": rows0[ROOM_C]["inc_rms_with_deg"],
                "ratios": {f"{t:g}": {"azi": r["azi_ratio_with"], "inc": r["inc_ratio_with"],
                                      "azi_rms_deg": r["azi_rms_with_deg"], "inc_rms_deg": r["inc_rms_with_deg"]}
                           for t, r in rows.items() if t != ROOM_C}}
    g, readings, tcc = bt.acceptance_readings(scenario, ROOM_C, seed=seed * 100)
    da, di = bt.acceptance_errors(engine, cal, g, readings, tcc, dec, terms=False)
    g0, acc, mag, tcc0 = bt.grid_readings(scenario, ROOM_C)
    da0, di0 = bt.grid_errors(engine, cal, g0, acc, mag, tcc0, dec, terms=False)
    return {"azi_rms_25c_deg": bt._rms(da), "inc_rms_25c_deg": bt._rms(di),
            "calibration_only_azi_rms_25c_deg": bt._rms(da0), "calibration_only_inc_rms_25c_deg": bt._rms(di0)}


def _prediction(cal, rep, ds) -> dict:
    from inclino.calib import common
    from inclino.procedures.adaptive import acceptance_prediction

    n_run = int(ds.meta.get("samples_averaged") or 16)
    w = common.world_of(ds)
    if w["dip_deg"] is None:
        w["dip_deg"] = float(rep.uncertainty.get("dip_deg", 60.0))
    p = acceptance_prediction(cal, rep, n_run, 16, w)
    return {"predicted_azi_rms_deg": p["azi_rms_deg"], "predicted_inc_rms_deg": p["inc_rms_deg"]} if p else {}


def bench_probe(seed: int, engine, workdir: str, procedures=PROCEDURES, progress=None) -> dict:
    from inclino.benchmarks.calibration_temperature import drawn_probe

    sc = drawn_probe(seed)
    out = {"seed": seed}
    for k, proc in enumerate(procedures):
        if progress:
            progress(f"probe {seed}: {proc}")
        thermal = proc.startswith("temperature")
        path = os.path.join(workdir, f"{proc}_{seed}.csv")
        r = acquire_run(proc, sc, seed * 10 + k + 1, path)
        (cal, rep), ds = fit_run(path, thermal)
        if thermal:
            engine.check(cal)
        r.update(acceptance(sc, cal, engine, seed, thermal))
        r.update(_prediction(cal, rep, ds))
        r["fit_passed"] = bool(rep.passed)
        r["diagnosable"] = diagnosability(path)
        if thermal:
            from inclino.calib import templag

            r["order"] = int(cal.temperature["order"])
            r["sensor_lag"] = templag.estimate(ds, cal)  # each triad behind TEMP_OUT (0 on the emulator)
        r["achieved_to_predicted"] = (r["azi_rms_25c_deg"] / r["predicted_azi_rms_deg"]
                                      if r.get("predicted_azi_rms_deg") else None)
        out[proc] = r
    return out


DETECT_Z = 3.6  # diagnose's detection threshold, noise standard deviations (docs/diagnose.md: the 50 % point)


def diagnosability(path: str) -> dict:
    """What `inclino diagnose` could test on this run: per candidate effect
    (diagnose.core.all_candidates; the sample skew left out, it needs
    continuous data) the signature's size per unit outside the baseline's
    span under the diagnose bench's noise (diagnose.plans.signature_z, the
    run's own poses, times and temperatures), as the smallest effect named
    half the time, DETECT_Z / z; None where the run cannot test it (z ~ 0:
    a temperature that never changes)."""
    from inclino.diagnose import core, plans
    from inclino.formats import dataset

    ds = dataset.read_raw(path)
    c = ds.columns
    plan = {"kind": "static", "inc": c["inc_deg"], "azi": c["azi_deg"], "tf": c["tf_deg"],
            "t_s": c["t_s"] - c["t_s"][0], "temp_c": c["temp_c"]}
    out = {}
    with np.errstate(all="ignore"):
        for cand in core.all_candidates():
            if cand.name == "sample-skew":
                continue
            z = plans.signature_z(plans.PROBE, plan, cand)
            out[cand.key] = {"z_per_unit": float(z) if np.isfinite(z) else 0.0, "units": cand.units,
                             "smallest_named": float(DETECT_Z / z) if np.isfinite(z) and z > 1e-6 else None}
    return out


def diagnosability_summary(per_probe: list) -> dict:
    """Per pair (room, temperature) and candidate: the median over the
    probes of the adaptive run's z over today's (1: as testable as today;
    < 1: the smallest effect diagnose names is 1/ratio times larger), and
    whether each run can test it at all."""
    out = {}
    for pair in ("room", "temperature"):
        a, t = f"{pair}_adaptive", f"{pair}_today"
        rows = [p for p in per_probe if "diagnosable" in p.get(a, {}) and "diagnosable" in p.get(t, {})]
        if not rows:
            continue
        res = {}
        for key in rows[0][a]["diagnosable"]:
            za = [p[a]["diagnosable"][key]["z_per_unit"] for p in rows]
            zt = [p[t]["diagnosable"][key]["z_per_unit"] for p in rows]
            ok = [x > 1e-6 and y > 1e-6 for x, y in zip(za, zt)]
            res[key] = {"testable_today": all(y > 1e-6 for y in zt), "testable_adaptive": all(x > 1e-6 for x in za),
                        "z_ratio_adaptive_to_today": _median([x / y for x, y, o in zip(za, zt, ok) if o]),
                        "smallest_named_today": _median([p[t]["diagnosable"][key]["smallest_named"] for p in rows]),
                        "smallest_named_adaptive": _median([p[a]["diagnosable"][key]["smallest_named"]
                                                            for p in rows]),
                        "units": rows[0][a]["diagnosable"][key]["units"]}
        out[pair] = res
    return out


def room_curve(path: str, every: int = 2) -> list:
    """Predicted acceptance azimuth and inclination RMS against bench time
    along a room-temperature run: calib.fit on the first k rows (what a
    stop after k poses would have printed), every `every` rows; bench time
    from the rows' own clock (t_s: the probe's clock, which with hold_idle
    is the bench's), from the run's start."""
    from inclino.calib import common, fit
    from inclino.errors import InclinoError
    from inclino.formats import dataset

    ds = dataset.read_raw(path)
    t = ds.columns["t_s"]
    out = []
    for k in list(range(12, len(ds), every)) + [len(ds)]:
        try:
            _, rep = fit(common.subset(ds, list(range(k))), "joint", temperature="off")
        except (InclinoError, np.linalg.LinAlgError, ValueError):
            continue
        pa = rep.uncertainty.get("prediction_acceptance_grid") or {}
        if pa:
            out.append({"rows": k, "bench_s": float(t[k - 1] - t[0]), "azi_deg": pa["azi_rms_deg"],
                        "inc_deg": pa["inc_rms_deg"]})
    return out


def temperature_curve(path: str, points: int = 40) -> list:
    """The predicted acceptance azimuth RMS at the worst of -5, 25 and 55
    degC against bench time along a chamber run: the Fisher information of
    the rows so far (calib.design, at the run's final fit: joint's
    parameters and the temperature terms) with the final fit's floor at 16
    samples per reading; None while the rows leave a term undetermined."""
    from inclino.calib import common, design, fit, joint
    from inclino.formats import dataset
    from inclino.procedures.adaptive import acceptance_prediction

    ds = dataset.read_raw(path)
    cal, rep = fit(ds, "joint", temperature="on")
    w = common.world_of(ds)
    w["dip_deg"] = float(rep.uncertainty.get("dip_deg", w["dip_deg"] or 60.0))
    pa = acceptance_prediction(cal, rep, int(float(ds.meta.get("samples_averaged") or 64)), 16, w)
    floor = float(np.sqrt(max(pa["azi_rms_deg"] ** 2 - pa["terms_azi_rms_deg"]["coefficients"] ** 2, 0.0)))
    info = {"dip_deg": w["dip_deg"], "s2": float(rep.residuals.get("s2", 1.0))}
    if rep.uncertainty.get("nonlinear_model"):
        info["nonlinear"] = rep.uncertainty["nonlinear_model"]
    est = design.Estimate.from_fit(cal, info, w, joint.SIGMA_ACC, joint.SIGMA_MAG, joint.SIGMA_POSE_DEG, order=2)
    Ws = design.attitude_weights(est, (-5.0, est.t_ref_c, 55.0), per_temperature=True)
    poses = tuple(ds.columns[c] for c in ("inc_deg", "azi_deg", "tf_deg"))
    J = design.row_jacobians(est, poses, ds.columns["temp_c"])
    t = ds.columns["t_s"]
    out = []
    for k in np.unique(np.linspace(12, len(ds), points).astype(int)):
        Jk = J[:k].reshape(-1, J.shape[-1])
        C = design.Design(Jk.T @ Jk, []).cov
        v = max(float(np.trace(C @ W[0])) for W in Ws)
        out.append({"rows": int(k), "bench_s": float(t[k - 1] - t[0]),
                    "azi_deg": float(np.sqrt(floor ** 2 + v)) if v < 1.0 else None})
    return out


def draw(curves: dict, path: str) -> str:
    """The figure of docs/calibration.md: predicted acceptance azimuth RMS
    against bench time, today's procedures and the adaptive ones."""
    from inclino import plotting

    plt = plotting.pyplot()
    fig, axs = plt.subplots(1, 2, figsize=(11, 4.2))
    for ax, pair, title in ((axs[0], "room", "room temperature: Li grid at 25 degC"),
                            (axs[1], "temperature", "through the chamber: the worst of -5, 25, 55 degC")):
        for proc in (f"{pair}_today", f"{pair}_adaptive"):
            c = [x for x in curves.get(proc, []) if x["azi_deg"] is not None]
            if c:
                name = "today's procedure" if proc.endswith("today") else "adaptive"
                ax.plot([x["bench_s"] / 60.0 for x in c], [x["azi_deg"] for x in c], marker=".", markersize=3,
                        label=f"{name} ({c[-1]['rows']} rows, {c[-1]['bench_s'] / 60.0:.0f} min)")
        ax.set_xlabel("bench time, min")
        ax.set_ylabel("predicted acceptance azimuth RMS, deg")
        ax.set_yscale("log")
        ax.set_title(title, fontsize=10)
        ax.grid(True, which="both", alpha=0.3)
        ax.legend(fontsize=8)
    fig.tight_layout()
    return plotting.save(fig, path)


def _median(xs):
    xs = [x for x in xs if x is not None]
    return float(np.median(xs)) if xs else None


def summarise(per_probe: list) -> tuple[dict, dict]:
    med = {}
    for proc in PROCEDURES:
        rows = [p[proc] for p in per_probe if proc in p]
        if not rows:
            continue
        m = {k: _median([r.get(k) for r in rows]) for k in (
            "bench_s", "rows", "planning_s", "azi_rms_25c_deg", "inc_rms_25c_deg", "calibration_only_azi_rms_25c_deg",
            "calibration_only_inc_rms_25c_deg", "predicted_azi_rms_deg", "achieved_to_predicted")}
        if proc.startswith("temperature"):
            for t in ("-5", "55"):
                m[f"azi_ratio_{t}c"] = _median([r["ratios"][t]["azi"] for r in rows])
                m[f"inc_ratio_{t}c"] = _median([r["ratios"][t]["inc"] for r in rows])
                m[f"worst_ratio_{t}c"] = float(max(max(r["ratios"][t]["azi"], r["ratios"][t]["inc"]) for r in rows))
        med[proc] = m
    met = {}
    both = [p for p in per_probe if all(k in p for k in PROCEDURES)]
    if both:
        cut_t = [p["temperature_today"]["bench_s"] / p["temperature_adaptive"]["bench_s"] for p in both]
        cut_r = [p["room_today"]["bench_s"] / p["room_adaptive"]["bench_s"] for p in both]
        cut_tp = [p["temperature_today"]["bench_s"] / (p["temperature_adaptive"]["bench_s"]
                                                      + p["temperature_adaptive"]["planning_s"]) for p in both]
        cut_rp = [p["room_today"]["bench_s"] / (p["room_adaptive"]["bench_s"] + p["room_adaptive"]["planning_s"])
                  for p in both]
        azi_r = med["room_adaptive"]["azi_rms_25c_deg"] / med["room_today"]["azi_rms_25c_deg"]
        azi_t = med["temperature_adaptive"]["azi_rms_25c_deg"] / med["temperature_today"]["azi_rms_25c_deg"]
        worst = max(max(r["azi"], r["inc"]) for p in both for r in p["temperature_adaptive"]["ratios"].values())
        ap = [p[k]["achieved_to_predicted"] for p in both for k in ("room_adaptive", "temperature_adaptive")]
        ap_room = _median([p["room_adaptive"]["achieved_to_predicted"] for p in both])
        ap_temp = _median([p["temperature_adaptive"]["achieved_to_predicted"] for p in both])
        band = TARGETS["achieved_to_predicted_band"]
        met = {
            "temperature_time_cut": float(np.median(cut_t)), "temperature_time_cut_per_probe": cut_t,
            "temperature_time_cut_with_planning": float(np.median(cut_tp)),
            "temperature_time_cut_ok": float(np.median(cut_t)) >= TARGETS["temperature_time_cut_min"],
            "room_time_cut": float(np.median(cut_r)), "room_time_cut_per_probe": cut_r,
            "room_time_cut_with_planning": float(np.median(cut_rp)),
            "room_time_cut_ok": float(np.median(cut_r)) >= TARGETS["room_time_cut_min"],
            "room_azi_rms_25c_to_today": azi_r,
            "room_azi_rms_25c_ok": azi_r <= TARGETS["azi_rms_25c_to_today_max"],
            "temperature_azi_rms_25c_to_today": azi_t,
            "temperature_azi_rms_25c_ok": azi_t <= TARGETS["azi_rms_25c_to_today_max"],
            "temperature_worst_ratio": worst,
            "temperature_ratio_ok": worst <= TARGETS["temperature_ratio_max"],
            "room_achieved_to_predicted_median": ap_room, "temperature_achieved_to_predicted_median": ap_temp,
            "achieved_to_predicted_ok": all(x is not None and band[0] <= x <= band[1] for x in (ap_room, ap_temp)),
            "achieved_to_predicted_all": ap,
        }
    return med, met


def bench_time(n_probes: int = N_PROBES, seed: int = SEED0, engine: str = "auto", progress=None,
               plot: str | None = None) -> TimeBench:
    """plot: also draw the first probe's predicted accuracy against bench
    time (PNG; the curves are in `curves` either way)."""
    from inclino.engines import temperature as temp_engine
    from inclino.model.world import MOTORISED, TurntableMotion

    t0 = time.monotonic()
    eng = temp_engine.get(engine)
    m = TurntableMotion(**MOTORISED)
    res = TimeBench(probes=n_probes, seeds=list(range(seed, seed + n_probes)),
                    scenario="typical, tempcos drawn from its spread (Scenario.draw_tempcos)",
                    turntable={"rate_deg_s": m.rate_deg_s, "settle_s": m.settle_s})
    res.notes.append(f"engine {eng.name}; bench time = the emulator's active clock (hold_idle)")
    with tempfile.TemporaryDirectory(prefix="inclino-bench-time-") as d:
        for s in res.seeds:
            try:
                res.per_probe.append(bench_probe(s, eng, d, progress=progress))
            except Exception as e:  # a probe a procedure cannot calibrate is reported, not hidden
                res.failed.append({"seed": s, "error": f"{type(e).__name__}: {e}"})
                continue
            if not res.curves:  # the first probe's runs, for the figure
                res.curves = {p: (room_curve if p.startswith("room") else temperature_curve)(
                    os.path.join(d, f"{p}_{s}.csv")) for p in PROCEDURES}
                res.curves["seed"] = s
        if plot and res.curves:
            draw(res.curves, plot)
    res.median, res.met = summarise(res.per_probe)
    res.diagnosability = diagnosability_summary(res.per_probe)
    keys = ("temperature_time_cut_ok", "room_time_cut_ok", "room_azi_rms_25c_ok", "temperature_azi_rms_25c_ok",
            "temperature_ratio_ok", "achieved_to_predicted_ok")
    res.passed = bool(res.met) and all(res.met.get(k) for k in keys) and not res.failed
    res.elapsed_s = time.monotonic() - t0
    return res


def text(res: TimeBench) -> str:
    out = [f"bench time against accuracy: {len(res.per_probe)} of {res.probes} probes (seeds "
           f"{res.seeds[0]}-{res.seeds[-1]}), turntable {res.turntable['rate_deg_s']:g} deg/s + "
           f"{res.turntable['settle_s']:g} s"]
    for proc, m in res.median.items():
        line = (f"  {proc:21s} bench {m['bench_s'] / 60:7.1f} min, {m['rows']:.0f} rows; Li grid 25 degC azimuth RMS "
                f"{m['azi_rms_25c_deg']:.4f} deg (calibration alone {m['calibration_only_azi_rms_25c_deg']:.4f}), "
                f"inclination {m['inc_rms_25c_deg']:.4f}; predicted {m['predicted_azi_rms_deg']:.4f}, achieved / "
                f"predicted {m['achieved_to_predicted']:.2f}")
        if "azi_ratio_-5c" in m:
            line += (f"; ratio to 25 degC at -5 / 55: azimuth {m['azi_ratio_-5c']:.2f} / {m['azi_ratio_55c']:.2f} "
                     f"(worst {m['worst_ratio_-5c']:.2f} / {m['worst_ratio_55c']:.2f})")
        if m.get("planning_s") is not None:
            line += f"; host computing {m['planning_s']:.0f} s"
        out.append(line)
    t = res.met
    if t:
        out.append(f"  time cut: temperature {t['temperature_time_cut']:.1f}x (target >= "
                   f"{TARGETS['temperature_time_cut_min']:g}), room {t['room_time_cut']:.1f}x (>= "
                   f"{TARGETS['room_time_cut_min']:g}); with the host's computing {t['temperature_time_cut_with_planning']:.1f}x"
                   f" / {t['room_time_cut_with_planning']:.1f}x")
        out.append(f"  azimuth RMS at 25 degC, adaptive / today: room {t['room_azi_rms_25c_to_today']:.3f}, temperature "
                   f"{t['temperature_azi_rms_25c_to_today']:.3f} (<= {TARGETS['azi_rms_25c_to_today_max']:g}); worst ratio "
                   f"to 25 degC with the terms {t['temperature_worst_ratio']:.3f} (<= {TARGETS['temperature_ratio_max']:g})")
        out.append(f"  prediction at the stop, achieved / predicted: room {t['room_achieved_to_predicted_median']:.2f}, "
                   f"temperature {t['temperature_achieved_to_predicted_median']:.2f} (band "
                   f"{TARGETS['achieved_to_predicted_band'][0]:g}-{TARGETS['achieved_to_predicted_band'][1]:g})")
    for pair, d in res.diagnosability.items():
        lost = [k for k, v in d.items() if v["testable_today"] and not v["testable_adaptive"]]
        rat = {k: v["z_ratio_adaptive_to_today"] for k, v in d.items() if v["z_ratio_adaptive_to_today"] is not None}
        if rat:
            lo = min(rat, key=rat.get)
            out.append(f"  diagnose on the {pair} runs: {len(rat)} effects testable on both"
                       + (f", not on the adaptive run: {', '.join(lost)}" if lost else "")
                       + f"; adaptive / today signature size median {np.median(list(rat.values())):.2f}, lowest "
                       f"{rat[lo]:.2f} ({lo})")
    for f in res.failed:
        out.append(f"  FAILED probe {f['seed']}: {f['error']}")
    out.append("  targets: " + ("met" if res.passed else "NOT met"))
    return "\n".join(out)
