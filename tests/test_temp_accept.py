"""The temperature terms measured where they act: a probe with hidden
tempcos (drawn at test time from the typical scenario's spread: every bias
and scale coefficient, first and second order, of every axis of both triads,
unknown to the test in size and axis) is calibrated from an emulated chamber
run and checked at -5, 25 and 55 degC through the temperature engine
(inclino.engines.temperature: the firmware's correction); `inclino accept
--temperatures` end to end on the emulator; its refusals."""
import json

import numpy as np
import pytest

from inclino import cli
from inclino.engines import firmware as core
from inclino.engines import temperature as temp_engine
from inclino.formats.calfile import Calibration
from inclino.benchmarks import calibration_temperature as bench_temp
from inclino_emu.probe import EmulatedProbe
from inclino_emu.runner import Emulator
from chamber_person import PersonAtChamber
from conftest import test_seed

RNG_SEED = test_seed()  # named in a failing test's report (conftest)
RNG = np.random.default_rng(RNG_SEED)

CHECK = (-5.0, 25.0, 55.0)


@pytest.fixture(scope="module")
def chamber_calibrated(tmp_path_factory):
    """(seed, scenario, calibration, CAL.json path) of a probe drawn now,
    calibrated from its emulated chamber run (acquire --procedure
    temperature, joint --temperature-terms on)."""
    seed = int(RNG.integers(1 << 20))
    d = tmp_path_factory.mktemp("chamber")
    sc = bench_temp.drawn_probe(seed)
    run = str(d / "run.csv")
    bench_temp.chamber_run(sc, run, CHECK, emu_seed=seed)
    from inclino.formats.dataset import read_raw

    assert int(read_raw(run).meta["samples_averaged"]) == 64  # the procedure's default (acquire_temp)
    cal, rep = bench_temp.fit_with_terms(run)
    path = str(d / "cal.json")
    cal.save(path)
    return seed, sc, cal, path


def test_chamber_calibrated_probe_meets_the_1_2x_target_through_the_engine(chamber_calibrated):
    """Issue 12's Done when: with the temperature terms, azimuth and
    inclination RMS on the acceptance grid (as the probe reads it, the
    expected RMS over bench_temp.REPEATS takings of the grid) at -5 and 55 degC
    within 1.2x the same probe's 25 degC figure; without the terms far
    outside it.  The margin (docs/calibration.md, `python -m
    inclino.cli.bench_temperature --probes 24 --seed 510`): the target is
    many standard deviations above the probes' worst ratio."""
    seed, sc, cal, _ = chamber_calibrated
    eng = temp_engine.get("auto")
    chk = bench_temp.check_probe(sc, cal, eng, CHECK, 25.0, seed=seed)
    for r in chk["setpoints"]:
        assert r["azi_ratio_with"] <= bench_temp.TARGET_RATIO, (seed, r)
        assert r["inc_ratio_with"] <= bench_temp.TARGET_RATIO, (seed, r)
    for r in chk["calibration_only"]:  # the noise-free grid: what the terms remove
        if r["setpoint_c"] != 25.0:
            assert r["azi_gain"] >= 3.0 and r["inc_gain"] >= 3.0, (seed, r)
            assert r["azi_rms_with_deg"] < 0.05, (seed, r)


def test_engine_without_terms_is_the_firmware_with_m_b(chamber_calibrated):
    """terms=False is the firmware's survey with the calibration's M, b bit
    for bit; a temperature block whose terms are zero changes nothing."""
    _, _, cal, _ = chamber_calibrated
    rng = RNG
    n = 50
    acc = rng.integers(-16384 * 64, 16384 * 64, (n, 3))
    mag = rng.integers(-60000 * 64, 60000 * 64, (n, 3))
    tcc = temp_engine.temp_q6_of(rng.uniform(-20, 70, n))
    eng = temp_engine.get("auto")
    out = eng.survey(acc, mag, tcc, cal, terms=False)
    ref = core.survey(acc, mag, cal.to_fixed())
    for k in core.ATT_COLS:
        assert np.array_equal(out[k], ref[k]), k
    zero = temp_engine.without_terms(cal)
    zero.temperature = json.loads(json.dumps(cal.temperature))
    for tri in ("acc", "mag"):
        for key in ("bias", "scale_ppm"):
            zero.temperature[tri][key] = np.zeros_like(np.asarray(cal.temperature[tri][key])).tolist()
    z = eng.survey(acc, mag, tcc, zero, terms=True)
    for k in core.ATT_COLS:
        assert np.array_equal(z[k], ref[k]), k


