"""`inclino demo`: the whole calibration bench on the emulated probe.

With no arguments (the README's first command, `make demo`):

1. start the emulated probe (host/inclino/model/scenarios/typical.toml: a typical
   uncalibrated probe; unthrottled) on a pseudo-terminal, with its control
   channel;
2. acquire an adaptive calibration run on the emulated turntable,
   unattended over the control channel (`inclino acquire --procedure
   adaptive --bench`): poses chosen one at a time until the predicted
   acceptance reaches its target; the turntable's moves take the time of a
   motorised table (world.MOTORISED) and the emulated clock holds while the
   host computes, so the bench time printed is the bench's;
3. fit it with `joint` (`inclino calibrate`);
4. download the calibration (write, read back, activate) and verify it bit
   for bit (`inclino download`, `inclino verify`);
5. run the acceptance grids, Li 2021 (with the horizontal circles) and Ren
   2014, before (identity: the probe as delivered) and after (`inclino
   accept --bench`), and print them in the papers' layout;
6. write the run, the calibration, the accept results and the figures into
   ./inclino-demo/ (-o): run.csv, cal.json, accept_li2021.json,
   accept_ren2014.json, fluxgate_sphere.png, circles.png, errors_li2021.png,
   errors_ren2014.png (and run_circles.png when the run holds circle
   rotations: `procedure="multi-position"`).

`inclino demo --core` is the earlier demo: a table of turntable poses read by
ideal sensors, through the firmware's C core and the float64 reference side
by side (for firmware engineers).
"""
from __future__ import annotations

import os
import time
from dataclasses import dataclass, field

from inclino.formats import safeio

# (inclination, azimuth, toolface) in degrees; Li 2021 Table 1 position 1 is
# (90, 0, 180): X down, Y west, Z north.
POSES = [
    (0.0, 0.0, 0.0),
    (0.3, 120.0, 40.0),
    (2.0, 45.0, 30.0),
    (10.0, 90.0, 120.0),
    (30.0, 135.0, 200.0),
    (45.0, 200.0, 300.0),
    (60.0, 270.0, 45.0),
    (90.0, 0.0, 180.0),
    (90.0, 315.0, 90.0),
    (120.0, 30.0, 10.0),
    (178.0, 100.0, 250.0),
]
DEFAULT_OUT = "inclino-demo"
DEMO_AVERAGE = 16  # samples per reading (the probe's default), set explicitly so the run records it
# The Li acceptance at the three toolfaces the fit's prediction is made for (calib/predict.GRID): at one
# toolface a horizontal accelerometer error is the same on every azimuth of a row, and the six positions at
# I = 2 deg, where the reading noise turns the azimuth most, make most of the grid's RMS -- one such grid's
# RMS strays from its expectation by -37/+37 % (5-95 %), three toolfaces' by -22/+23 %.
DEMO_TOOLFACES = {"li2021": (0.0, 120.0, 240.0), "ren2014": (0.0,)}


# ---------------------------------------------------------------- --core
@dataclass
class DemoResult:
    poses: object
    fixed: dict
    ref: dict
    field_nT: float
    dip_deg: float


def run(field_nT: float = 50000.0, dip_deg: float = 60.0) -> DemoResult:
    import numpy as np

    from inclino.engines import attitude as engines, reference

    p = np.array(POSES)
    g, b = reference.body_vectors(p[:, 0], p[:, 1], p[:, 2], field_nT, dip_deg)
    acc = reference.quantise_acc(g) * reference.ACC_LSB_G
    mag = reference.quantise_mag(b) * reference.MAG_LSB_NT
    return DemoResult(p, engines.run(acc, mag, None, "firmware"), engines.run(acc, mag, None, "reference"),
                      field_nT, dip_deg)


def render(r: DemoResult) -> str:
    from inclino.engines import golden

    head = (f"Ideal probe on a turntable, field {r.field_nT:g} nT, dip {r.dip_deg:g} deg; "
            "C = the firmware's fixed-point core (via cffi), F = float64 reference on the same counts\n")
    cols = (f"{'set I':>6} {'set A':>6} {'set T':>6} | {'C inc':>9} {'F inc':>9} | {'C azi':>9} {'F azi':>9} |"
            f" {'C tf':>9} {'F tf':>9} | {'C Gt':>7} {'C Bt':>8} {'C dip':>7} | flags")
    lines = [head, cols, "-" * len(cols)]
    for i, (I, A, T) in enumerate(r.poses):
        f, e = r.fixed, r.ref
        fl = int(f["flags"][i])
        lines.append(
            f"{I:6.1f} {A:6.1f} {T:6.1f} | {f['inc_deg'][i]:9.4f} {e['inc_deg'][i]:9.4f} |"
            f" {f['azi_deg'][i]:9.4f} {e['azi_deg'][i]:9.4f} | {f['tf_deg'][i]:9.4f} {e['tf_deg'][i]:9.4f} |"
            f" {f['gt_g'][i]:7.5f} {f['bt_nT'][i]:8.1f} {f['dip_deg'][i]:7.3f} | "
            + (",".join(golden.flag_names(fl)) or "-"))
    lines.append("")
    lines.append("Azimuth and toolface are undefined where the near-vertical flag is set (I < 0.5 deg).")
    return "\n".join(lines)


