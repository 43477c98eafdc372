"""The thermal chamber: the air's profile and the probe's lag (against a
numerical integration of the lag equation), the control channel's chamber
and advance commands and their refusals, the tempcos (order-2 polynomials,
a per-probe draw from the scenario's spread) reaching the probe's readings,
and `inclino acquire --procedure temperature` on the emulated bench."""
import math

import numpy as np
import pytest

from inclino.procedures import acquire_temp
from inclino.procedures.turntable import ManualTurntable
from inclino import cli
from inclino.formats import dataset
from inclino.link.serial_link import ProbeLink
from inclino.model import effects as fx
from inclino_emu.control import ControlClient
from inclino_emu.probe import EmulatedProbe
from inclino_emu.runner import Emulator
from inclino.model.scenario import load_scenario, scenario_from_dict
from inclino.model.world import Chamber
from chamber_person import PersonAtChamber


def _integrate(profile, tau, t0_c, t_end, dt=0.05):
    """The air's piecewise-linear profile and the probe's lag, integrated
    with small steps (RK4 on dTp/dt = (Tc - Tp) / tau), independent of
    Chamber's closed form.  profile: [(t_s, setpoint, rate_c_per_min)]."""
    # build the air as explicit pieces by walking the profile
    pieces = []  # (t_start, c_start, target, r)
    c = t0_c
    for k, (ts, sp, rate) in enumerate(profile):
        if pieces:
            p0 = pieces[-1]
            dtp = ts - p0[0]
            c = p0[2] if p0[3] == 0 else (p0[1] + math.copysign(min(abs(p0[2] - p0[1]), p0[3] * dtp), p0[2] - p0[1]))
        pieces.append((ts, c, sp, rate / 60.0))

    def air_at(t):
        c = t0_c
        for (ts, c0, target, r) in pieces:
            if t < ts:
                break
            if r == 0:
                c = target
            else:
                c = c0 + math.copysign(min(abs(target - c0), r * (t - ts)), target - c0)
        return c

    # integrate piece by piece between the air's breakpoints (set points and
    # ramp ends), the air evaluated strictly inside each piece
    bps = {0.0, t_end}
    for (ts, c0, target, r) in pieces:
        bps.add(ts)
        if r:
            bps.add(ts + abs(target - c0) / r)
    bps = sorted(b for b in bps if 0.0 <= b <= t_end)
    eps = 1e-9
    tp = t0_c
    out = []
    for a, b in zip(bps[:-1], bps[1:]):
        n = max(1, int(math.ceil((b - a) / dt)))
        h = (b - a) / n

        def f(tt, y):
            return (air_at(min(max(tt, a + eps), b - eps)) - y) / tau

        for i in range(n):
            t = a + i * h
            k1 = f(t, tp)
            k2 = f(t + h / 2, tp + h / 2 * k1)
            k3 = f(t + h / 2, tp + h / 2 * k2)
            k4 = f(t + h, tp + h * k3)
            tp += h / 6 * (k1 + 2 * k2 + 2 * k3 + k4)
            if i + 1 < n:   # not on a breakpoint, where the air may jump
                out.append((t + h, air_at(t + h), tp))
    return out


def test_chamber_lag_matches_a_numerical_integration(rng):
    tau = float(rng.uniform(20, 120))
    t0 = float(rng.uniform(-10, 40))
    prof = [(float(rng.uniform(5, 30)), float(rng.uniform(-30, 80)), float(rng.uniform(5, 30))),
            (float(rng.uniform(200, 300)), float(rng.uniform(-30, 80)), 0.0),
            (float(rng.uniform(400, 500)), float(rng.uniform(-30, 80)), float(rng.uniform(1, 30)))]
    ch = Chamber(t0, tau)
    for ts, sp, rate in prof:
        ch.set(ts, sp, rate)
    ref = _integrate(prof, tau, t0, 700.0)
    for t, air, tp in ref[::97]:
        assert ch.chamber_c(t) == pytest.approx(air, abs=1e-6)
        assert ch.at(t) == pytest.approx(tp, abs=1e-6), t
    # the array form is the scalar form, bit for bit
    ts = np.array([r[0] for r in ref[::50]])
    assert np.array_equal(ch(ts), np.array([ch.at(float(t)) for t in ts]))