@pytest.mark.heavy
def test_firmware_engine_is_the_golden_model_and_the_host_model(chamber_calibrated):
    """With the terms, the firmware's C and the golden model agree bit for
    bit on random readings and temperatures; on the noise-free grid at -5,
    25 and 55 degC the firmware's fixed-point temperature path stays within
    0.005 deg of the terms applied in float64 (host-terms)."""
    seed, sc, cal, _ = chamber_calibrated
    fw, gd, ht = (temp_engine.get(n) for n in ("firmware", "golden", "host-terms"))
    rng = RNG
    n = 200
    acc = rng.integers(-16384 * 64, 16384 * 64, (n, 3))
    mag = rng.integers(-60000 * 64, 60000 * 64, (n, 3))
    tq6 = temp_engine.temp_q6_of(rng.uniform(-40, 125, n)) + rng.integers(-63, 64, n)
    a, g = fw.survey(acc, mag, tq6, cal), gd.survey(acc, mag, tq6, cal)
    for k in core.ATT_COLS:
        assert np.array_equal(a[k], g[k]), k
    for T in CHECK:
        grid, acc, mag, tq = bench_temp.grid_readings(sc, T)
        a, h = fw.survey(acc, mag, tq, cal), ht.survey(acc, mag, tq, cal)
        assert np.abs(a["inc"] - h["inc"]).max() / 65536.0 < 0.005, (seed, T)
        ok = grid[0] >= 5.0
        assert np.abs(((a["azi"] - h["azi"])[ok] / 65536.0 + 180.0) % 360.0 - 180.0).max() < 0.005, (seed, T)


def test_temp_q6_is_what_the_probe_reports():
    """temp_engine.temp_q6_of (the temperature the bench's grids hand the
    engine) against the emulated probe's own averaged reading."""
    p = EmulatedProbe(bench_temp.drawn_probe(1))
    p.poll = p.lib.app_main_poll
    for T in RNG.uniform(-30.0, 80.0, 4):
        p.phys.set_temperature(float(T))
        r = p.raw()
        assert r["temp_q6"] == int(temp_engine.temp_q6_of(T)), T
        assert int(temp_engine.temp_q6_from_centi(round(r["temp_c"] * 100))) == r["temp_q6"], T


