"""The emulator's fast paths compute what the plain NumPy models compute,
bit for bit: block-drawn noise, cached truth and chain, single samples as
floats, the ADS1256's skipped updates, firmware calls that keep the GIL.
(Speed itself is measured by `inclino bench emulator`, not here.)"""
import math
import tomllib
from importlib import resources

import numpy as np
import pytest

from inclino_emu import ads1256 as A
from inclino.model import effects as fx
from inclino_emu import hal
from inclino_emu.clock import Clock
from inclino_emu.probe import EmulatedProbe
from inclino.model.scenario import load_scenario, scenario_from_dict
from inclino.model.world import Trajectory


def test_normal_stream_hands_out_the_generators_sequence():
    ref = np.random.default_rng([5, 1])
    s = fx.NormalStream(np.random.default_rng([5, 1]), block=7)
    got = []
    for k in range(300):      # single triads, shaped arrays and scalars, across block edges
        if k % 5 == 0:
            got.extend(s.standard_normal((2, 3)).ravel())
        elif k % 7 == 0:
            got.append(s.standard_normal())
        else:
            got.extend(s.take3())
    want = ref.standard_normal(len(got))
    assert np.array_equal(np.array(got), want)


def test_sampler_equals_the_numpy_random_part():
    rng = np.random.default_rng(3)
    model = fx.TriadModel(noise=fx.WhiteNoise([0.3, 0.2, 0.1], n_ref=256),
                          saturation=fx.Saturation([-1.0, -0.5, -2.0], [1.0, 0.5, 2.0]))
    y = rng.uniform(-1.5, 1.5, (500, 3))       # some beyond the rails
    for n_avg in (None, 1, 16, 256):
        g1, g2 = np.random.default_rng(9), fx.NormalStream(np.random.default_rng(9))
        want = np.array([model.random_part(v, g1, n_avg, quantise=False) for v in y])
        f = model.sampler(g2, n_avg)
        got = np.array([f(tuple(v)) for v in y])
        assert np.array_equal(got, want)
    bare = fx.TriadModel()
    assert bare.random_part3((1.0, 2.0, 3.0), None) == (1.0, 2.0, 3.0)


def _custom(rate=0.0, drift=False):
    d = tomllib.loads(resources.files("inclino.model").joinpath("scenarios", "typical.toml").read_text())
    d["world"]["temperature_rate_c_per_s"] = rate
    d["world"]["encoder"] = {"offset_deg": [0.1, -0.2, 0.3], "scale": [1e-4, -2e-4, 3e-4]}
    if drift:
        d["world"]["field_drift"] = {"rate_nT_per_s": 3.0, "dip_rate_deg_per_s": 0.01}
    return scenario_from_dict(d, "custom")


def _chamber(draw):
    """The typical probe with its tempcos drawn (first and second order on
    every axis), a nonlinearity on every axis, ramping 0.05 degC/s."""
    d = tomllib.loads(resources.files("inclino.model").joinpath("scenarios", "typical.toml").read_text())
    d["world"]["temperature_rate_c_per_s"] = 0.05
    d["mag"]["nonlinearity"] = {"k2": [2e-9, -3e-9, 1e-9]}
    d["acc"]["nonlinearity"] = {"k2": [1e-3, 0.0, -2e-3]}
    s = scenario_from_dict(d, "chamber").draw_tempcos(draw)
    assert all(np.any(m.scale_tempco.ppm2 != 0) and np.any(m.bias_tempco.c2 != 0) for m in (s.acc, s.mag))
    return s


@pytest.mark.parametrize("scn", ["typical", "li2021", "ideal", "ramp", "drift", "chamber-3", "chamber-8"])
def test_single_samples_equal_the_numpy_chain(scn):
    """acc_sample / mag_sample (cached truth and chain head, the
    temperature-dependent tail on floats) against the full chain on NumPy
    arrays with a plain Generator, sample by sample, through moves, a held
    temperature, a rotating trajectory; the chamber cases with every
    temperature term of both orders and a nonlinearity."""
    s = {"ramp": lambda: _custom(rate=0.05), "drift": lambda: _custom(drift=True),
         "chamber-3": lambda: _chamber(3), "chamber-8": lambda: _chamber(8)}.get(
        scn, lambda: load_scenario(scn))()
    p = s.probe(21)
    ga, gm = np.random.default_rng([21, 0]), np.random.default_rng([21, 1])
    steps = [("move", (30.0, 60.0, 90.0)), ("run", 40), ("temp", 55.0), ("run", 20), ("move", (120.0, 5.0, 300.0)),
             ("temp", None), ("run", 20), ("traj", None), ("run", 30), ("move", (0.0, 0.0, 0.0)), ("run", 10)]
    t = 0.0
    for what, arg in steps:
        if what == "move":
            p.move_to(*arg)
        elif what == "temp":
            p.set_temperature(arg)
        elif what == "traj":
            p.trajectory = Trajectory([t, t + 1.0], [10.0, 20.0], [0.0, 90.0], [0.0, 720.0])
        else:
            for k in range(arg):
                t += 0.0037
                n = (None, 16, 256)[k % 3]
                temp = p.temperature(np.float64(t))   # the NumPy path of the temperature
                want_a = s.acc.apply(p.true_acc(np.float64(t)), temp, ga, n, quantise=False)
                want_m = s.mag.apply(p.true_mag(np.float64(t)), temp, gm, None, quantise=False)
                assert np.array_equal(np.array(p.acc_sample(t, n)), want_a)
                assert np.array_equal(np.array(p.mag_sample(t)), want_m)
    # the array forms draw from the same streams
    ts = np.arange(4) * 0.01
    want = s.acc.apply(p.true_acc(ts), p.temperature(ts), ga, 4, quantise=False)
    assert np.array_equal(p.acc_analog(ts, 4), want)