def test_chamber_refusals():
    ch = Chamber(25.0, 60.0)
    ch.set(100.0, 40.0, 2.0)
    with pytest.raises(ValueError):
        ch.set(50.0, 30.0)                       # before the last set point
    for bad in (float("nan"), float("inf"), 500.0, -100.0):
        with pytest.raises(ValueError):
            ch.set(200.0, bad)
    for bad in (-1.0, float("nan"), 31.0):
        with pytest.raises(ValueError):
            ch.set(200.0, 30.0, bad)
    with pytest.raises(ValueError):
        Chamber(25.0, -1.0)


def test_scenario_chamber_profile_and_tempco_tables():
    d = {"world": {"chamber": {"temperature_c": 20.0, "tau_s": 0.0, "profile": [[10.0, 30.0, 30.0]]}},
         "acc": {"bias_tempco": {"value": [1e-5, 0, 0], "value2": [1e-7, 0, 0], "spread": 1e-5, "spread2": 0.0}},
         "mag": {"scale_tempco": {"ppm": [10.0, 0, 0], "ppm2": [0.1, 0, 0]}}}
    s = scenario_from_dict(d)
    p = s.probe()
    assert p.temperature(5.0) == 20.0 and p.temperature(15.0) == pytest.approx(22.5) and p.temperature(60.0) == 30.0
    assert s.acc.bias_tempco.c2[0] == 1e-7 and s.mag.scale_tempco.ppm2[0] == 0.1
    assert set(s.tempco_spread) == {"acc"}
    with pytest.raises(ValueError):
        scenario_from_dict({"acc": {"bias_tempco": {"value": 0.0, "spread": -1.0}}})


def test_tempco_polynomials_and_their_inverse(rng):
    bt = fx.BiasTempco(rng.normal(0, 3, 3), 25.0, rng.normal(0, 0.05, 3))
    st = fx.ScaleTempco(rng.normal(0, 50, 3), 25.0, rng.normal(0, 0.5, 3))
    T = rng.uniform(-20, 80, 50)
    v = rng.normal(0, 30000, (50, 3))
    dT = (T - 25.0)[:, None]
    assert np.allclose(bt.apply(v, T), v + bt.c * dT + bt.c2 * dT ** 2)
    assert np.allclose(st.apply(v, T), v * (1 + 1e-6 * (st.ppm * dT + st.ppm2 * dT ** 2)))
    # the calibration's inverse undoes the chain's temperature effects about the bias
    b = rng.normal(0, 200, 3)
    chain = fx.TriadModel(scale_tempco=st, bias=fx.Bias(b), bias_tempco=bt)
    y = chain.deterministic(v, T)
    y_ref = chain.deterministic(v, 25.0)
    assert np.allclose(fx.to_reference_temperature(y, T, b, bt, st), y_ref, atol=1e-6)
    assert np.allclose(fx.from_reference_temperature(y_ref, T, b, bt, st), y, atol=1e-6)


def test_tempco_draws_follow_the_spread():
    s = load_scenario("typical")
    a, a2, b = s.draw_tempcos(1), s.draw_tempcos(1), s.draw_tempcos(2)
    assert np.array_equal(a.mag.bias_tempco.c, a2.mag.bias_tempco.c)
    assert not np.array_equal(a.mag.bias_tempco.c, b.mag.bias_tempco.c)
    assert np.array_equal(s.mag.bias_tempco.c, load_scenario("typical").mag.bias_tempco.c)  # the original stays
    # over many probes the coefficients scatter by the spread about the scenario's value
    c = np.array([s.draw_tempcos(k).acc.scale_tempco.ppm for k in range(300)])
    s1, _ = s.tempco_spread["acc"]["scale_tempco"]
    assert np.allclose(c.mean(0), s.acc.scale_tempco.ppm, atol=4 * s1[0] / np.sqrt(300))
    assert np.allclose(c.std(0), s1, rtol=0.2)


@pytest.fixture
def emu(rng):
    e = Emulator("typical", control_port=0, realtime=False, tempco_draw=int(rng.integers(1000)))
    e.start()
    yield e
    e.stop()