def test_accept_temperatures_cli_on_the_emulator(chamber_calibrated, tmp_path, capsys):
    seed, _, cal, path = chamber_calibrated
    emu = Emulator(bench_temp.drawn_probe(seed), seed=seed + 1, control_port=0, realtime=False).start()
    save = tmp_path / "acc_t.json"
    try:
        rc = cli.main(["accept", "--port", emu.path, "--bench", f"127.0.0.1:{emu.control_port}", "--cal", path,
                       "--temperatures", "-5,25,55", "--toolfaces", "0", "--vertical-takings", "3", "--force", "--quiet",
                       "--json", "-o", str(save)])
    finally:
        emu.stop()
    out, err = capsys.readouterr()
    r = json.loads(out)  # the exit status follows the verdict (below)
    assert json.loads(save.read_text()) == r
    # 0 when no ratio is above the target by more than --significance-z of its uncertainties, 1 with the
    # reasons otherwise (docs/calibration.md: the pooled takings and the ratio's uncertainty)
    assert rc == (0 if r["passed"] else 1) and r["passed"] == (not r["reasons"]), (rc, r["reasons"], err)
    # the text report ends with its verdict and, on a pass, the largest ratio with the terms it rests on
    from inclino.procedures.accept_temp import TempAcceptResult, render

    last = render(TempAcceptResult.from_json(out)).splitlines()[-1]
    if r["passed"]:
        worst = max((s[f"{q}_ratio_with"], s[f"{q}_ratio_with_u"]) for s in r["setpoints"] for q in ("azi", "inc")
                    if s["setpoint_c"] != 25.0)
        assert last.startswith(f"verdict: PASS: worst ratio with the terms {worst[0]:.2f} +- {worst[1]:.2f} ("), last
    else:
        assert last == "verdict: FAIL: " + "; ".join(r["reasons"])
    assert r["takings"] == 1 and r["vertical_takings"] == 3 and r["significance_z"] == 2.0
    assert r["setpoints_c"] == list(CHECK) and r["reference_c"] == 25.0 and r["target_ratio"] == 1.2
    assert r["engine"] == temp_engine.get("auto").name
    assert r["download"] and r["probe_serial"] == 1001
    assert not r["survey_mismatches"] and r["surveys_checked"] == sum(p["reads"] for p in r["points"])
    if r["terms_in_firmware"]:  # the "with" column is the probe's own correction
        assert r["with_equals_probe"] == r["surveys_checked"]
    assert len(r["points"]) == 3 * (66 + 2 * 6)  # the six I = 2 deg positions taken 3 times in all
    ref25 = next(s for s in r["setpoints"] if s["setpoint_c"] == 25.0)
    for s in r["setpoints"]:
        assert abs(s["probe_c_mean"] - s["setpoint_c"]) < 1.5
        for key in ("with", "without"):
            assert s[key]["azi_points"] == 66 and s[key]["inc_points"] == 66
            assert s[key]["azi_rows"] == 66 + 2 * 6 and s[key]["inc_rows"] == 66 + 2 * 6
        for q in ("azi", "inc"):
            ratio, u = s[f"{q}_ratio_with"], s[f"{q}_ratio_with_u"]
            assert (u == 0.0) if s["setpoint_c"] == 25.0 else (0.0 < u < 0.5 * ratio), (q, s)
            said = [x for x in r["reasons"] + r["above_within_uncertainty"] if f"at {s['setpoint_c']:g} degC" in x
                    and ("azimuth" if q == "azi" else "inclination") in x]
            assert (ratio > 1.2) == bool(said)
            assert (ratio - 2.0 * u > 1.2) == any(x in r["reasons"] for x in said)
        if s["setpoint_c"] != 25.0:  # the room-temperature-only calibration is off at the extremes
            for q, least in (("azi", 1.5), ("inc", 2.0)):
                # the same readings with and without: the terms remove the temperature's part where it
                # is at least the grid's noise (the 25 degC RMS), and most of it where it stands out (3x);
                # a drawn probe can have small tempcos on one triad (CI drew one whose inclination at
                # -5 degC was 1.5x its 25 degC figure without the terms: a gain of at most ~1.5)
                rms25 = ref25["with"][f"{q}_rms_deg"]
                effect = np.sqrt(max(s["without"][f"{q}_rms_deg"] ** 2 - rms25 ** 2, 0.0))
                if effect > rms25:
                    assert s[f"{q}_gain"] > 1.0, (q, s)
                if effect > 3.0 * rms25:
                    assert s[f"{q}_gain"] > least and s[f"{q}_ratio_without"] > 1.5 * s[f"{q}_ratio_with"], (q, s)
    assert Calibration.load(path).temperature["order"] == cal.temperature["order"]


@pytest.mark.parametrize("temps, why", [
    ("a,b", "comma-separated"), ("25", "at least one other"), ("-5,30", "must be one of the set points"),
    ("-50,25", "outside"), ("25,25,55", "twice"), ("", "comma-separated"), ("-5,,25", "comma-separated"),
])
def test_accept_temperatures_refusals(temps, why, capsys, chamber_calibrated):
    _, _, _, path = chamber_calibrated
    rc = cli.main(["accept", "--port", "/nonexistent/tty", "--cal", path, "--temperatures", temps])
    out, err = capsys.readouterr()
    assert rc == 2 and why in err and len(err.strip().splitlines()) == 1 and not out, (temps, err)


def test_accept_temperatures_needs_terms(tmp_path, capsys, chamber_calibrated):
    plain = tmp_path / "plain.json"
    Calibration().save(str(plain))
    outside = Calibration.load(chamber_calibrated[3])  # terms the image cannot hold: the probe would not apply them
    outside.temperature["applied_by_firmware"] = False
    outside.temperature["firmware"] = {"image_version": 1, "why_not": "a term beyond the image's range"}
    outside.save(str(tmp_path / "outside.json"))
    if temp_engine.firmware_available():
        rc = cli.main(["accept", "--port", "/nonexistent/tty", "--temperatures", "-5,25,55", "--cal",
                       str(tmp_path / "outside.json")])
        out, err = capsys.readouterr()
        assert rc == 3 and "cannot apply" in err and len(err.strip().splitlines()) == 1, err
    for args, why in ((["--cal", str(plain)], "no temperature terms"), ([], "needs --cal"),
                      (["--cal", chamber_calibrated[3], "--target-ratio", "0.5"], "--target-ratio"),
                      (["--cal", chamber_calibrated[3], "--circles"], "does not take"),
                      (["--cal", chamber_calibrated[3], "--takings", "0"], "--takings"),
                      (["--cal", chamber_calibrated[3], "--vertical-takings", "51"], "--vertical-takings"),
                      (["--cal", chamber_calibrated[3], "--significance-z", "nan"], "--significance-z")):
        rc = cli.main(["accept", "--port", "/nonexistent/tty", "--temperatures", "-5,25,55", *args])
        out, err = capsys.readouterr()
        assert rc == 2 and why in err and len(err.strip().splitlines()) == 1, (args, err)