# ---------------------------------------------------------------- the calibration demo
@dataclass
class CalibrationDemo:
    out_dir: str
    probe_serial: int = 0
    run_rows: int = 0
    fit_passed: bool = False
    fit_summary: str = ""
    download: dict = field(default_factory=dict)
    verify_ok: bool = False
    accept: dict = field(default_factory=dict)  # grid -> AcceptResult
    prediction: dict = field(default_factory=dict)  # the fit's acceptance prediction (calib/predict.py)
    agreement: str = ""  # the prediction against the Li acceptance
    files: list = field(default_factory=list)
    timings: dict = field(default_factory=dict)
    elapsed_s: float = 0.0
    bench: dict = field(default_factory=dict)  # the run's bench time and, adaptive, its stop


def calibration_demo(out_dir: str = DEFAULT_OUT, scenario: str = "typical", seed: int | None = None,
                     procedure: str = "adaptive", grids=("li2021", "ren2014"), quiet: bool = False,
                     say=None, figures: bool = True) -> CalibrationDemo:
    """The whole calibration procedure on the emulated probe and its turntable;
    prints each step with `say`.  figures=False skips the PNGs (the demo
    benchmark, which runs it over seeds)."""
    from inclino.procedures import acquire as acq
    from inclino.procedures.turntable_emulated import EmulatedTurntable
    from inclino.procedures import accept as acc
    from inclino.link import operations as calops
    from inclino.formats import dataset
    from inclino.procedures import plots
    from inclino.calib import common, fit
    from inclino.errors import InclinoError
    from inclino.link.serial_link import ProbeLink

    say = say or (lambda m: print(m, flush=True))
    try:
        from inclino_emu.runner import Emulator
    except ImportError as e:
        raise InclinoError(f"the emulator is not installed: {e}")
    t_all = time.monotonic()
    res = CalibrationDemo(os.path.abspath(out_dir))
    try:
        os.makedirs(out_dir, exist_ok=True)
    except OSError as e:
        from inclino.errors import DataError

        raise DataError(f"cannot create {out_dir}: {e.strerror}")
    run_csv, cal_json = os.path.join(out_dir, "run.csv"), os.path.join(out_dir, "cal.json")
    n_steps = 5

    def step(k, text):
        say(f"[{k}/{n_steps}] {text}")

    def lap(name, t0):
        res.timings[name] = round(time.monotonic() - t0, 2)

    t0 = time.monotonic()
    step(1, f"starting the emulated probe ({scenario} scenario, unthrottled) ...")
    from inclino.model.scenario import Scenario, load_scenario
    from inclino.model.world import MOTORISED, TurntableMotion

    sc = scenario if isinstance(scenario, Scenario) else load_scenario(scenario)
    sc.world.turntable.motion = TurntableMotion(**MOTORISED)  # the moves take a motorised table's time
    emu = Emulator(sc, seed=seed, control_port=0, realtime=False, hold_idle=True).start()
    table = None
    try:
        table = EmulatedTurntable(f"127.0.0.1:{emu.control_port}")
        with ProbeLink(emu.path, timeout=2.0) as link:
            ident = link.identify()
            res.probe_serial = ident.serial
            say(f"      {ident.product} fw {'.'.join(map(str, ident.fw_version))}, serial {ident.serial}, "
                f"calibration: {'none (identity)' if ident.cal_slot == 0xFF else ident.cal_slot}; "
                f"port {emu.path}, bench 127.0.0.1:{emu.control_port}")
            lap("start", t0)

            t0 = time.monotonic()
            step(2, f"acquiring a{'n' if procedure[0] in 'aeiou' else ''} {procedure} calibration run on the "
                    f"emulated turntable -> {run_csv}")
            a0 = float(table.call("status")["active_s"])
            if procedure == "adaptive":
                from inclino.procedures.adaptive import AdaptivePlan, acquire_adaptive

                r = acquire_adaptive(link, run_csv, table, AdaptivePlan(average=DEMO_AVERAGE), quiet=quiet)
            else:
                r = acq.acquire(link, procedure, run_csv, table, quiet=quiet, average=DEMO_AVERAGE)
            res.run_rows = r.rows
            res.bench = {"bench_s": float(table.call("status")["active_s"]) - a0,
                         "turntable": dict(MOTORISED)}
            say(f"      {r.rows} positions, {r.reads} readings, field {r.meta.get('field_nT', 0):g} nT, dip "
                f"{r.meta.get('dip_deg', 0):g} deg; bench time {res.bench['bench_s'] / 60:.1f} min "
                f"(turntable {MOTORISED['rate_deg_s']:g} deg/s, {MOTORISED['settle_s']:g} s to settle)")
            if procedure == "adaptive":
                pa = (r.prediction or {}).get("acceptance_grid") or {}
                res.bench.update({"stop": r.stop_reason, "targets": r.targets, "planning_s": r.planning_s,
                                  "predicted_azi_rms_deg": pa.get("azi_rms_deg"),
                                  "trace": [{k: t[k] for k in ("pose", "bench_s", "predicted_azi_deg",
                                                               "predicted_inc_deg")} for t in r.trace]})
                say(f"      stopped: {r.stop_reason}; predicted acceptance azimuth RMS "
                    f"{pa.get('azi_rms_deg', float('nan')):.4f} deg (target {r.targets.get('azi_deg') or 0:.4f}), "
                    f"inclination {pa.get('inc_rms_deg', float('nan')):.4f} deg; the host computed "
                    f"{r.planning_s:.1f} s between readings")
            lap("acquire", t0)

            t0 = time.monotonic()
            step(3, f"fitting with joint -> {cal_json}")
            ds = dataset.read_raw(run_csv)
            cal, rep = fit(ds, "joint", data_hash=common.file_hash(run_csv, ds))
            cal.save(cal_json)
            res.prediction = rep.uncertainty.get("prediction_acceptance_grid") or {}
            res.fit_passed, res.fit_summary = rep.passed, rep.summary()
            say("      " + res.fit_summary.replace("\n", "\n      "))
            lap("fit", t0)

            t0 = time.monotonic()
            step(4, "downloading (write, read back, activate) and verifying bit for bit")
            d = calops.download(link, cal)
            res.download = {"slot": d.slot, "sequence": d.sequence, "image_crc": f"{d.image_crc:04X}"}
            v = calops.verify(link, cal)
            res.verify_ok = v.ok
            say(f"      slot {d.slot}, sequence {d.sequence}, image CRC {d.image_crc:04X}; verify: storage "
                f"{'pass' if v.storage_ok else 'FAIL'}, correction {'pass' if v.correction_ok else 'FAIL'} "
                f"({v.checks} surveys bit for bit)")
            if not v.ok:
                raise InclinoError("verify failed: " + "; ".join(v.mismatches))
            lap("download_verify", t0)

            t0 = time.monotonic()
            step(5, f"acceptance grids {', '.join(grids)}: before = identity (as delivered), after = joint")
            for g in grids:
                a = acc.accept(link, table, g, before="identity", circles=(g == "li2021"), quiet=quiet,
                               average=DEMO_AVERAGE, toolfaces=DEMO_TOOLFACES.get(g, (0.0,)))
                res.accept[g] = a
                path = os.path.join(out_dir, f"accept_{g}.json")
                safeio.write_output(path, a.to_json() + "\n")
                res.files.append(path)
                say("")
                say(acc.render(a))
                say("")
            lap("accept", t0)
    finally:
        if table is not None:
            table.close()
        emu.stop()
    t0 = time.monotonic()
    res.files += [run_csv, cal_json]
    if figures:
        res.files += plots.run_figures(dataset.read_raw(run_csv), cal, out_dir)
        for a in res.accept.values():
            res.files += plots.accept_figures(a, out_dir)
        lap("plots", t0)
    res.agreement = prediction_agreement(res.prediction, res.accept.get("li2021"), scenario,
                                         run=dataset.read_raw(run_csv), cal=cal)
    res.elapsed_s = time.monotonic() - t_all
    return res