def test_control_channel_chamber_and_advance(emu):
    ctl = ControlClient(port=emu.control_port)
    try:
        st = ctl.call("chamber")
        assert st["ok"] and st["setpoint_c"] == 25.0 and st["tau_s"] == 600.0
        st = ctl.call("chamber", setpoint_c=55.0, rate_c_per_min=1.0)
        assert st["ok"] and st["chamber_c"] == pytest.approx(25.0, abs=0.05)
        t0 = st["t"]
        a = ctl.call("advance", s=600.0)
        assert a["ok"] and a["t"] >= t0 + 600.0
        st = ctl.call("chamber")   # a 30 min ramp: still ramping (the emulator runs on between requests)
        assert st["chamber_c"] == pytest.approx(min(55.0, 25.0 + 1.0 * (st["t"] - t0) / 60.0), abs=0.01)
        assert 25.0 < st["probe_c"] < st["chamber_c"]                 # lagging behind the air
        # the probe warms while the emulator runs between two requests: the
        # truth's temperature lies between the chamber's reports before and after
        truth = ctl.call("truth")["temp_c"]
        after = ctl.call("chamber")["probe_c"]
        assert st["probe_c"] - 1e-9 <= truth <= after + 1e-9
        ctl.call("advance", s=86400.0)
        st = ctl.call("chamber")
        assert st["chamber_c"] == 55.0 and st["probe_c"] == pytest.approx(55.0, abs=1e-6)
        for bad in ({"setpoint_c": float("nan")}, {"setpoint_c": "hot"}, {"setpoint_c": True},
                    {"setpoint_c": 1000.0}, {"setpoint_c": 30.0, "rate_c_per_min": -1.0},
                    {"rate_c_per_min": 2.0}, {"setpoint_c": 30.0, "ramp": 1}):
            r = ctl.call("chamber", **bad)
            assert not r["ok"] and r["error"], bad
        for bad in ({"s": 0}, {"s": -5.0}, {"s": 1e9}, {"s": float("inf")}, {}):
            r = ctl.call("advance", **bad)
            assert not r["ok"] and r["error"], bad
        assert ctl.call("chamber")["setpoint_c"] == 55.0                # the refusals changed nothing
    finally:
        ctl.close()


def test_probe_readings_follow_the_chamber_with_the_scenarios_tempcos(rng):
    """The firmware's raw readings at one pose, at 25 degC and after a soak
    at a random set point, differ as the probe's (drawn) tempcos predict."""
    sc = load_scenario("typical").draw_tempcos(int(rng.integers(1 << 30)))
    sc.acc.noise = None
    sc.mag.noise = None
    p = EmulatedProbe(sc)
    p.poll = p.lib.app_main_poll
    p.move_to(30.0, 60.0, 45.0)
    sp = float(rng.uniform(-20.0, 70.0))
    r0 = p.raw()
    ch = p.phys.chamber(p.clock.now)
    ch.set(p.clock.now, sp, 5.0)
    p.step(3 * 3600.0, quantum=1.0)                  # >= 9 time constants after the ramp
    r1 = p.raw()
    assert r1["temp_c"] == pytest.approx(sp, abs=0.3)   # TEMP_OUT: 0.47 degC per count
    g, b = p.truth()
    q6 = 64.0   # the probe's raw means are Q6 counts (firmware/include/inclino/acquire.h, ACQ_FRAC_BITS)
    for tri, true, lsb, tol in (("acc", g, 2.0 ** -14 / q6, 2 * q6), ("mag", b, 1.0 / q6, 2 * q6)):
        model = getattr(sc, tri)
        d_pred = (model.deterministic(true, p.phys.temperature(p.clock.now)) - model.deterministic(true, 25.0)) / lsb
        d_meas = np.array(r1[tri], float) - np.array(r0[tri], float)
        assert np.abs(d_meas - d_pred).max() <= tol + 1e-3 * np.abs(d_pred).max(), (tri, d_meas, d_pred)