def test_accept_temperatures_guides_a_person(chamber_calibrated):
    """Guided: the person is told each set point and pose; the probe's
    temperature is shown while it soaks."""
    from inclino.procedures.accept_temp import accept_temperatures
    from inclino.procedures.turntable import ManualTurntable
    from inclino.procedures.acquire_temp import ThermalPlan
    from inclino.link.serial_link import ProbeLink
    from inclino_emu.control import ControlClient

    seed, _, cal, _ = chamber_calibrated
    emu = Emulator(bench_temp.drawn_probe(seed), seed=seed + 2, control_port=0, realtime=False).start()
    try:
        ctl = ControlClient(port=emu.control_port)
        person = PersonAtChamber(ctl)
        table = ManualTurntable(stdin=person, say=person.say)
        plan = ThermalPlan(setpoints=(25.0, 40.0), ramp_rate=5.0, interval_min=5.0)
        with ProbeLink(emu.path, timeout=2.0) as link:
            r = accept_temperatures(link, table, cal, (25.0, 40.0), plan=plan, inclinations=(30.0, 60.0),
                                    azimuths=(0.0, 120.0, 240.0), toolfaces=(0.0,), quiet=True, force=True,
                                    sleep=person.sleep)
        ctl.close()
    finally:
        emu.stop()
    assert person.setpoints == [25.0, 40.0] and len(person.poses) == 2 * (1 + 6)
    assert any("probe at" in m for m in person.said)
    assert [s["setpoint_c"] for s in r.setpoints] == [25.0, 40.0] and len(r.points) == 12
    assert abs(r.setpoints[1]["probe_c_mean"] - 40.0) < 1.5 and not r.survey_mismatches


def test_pooled_stats_weigh_positions_equally_and_state_their_spread():
    """accept_temp.pooled_stats on rows drawn now: each position's squared
    error is the mean over its takings (a position taken 8 times weighs as
    one taken once), and the RMS's relative uncertainty it states from the
    readings' scatter matches the spread of the RMS over repeated draws
    (within -15 %, +35 %), for grids whose noise and systematic errors are drawn."""
    from inclino.procedures.accept_temp import pooled_stats

    rng = RNG
    P, R = 60, 3
    sys_err = rng.normal(0.0, rng.uniform(0.002, 0.01), P)  # the calibration's error at each position, deg
    sigma = rng.uniform(0.003, 0.01, P)  # one reading's noise, deg
    sigma[:6] *= rng.uniform(5.0, 15.0)  # near vertical: the noise makes the azimuth RMS
    takings = np.where(np.arange(P) < 6, 8, 1)

    def draw():
        rows = []
        for p in range(P):
            for _ in range(takings[p]):
                e = sys_err[p] + sigma[p] * rng.standard_normal(R)
                pt = {"inc_err": float(e.mean()), "azi_err": float(e.mean()),
                      "inc_var": float(e.var(ddof=1) / R), "azi_var": float(e.var(ddof=1) / R)}
                rows.append({"set_inc": float(p), "set_azi": 0.0, "tf": 0.0, "reads": R, "with": pt})
        return pooled_stats(rows, "with")

    stats = [draw() for _ in range(400)]
    rms = np.array([s["azi_rms_deg"] for s in stats])
    expected = np.sqrt(np.mean(sys_err ** 2 + sigma ** 2 / R))  # the expected RMS of one taking
    assert abs(rms.mean() / expected - 1.0) < 0.03, (rms.mean(), expected)
    stated = np.median([s["azi_rms_rel_u"] for s in stats])
    measured = rms.std(ddof=1) / rms.mean()
    assert 0.85 < stated / measured < 1.35, (stated, measured)  # the delta method: 2-15 % high here
    s = stats[0]
    assert s["azi_points"] == P and s["azi_rows"] == int(takings.sum()) and s["inc_rms_deg"] == s["azi_rms_deg"]