def multi_position_minutes(turntable: dict, average: int = DEMO_AVERAGE, reads: int = 3) -> float:
    """The bench time of `acquire --procedure multi-position` on a turntable
    of this motion (world.TurntableMotion) from home, by the motion model:
    its moves plus `reads` readings a pose (docs/emulator.md: 0.09 s a
    16-sample reading)."""
    import numpy as np

    from inclino.model.world import TurntableMotion
    from inclino.procedures.acquire import procedure_steps

    m = TurntableMotion(**turntable)
    st = procedure_steps("multi-position")
    p = np.array([(0.0, 0.0, 0.0)] + [(x.inc, x.azi, x.tf) for x in st])
    moves = m.duration(tuple(p[:-1].T), tuple(p[1:].T))
    read = reads * (0.0052 * average + 0.007)
    return float((moves.sum() + read * len(st)) / 60.0)


def acting_effects(scenario: str, run, acc_li, cal) -> list[tuple[str, float]]:
    """The emulated probe's effects that the prediction leaves out, each with
    the azimuth RMS it puts on this acceptance (deg): only what can act in
    this run.  A temperature coefficient acts through the difference between
    each acceptance reading's temperature and the calibration run's mean
    (at one constant temperature it is a bias and a scale the calibration
    took in, and is not listed); the fluxgate's sampling skew only while the probe turns (the
    demo's readings are static); turntable encoder or axis errors and a
    field drift of the scenario's world act wherever they are set."""
    import numpy as np

    from inclino.engines import reference as ref
    from inclino.calib.predict import raw_sensitivity

    try:
        from inclino.model.scenario import load_scenario

        s = load_scenario(scenario)
    except Exception:
        return []
    pts = [p for p in acc_li.points if p.get("after")]
    if not pts:
        return []
    I, A, T = (np.array([p["pose"][k] for p in pts], float) for k in range(3))
    w = s.world
    g, f = ref.body_vectors(I, A, T, w.earth.field_nT, w.earth.dip_deg, 0.0, w.gravity_g)
    t_run = float(np.mean(run.columns["temp_c"])) if "temp_c" in run.columns else None
    t_pts = np.array([p.get("temp_c", np.nan) if p.get("temp_c") is not None else np.nan for p in pts], float)
    out = []
    tempco = {(tri, attr) for tri in ("acc", "mag") for attr in ("bias_tempco", "scale_tempco")
              if getattr(getattr(s, tri), attr, None) is not None}
    # a temperature difference below this is the arithmetic of one constant temperature (the run's mean of
    # equal values against each of them: 3.6e-15 degC in the demo), not a difference a coefficient acts through
    same_temp_c = 1e-6
    if tempco:
        names = ", ".join(f"{'accelerometer' if t == 'acc' else 'fluxgate'} {a.replace('_', ' ')} coefficient"
                          for t, a in sorted(tempco))
        if t_run is None or not np.all(np.isfinite(t_pts)):
            out.append((f"temperature coefficients ({names}): the temperatures are not recorded", float("nan")))
        elif float(np.max(np.abs(t_pts - t_run))) > same_temp_c:
            ya = np.array([s.acc.deterministic(g[i], t_pts[i]) - s.acc.deterministic(g[i], t_run)
                           for i in range(len(pts))])
            ym = np.array([s.mag.deterministic(f[i], t_pts[i]) - s.mag.deterministic(f[i], t_run)
                           for i in range(len(pts))])
            acc0 = np.array([s.acc.deterministic(g[i], t_run) for i in range(len(pts))])
            mag0 = np.array([s.mag.deterministic(f[i], t_run) for i in range(len(pts))])
            Ra, _ = raw_sensitivity(cal, acc0, mag0)
            da = np.einsum("nk,nk->n", Ra, np.concatenate([ya, ym], 1))
            ok = I >= 0.5  # the acceptance counts azimuth wherever the probe does not flag near-vertical
            dT = float(np.max(np.abs(t_pts - t_run)))
            out.append((f"temperature coefficients ({names}) over {dT:.2g} degC between the run and the "
                        f"acceptance", float(np.sqrt(np.mean(da[ok] ** 2)))))
    enc = getattr(w.turntable, "encoder", None)
    if enc is not None and (np.any(enc.offset_deg != 0) or np.any(enc.scale != 0)):
        out.append(("turntable encoder errors", float("nan")))
    if getattr(w.turntable, "geometry", None) is not None:
        out.append(("turntable axis errors", float("nan")))
    drift = getattr(w, "drift", None)
    if drift is not None and any(getattr(drift, k, 0.0) for k in ("rate_nT_per_s", "dip_rate_deg_per_s",
                                                                   "declination_rate_deg_per_s")):
        out.append(("field drift", float("nan")))
    return out