def test_acquire_temperature_procedure_on_the_bench(emu, capsys, tmp_path):
    out = tmp_path / "chamber.csv"
    rc = cli.main(["acquire", "--port", emu.path, "--bench", f"127.0.0.1:{emu.control_port}", "--procedure",
                   "temperature", "--temperatures", "10,40", "--ramp-rate", "5", "--interval-min", "4",
                   "--ramp-poses", "2", "-o", str(out), "--quiet"])
    o, err = capsys.readouterr()
    assert rc == 0, err
    ds = dataset.read_raw(str(out))
    T = ds.columns["temp_c"]
    assert "inclino acquire temperature (set points 10,40 degC" in ds.meta["source"]
    assert int(ds.meta["samples_averaged"]) == 64  # the procedure's default averaging
    # the last 12 rows are the twelve positions at 40 degC, the 12 before the ramp's last at 10 degC
    assert np.all(np.abs(T[-12:] - 40.0) < 1.5)
    assert T.min() < 11.0 and T.max() > 39.0
    n_ramp = len(T) - 24
    assert n_ramp >= 4 and n_ramp % 2 == 0            # two ramp poses at every interval
    # the probe's own temperature readings change smoothly through the ramps
    assert np.abs(np.diff(T)).max() < 10.0
    with ProbeLink(emu.path, timeout=2.0):
        pass


def test_acquire_temperature_bad_options(emu, capsys, tmp_path):
    out = tmp_path / "x.csv"
    base = ["acquire", "--port", emu.path, "--bench", f"127.0.0.1:{emu.control_port}", "--procedure",
            "temperature", "-o", str(out)]
    for extra in (["--temperatures", "a,b"], ["--temperatures", "200"], ["--temperatures", "nan"],
                  ["--ramp-rate", "0"], ["--ramp-poses", "9"], ["--interval-min", "-1"], ["--soak-tol", "inf"]):
        rc = cli.main(base + extra)
        err = capsys.readouterr().err
        assert rc == 2 and err.count("\n") == 1, (extra, err)
    assert not out.exists() and not (tmp_path / "x.csv.part").exists()


def test_settled_needs_the_band_and_a_quiet_window():
    plan = acquire_temp.ThermalPlan(soak_band=1.0, soak_tol=0.5, soak_window_min=10.0)
    assert not acquire_temp.settled([(0.0, 25.0), (12.0, 25.0)], 55.0, plan)       # far from the set point
    assert not acquire_temp.settled([(0.0, 54.9), (4.0, 55.0)], 55.0, plan)        # window not yet spanned
    assert not acquire_temp.settled([(0.0, 53.0), (6.0, 54.2), (12.0, 54.9)], 55.0, plan)  # still moving
    assert acquire_temp.settled([(0.0, 54.0), (2.0, 54.6), (12.0, 55.0)], 55.0, plan)


def test_acquire_temperature_guides_a_person(emu, tmp_path):
    ctl = ControlClient(port=emu.control_port)
    person = PersonAtChamber(ctl)
    table = ManualTurntable(stdin=person, say=person.say)
    plan = acquire_temp.ThermalPlan(setpoints=(35.0, 15.0), ramp_rate=4.0, interval_min=5.0, ramp_poses=3)
    out = tmp_path / "op.csv"
    with ProbeLink(emu.path, timeout=2.0) as link:
        r = acquire_temp.acquire_temperature(link, str(out), table, plan, world={"field_nT": 50000, "dip_deg": 60},
                                             quiet=True, sleep=person.sleep)
    ctl.close()
    assert person.setpoints == [35.0, 15.0]
    # one ramp pose held per set point, then the twelve positions
    ramp = acquire_temp.RAMP_POSES
    assert person.poses[0] == [ramp[0].inc, ramp[0].azi, ramp[0].tf]
    assert person.poses[13] == [ramp[1].inc, ramp[1].azi, ramp[1].tf] and len(person.poses) == 26
    ds = dataset.read_raw(str(out))
    assert r.rows == len(ds.columns["temp_c"]) and "operator" in ds.meta["source"]
    T = ds.columns["temp_c"]
    assert np.all(np.abs(T[-12:] - 15.0) < 1.5)
    assert any("probe at" in m for m in person.said)   # the person sees the probe's temperature
