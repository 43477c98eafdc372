"""`inclino demo --chamber`: the temperature step on the emulated probe.

1. start the emulated probe (typical scenario, its tempcos drawn from the
   scenario's spread: `--tempco-draw`, default 1) with its thermal chamber;
2. acquire a chamber run on the emulated turntable (`inclino acquire
   --procedure temperature`, set points -5, 25, 55 degC by default);
3. fit it with joint and its temperature terms (`inclino calibrate --method
   joint --temperature-terms on`) and print them, with the azimuth and
   inclination error over the run's temperatures with and without them;
4. diagnose the run as it is and with the terms applied (`inclino diagnose`,
   `--cal`): the temperature effects named before and after, with their
   estimates (what the terms leave is at the level of TEMP_OUT's 0.47 degC
   counts);
5. download the calibration with its terms to the same emulated probe and
   check it at each set point (`inclino accept --temperatures`): the Li 2021
   grid through the temperature engine (inclino.engines.temperature: the firmware's
   correction; while the firmware does not apply the terms, the terms on the
   host before the firmware's C, and the result says so), with the terms and
   without them, the gain and the ratio to the 25 degC figure (the set point
   nearest the terms' t_ref when 25 is not among them).

Files in -o: run_temperature.csv, cal_temperature.json,
accept_temperature.json (accept_temp.TempAcceptResult).  `inclino demo
--chamber` exits 0 when the fit passed and, at every set point other
than the reference, the terms brought the acceptance grid's azimuth and
inclination RMS down (gain > 1); the 1.2x verdict of step 5 is printed and
saved, not the exit status (`inclino accept --temperatures` exits on it).
"""
from __future__ import annotations

import os
import time


def run(out_dir: str, tempco_draw: int = 1, setpoints=(-5.0, 25.0, 55.0), seed: int | None = None,
        quiet: bool = False, say=None) -> dict:
    from inclino.procedures.turntable_emulated import EmulatedTurntable
    from inclino.procedures import accept_temp, acquire_temp
    from inclino.formats import safeio
    from inclino.errors import DataError, InclinoError
    from inclino.link.serial_link import ProbeLink

    say = say or (lambda m: print(m, flush=True))
    try:
        from inclino_emu.runner import Emulator
    except ImportError as e:
        raise InclinoError(f"the emulator is not installed: {e}")
    try:
        os.makedirs(out_dir, exist_ok=True)
    except OSError as e:
        raise DataError(f"cannot create {out_dir}: {e.strerror}")
    plan = acquire_temp.ThermalPlan(setpoints=tuple(setpoints))
    plan.check()
    run_csv = os.path.join(out_dir, "run_temperature.csv")
    cal_json = os.path.join(out_dir, "cal_temperature.json")
    acc_json = os.path.join(out_dir, "accept_temperature.json")
    t_all = time.monotonic()
    out = {"files": [run_csv, cal_json, acc_json]}
    say(f"[1/5] starting the emulated probe (typical scenario, tempcos drawn with seed {tempco_draw}, "
        "a thermal chamber at 25 degC, probe time constant 600 s; unthrottled) ...")
    emu = Emulator("typical", seed=seed, control_port=0, realtime=False, tempco_draw=tempco_draw).start()
    table = None
    try:
        table = EmulatedTurntable(f"127.0.0.1:{emu.control_port}")
        with ProbeLink(emu.path, timeout=2.0) as link:
            say(f"[2/5] acquiring a chamber run, set points {', '.join(f'{t:g}' for t in setpoints)} degC "
                f"(ramp {plan.ramp_rate:g} degC/min; emulated time runs ahead) -> {run_csv}")
            r = acquire_temp.acquire_temperature(link, run_csv, table, plan, quiet=quiet)
            out["rows"] = r.rows
            for n in r.notes:
                say(f"      {n['setpoint_c']:g} degC: settled after {n['soak_min']:g} min of chamber time, "
                    f"probe at {n['probe_c']:.2f} degC")
            say(f"      {r.rows} rows, {r.reads} readings, {r.elapsed_s:.1f} s")
            cal = _fit_and_diagnose(run_csv, cal_json, out, say)
            ref_c = min(setpoints, key=lambda t: abs(t - float(cal.temperature["t_ref_c"])))
            say(f"[5/5] downloading the calibration with its terms and checking it at "
                f"{', '.join(f'{t:g}' for t in setpoints)} degC (the Li 2021 grid; with and without the terms, "
                f"against {ref_c:g} degC) -> {acc_json}")
            res = accept_temp.accept_temperatures(link, table, cal, tuple(setpoints), reference_c=ref_c,
                                                  quiet=quiet)
    finally:
        if table is not None:
            table.close()
        emu.stop()
    safeio.write_output(acc_json, res.to_json() + "\n")
    for line in accept_temp.render(res).splitlines():
        say("      " + line)
    out["accept"] = {"passed": res.passed, "engine": res.engine, "terms_in_firmware": res.terms_in_firmware,
                     "setpoints": res.setpoints}
    gains = [s[f"{q}_gain"] for s in res.setpoints if s["setpoint_c"] != ref_c for q in ("azi", "inc")]
    out["accept_gain_min"] = min(g for g in gains if g is not None) if gains else None
    out["elapsed_s"] = time.monotonic() - t_all
    worst = max(cal.temperature["error_over_range"], key=lambda x: x["azi_rms_without_deg"])
    out["gain"] = worst["azi_rms_without_deg"] / max(worst["azi_rms_with_deg"], 1e-9)
    say(f"Summary: order {cal.temperature['order']} terms; acceptance grid through the {res.engine} engine: "
        + "; ".join(f"{s['setpoint_c']:g} degC azimuth RMS {s['with']['azi_rms_deg']:.3f} deg with the terms, "
                    f"{s['without']['azi_rms_deg']:.3f} without" for s in res.setpoints)
        + f"; 1.2x verdict {'PASS' if res.passed else 'FAIL'}; {out['elapsed_s']:.1f} s; files in {out_dir}/")
    return out


def _fit_and_diagnose(run_csv, cal_json, out, say):
    from inclino.formats import dataset
    from inclino.calib import common, fit, thermal
    from inclino.diagnose.analysis import diagnose

    say(f"[3/5] fitting joint with its temperature terms -> {cal_json}")
    ds = dataset.read_raw(run_csv)
    cal, rep = fit(ds, "joint", data_hash=common.file_hash(run_csv, ds), temperature="on")
    cal.save(cal_json)
    out["passed"] = rep.passed
    out["temperature"] = cal.temperature
    say("      " + rep.summary().replace("\n", "\n      "))
    say(thermal.summary(cal.temperature))
    say("[4/5] diagnosing the run as it is, then with the temperature terms applied")
    named = {}
    for label, d in (("as acquired", ds), ("with the terms", thermal.corrected_dataset(ds, cal, cal.temperature))):
        dg = diagnose(d)
        names = [f"{e.name} ({e.sensor} {e.axis}) {e.estimate:.3g} {e.units}" for e in dg.effects
                 if e.name.startswith("temperature-")]
        named[label] = names
        say(f"      {label}: temperature effects named: {'; '.join(names) if names else 'none'}")
    out["diagnose_temperature_effects"] = named
    return cal