def _spread(pred: dict, acc_li, run, cal, band) -> dict:
    """calib.predict.rms_spread for the acceptance grid that was run."""
    import numpy as np

    try:
        from inclino.calib.common import world_of
        from inclino.calib.predict import rms_spread

        u = cal.report["uncertainty"]
        grid = tuple(np.array([p["pose"][k] for p in acc_li.points], float) for k in range(3))
        sg = pred["sigmas"]
        return rms_spread(cal, u["covariance"], world_of(run), u.get("dip_deg", run.meta.get("dip_deg")),
                          sg["acc_g"], sg["mag_nT"], grid, band=band, sigma_pose_deg=sg.get("pose_deg"))
    except (KeyError, TypeError, ValueError, AttributeError):
        return {}


def prediction_agreement(pred: dict, acc_li, scenario: str, band=(0.7, 1.4), run=None, cal=None) -> str:
    """One line: the fit's predicted acceptance azimuth RMS against the Li
    acceptance's.  Outside the band it names only the effects outside the
    prediction that act in this run, with the azimuth RMS each puts on the
    acceptance (an effect that cannot act here is not named), and says how
    far a finite grid's RMS strays from its expectation by chance."""
    import numpy as np

    if not pred or acc_li is None:
        return ""
    p, a = pred["azi_rms_deg"], acc_li.stats["after"]["azi_rms_deg"]
    r = a / p if p > 0 else float("inf")
    line = (f"prediction: azimuth RMS {p:.4f} deg predicted by the fit for an acceptance on the Li grid, "
            f"{a:.4f} measured: ratio {r:.2f}")
    if band[0] <= r <= band[1]:
        return line + f" (within {band[0]:g}-{band[1]:g}: the prediction holds)"
    acting = acting_effects(scenario, run, acc_li, cal) if (run is not None and cal is not None) else []
    big = [(n, v) for n, v in acting if not np.isfinite(v) or v >= 0.1 * p]
    small = [(n, v) for n, v in acting if np.isfinite(v) and v < 0.1 * p]
    why = ""
    if big:
        why = " effects outside the prediction act in this run: " + "; ".join(
            n + (f" ({v:.4f} deg azimuth RMS)" if np.isfinite(v) else "") for n, v in big)
    else:
        why = " no effect outside the prediction acts in this run"
        if small:
            why += " (" + "; ".join(f"{n}: {v:.2g} deg azimuth RMS" for n, v in small) + ", too small to matter)"
        sp = _spread(pred, acc_li, run, cal, band)
        if sp:
            why += (f"; by chance alone one grid's RMS is {sp['ratio_p5']:.2f}-{sp['ratio_p95']:.2f} times the "
                    f"prediction (5-95 %) and outside {band[0]:g}-{band[1]:g} in {100 * sp['p_outside_band']:.0f} % of "
                    "checks: the reading noise at the near-vertical positions dominates it")
    return line + f" (outside {band[0]:g}-{band[1]:g}:" + why + "; the prediction covers the coefficients, " \
        "the readings' own noise per channel, the pose error, the resolution and the fitted nonlinearity)"