def test_front_end_differential_equals_the_nine_inputs():
    b = (12345.678, -54321.0, 45000.25)
    fe = A.FluxgateFrontEnd(lambda t: np.array(b))
    v = fe(0.0)
    for p_ in range(9):
        for n_ in range(9):
            assert fe.differential(0.0, p_, n_) == v[p_] - v[n_]


class _NoGuard(A.ADS1256):
    """The ADS1256 with the update guard off: every access brings the
    conversions up to date, as the model did before the guard."""
    _guard = property(lambda self: -math.inf, lambda self, v: None)


def _drive(adc_cls, seed):
    rng = np.random.default_rng(seed)
    c = Clock()
    b = np.array([1234.5, -2345.25, 40000.0])
    adc = adc_cls(c, A.FluxgateFrontEnd(lambda t: b + 10.0 * np.sin(t * 7.0)))
    log = []
    cmds = [[A.WREG | A.MUX, 0, 0x08], [A.WREG | A.MUX, 0, 0x18], [A.SYNC], [A.WAKEUP], [A.RDATA, 0, 0, 0],
            [A.WREG | A.DRATE, 0, 0xA1], [A.WREG | A.DRATE, 0, 0xF0], [A.SELFCAL], [A.STANDBY], [A.RDATAC],
            [A.SDATAC], [A.RREG | 0, 3, 0, 0, 0, 0], [0x00, 0x00, 0x00], [A.WREG | A.STATUS, 0, 0x04]]
    for _ in range(600):
        r = rng.random()
        if r < 0.5:
            c.advance(float(rng.choice([1e-6, 20e-6, 200e-6, 1.1e-3, 5e-3])))
            log.append(("drdy", c.now, adc.drdy(), adc.next_drdy_time()))
        else:
            for byte in cmds[rng.integers(len(cmds))]:
                log.append(("byte", c.now, adc.transfer8(byte)))
                c.advance(8e-6)
            if rng.random() < 0.5:
                adc.cs_high()
    return log, adc.data_code, adc.t6_violations, adc.ignored_bytes


@pytest.mark.parametrize("seed", [1, 2, 3])
def test_ads1256_guard_changes_nothing(seed):
    assert _drive(A.ADS1256, seed) == _drive(_NoGuard, seed)


def test_gil_held_calls_match_cffi_and_fall_back():
    lib, ffi, g = hal.lib, hal.ffi, hal.gil_held_lib
    for s, n in ((7, 3), (-7, 3), (-1, 1), (2**31 - 1, 64)):
        assert g.acq_avg(s, n) == lib.acq_avg(s, n)
    assert g.ads_sign_extend24(0x800000) == lib.ads_sign_extend24(0x800000) == -(1 << 23)
    buf = ffi.new("uint8_t[]", b"123456789")
    assert g.crc16_update(0xFFFF, buf, 9) == lib.crc16_update(0xFFFF, buf, 9)
    assert g.crc16_update(0xFFFF, b"123456789", 9) == lib.crc16_update(0xFFFF, b"123456789", 9)  # via cffi
    with pytest.raises(OverflowError):
        g.acq_avg(1, 300)                        # uint8_t out of range: cffi's error
    with pytest.raises(TypeError):
        g.crc16_update(0, ffi.new("int32_t[2]"), 2)   # wrong pointer type: cffi's error


def test_hal_counting_counts_callbacks_and_restores():
    p = EmulatedProbe("ideal")
    with hal.counting(p.board) as cnt:
        p.survey()
    assert cnt.counts["spi_xfer16"] > 0 and cnt.counts["adc_drdy"] > 0 and cnt.total == sum(cnt.counts.values())
    before = dict(cnt.counts)
    s = p.survey()                               # unwrapped again, still working
    assert s["status"] == 0 and cnt.counts == before