def summary(res: CalibrationDemo) -> str:
    lines = ["Summary"]
    for g, a in res.accept.items():
        b, f = a.stats["before"], a.stats["after"]
        lines.append(f"  {g:8s} azimuth RMS {b['azi_rms_deg']:.3f} -> {f['azi_rms_deg']:.3f} deg "
                     f"(max {b['azi_max_deg']:.3f} -> {f['azi_max_deg']:.3f}); inclination RMS "
                     f"{b['inc_rms_deg']:.3f} -> {f['inc_rms_deg']:.3f} deg (max {b['inc_max_deg']:.3f} -> "
                     f"{f['inc_max_deg']:.3f}); {'PASS' if a.passed else 'FAIL'}")
    if res.bench:
        b = res.bench
        line = f"  bench time of the run: {b['bench_s'] / 60:.1f} min for {res.run_rows} poses"
        if "stop" in b:
            line += (f" (stopped: {b['stop']}); the multi-position procedure's 94 poses take "
                     f"{multi_position_minutes(b['turntable']):.1f} min on the same table")
        lines.append(line)
    if res.agreement:
        lines.append("  " + res.agreement)
    lines.append(f"  files in {res.out_dir}/: " + ", ".join(sorted(os.path.basename(p) for p in res.files)))
    t = res.timings
    lines.append(f"  {res.elapsed_s:.1f} s (" + ", ".join(f"{k} {v:.1f} s" for k, v in t.items()) + ")")
    return "\n".join(lines)
