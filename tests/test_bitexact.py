"""The firmware C and the golden model agree bit for bit on a million
vectors plus the edge cases, and the comparison does catch a difference."""
import numpy as np
import pytest

from inclino.engines import bitexact, golden
from inclino import cli


@pytest.mark.heavy
def test_million_vectors_zero_mismatches(capsys):
    assert cli.main(["bitexact", "--vectors", "1000000", "--seed", "11"]) == 0
    out = capsys.readouterr().out.strip()
    assert out.startswith("bitexact: ") and out.endswith(" 0 mismatches")
    assert int(out.split()[1]) >= 1_000_000


def test_edge_cases_cover_every_flag():
    rng = np.random.default_rng(0)
    cals = bitexact.random_cals(rng, 16)
    acc, mag = bitexact.edge_vectors()
    idx = np.arange(len(acc)) % len(cals)
    arr = [np.array([getattr(c, k) for c in cals], dtype=np.int64)[idx]
           for k in ("acc_m", "acc_b", "mag_m", "mag_b")]
    flags = np.bitwise_or.reduce(golden.survey_compute(acc, mag, *arr)["flags"])
    for bit in golden.FLAG_NAMES:
        assert flags & bit, golden.FLAG_NAMES[bit]


def test_comparison_detects_a_one_lsb_difference(monkeypatch, capsys):
    real = golden.fx_atan2_q16

    def off_by_one(y, x):
        r = real(y, x)
        return r + ((np.asarray(y) % 1009) == 7)

    monkeypatch.setattr(golden, "fx_atan2_q16", off_by_one)
    assert cli.main(["bitexact", "--vectors", "20000"]) == 1
    out = capsys.readouterr().out
    assert " 0 mismatches" not in out


def test_temperature_path_difference_is_caught(monkeypatch, capsys):
    """A one-LSB slip in the golden model's evaluation of the temperature
    terms is found: the temperature path is compared."""
    real = golden.corr_temp_eval

    def off_by_one(dt, *args):
        beff, e, sat = real(dt, *args)
        return beff + ((np.asarray(e) % 1013) == 5), e, sat

    monkeypatch.setattr(golden, "corr_temp_eval", off_by_one)
    assert cli.main(["bitexact", "--vectors", "20000"]) == 1
    assert " 0 mismatches" not in capsys.readouterr().out


def test_temperature_edges_reach_every_clamp():
    """The edge temperatures and the limit terms drive dT's clamps, e's
    clamp and b_eff's saturation (the arith-saturated flag) in the golden
    model the comparison runs."""
    rng = np.random.default_rng(1)
    tc = bitexact.random_temp_cals(rng, bitexact.random_cals(rng, 12))
    _, sat_dt = golden.corr_temp_dt(np.array(bitexact.EDGE_TEMPS), 0)
    assert sat_dt.any() and not sat_dt.all()
    hit = False
    for c in tc:
        t = c.temp
        dt, _ = golden.corr_temp_dt(np.array(bitexact.EDGE_TEMPS), t.t_ref)
        _, e, sat = golden.corr_temp_eval(dt, c.acc_b, t.acc_c1, t.acc_c2, t.acc_r1, t.acc_r2)
        hit |= bool(sat.any() and (np.abs(e) == golden.E_MAX).any())
    assert hit


def _temp_eval_c(dt, bias, c1, c2, r1, r2):
    """correct.c corr_temp_eval, the firmware C itself (inclino.engines._core)."""
    from inclino.engines._core import ffi, lib

    c = ffi.new("corr_triad_t *")
    tc = ffi.new("corr_tc_t *")
    tt = ffi.new("corr_tt_t *")
    sat = ffi.new("uint8_t *")
    for i in range(3):
        c.bias[i] = int(bias[i])
        tc.c1[i], tc.c2[i], tc.r1[i], tc.r2[i] = int(c1[i]), int(c2[i]), int(r1[i]), int(r2[i])
    lib.corr_temp_eval(int(dt), c, tc, tt, sat)
    return np.array(list(tt.beff)), np.array(list(tt.e)), bool(sat[0])


def test_second_order_terms_are_applied_as_c2_dt2_and_r2_dt2():
    """The second-order temperature terms alone (c1 = r1 = 0), in the image's
    formats (caltemp: c2 Q31 g/degC^2, r2 Q31 /degC^2, dT Q7 degC; b_eff
    and e in Q29): b_eff - b = c2 dT^2 and e = r2 dT^2, i.e. c2 dt^2 / 2^16
    in LSBs, within 4 LSB (the Q31 product floors its partial products), in the golden
    model and in the firmware C.  A dropped or first-order-only term is
    wrong by up to millions of LSBs here."""
    cases = 0
    for dt in (-3840, -1280, -1, 1, 640, 3840, 5120):  # -30 .. +40 degC in Q7
        for c2, r2 in ((20000, -15000), (-32767, 32767), (1, -1), (7, 12345)):
            bias = np.array([1000, -2000, 0])
            c2v, r2v = np.array([c2, -c2, c2 // 2]), np.array([r2, r2 // 3, -r2])
            zero = np.zeros(3, dtype=np.int64)
            want_b = bias + c2v * dt * dt / 2.0**16
            want_e = r2v * dt * dt / 2.0**16
            gb, ge, gsat = golden.corr_temp_eval(np.array(dt), bias, zero, c2v, zero, r2v)
            cb, ce, csat = _temp_eval_c(dt, bias, zero, c2v, zero, r2v)
            assert not gsat and not csat
            np.testing.assert_allclose(gb, want_b, atol=4.0)
            np.testing.assert_allclose(ge, want_e, atol=4.0)
            assert np.array_equal(cb, gb) and np.array_equal(ce, ge)
            cases += 1
    assert cases == 28


def test_second_order_terms_in_the_float_model_and_the_image_form():
    """The float definitions of the second-order terms, against the
    polynomial written out: the emulator's BiasTempco / ScaleTempco
    (y = x + c dT + c2 dT^2; scale factor 1 + 1e-6 (p dT + p2 dT^2)), and
    CAL.json's terms in the firmware's form (caltemp: r1 = -p1, r2 = p1^2 -
    p2, the expansion of 1 / (1 + s) to second order, and apply_float)."""
    from inclino.formats import caltemp
    from inclino.model import effects as fx

    T = np.array([-5.0, 10.0, 25.0, 40.0, 55.0])
    dT = T - 25.0
    c, c2 = np.array([1e-5, -2e-5, 0.0]), np.array([3e-7, 0.0, -1e-7])
    bt = fx.BiasTempco(c, 25.0, c2)
    np.testing.assert_allclose(bt.offset(T, np.zeros((5, 3))), dT[:, None] * c + dT[:, None] ** 2 * c2, atol=1e-15)
    p, p2 = np.array([40.0, -60.0, 0.0]), np.array([0.5, 0.0, -0.8])
    st = fx.ScaleTempco(p, 25.0, p2)
    np.testing.assert_allclose(st.factor(T, np.zeros((5, 3))), 1 + 1e-6 * (dT[:, None] * p + dT[:, None] ** 2 * p2),
                               rtol=1e-14)
    block = {"order": 2, "t_ref_c": 25.0,
             "acc": {"bias": [c.tolist(), c2.tolist()], "scale_ppm": [p.tolist(), p2.tolist()]},
             "mag": {"bias": [[0.5, -1.0, 0.0], [0.02, 0.0, -0.03]], "scale_ppm": [p.tolist(), p2.tolist()]}}
    c1f, c2f, r1f, r2f = caltemp.firmware_coefficients(block, "acc")
    np.testing.assert_allclose(c2f, c2, rtol=0, atol=0)
    np.testing.assert_allclose(r1f, -1e-6 * p, rtol=1e-15)
    np.testing.assert_allclose(r2f, (1e-6 * p) ** 2 - 1e-6 * p2, rtol=1e-12, atol=1e-24)
    ft = caltemp.to_fixed(block)
    assert ft.order == 2
    _, c2q, _, r2q = caltemp.from_fixed(ft, "acc")
    np.testing.assert_allclose(c2q, c2, atol=2.0**-31)
    np.testing.assert_allclose(r2q, (1e-6 * p) ** 2 - 1e-6 * p2, atol=2.0**-31)
    # the firmware's form of a reading against the exact 1 / (1 + s): within the stated truncation bound
    raw = np.tile([0.3, -0.7, 0.65], (5, 1))
    b = np.array([1e-3, -2e-3, 5e-4])
    got = caltemp.apply_float(raw, T, b, ft, "acc")
    exact = fx.to_reference_temperature(raw, T, b, fx.BiasTempco(c, 25.0, c2), st) - b
    bound = np.array(caltemp.truncation_bound(block, -5.0, 55.0)["acc"])
    quant = 2.0**-31 * (np.abs(dT) + dT ** 2)[:, None] * 2 + 2.0**-38 * np.abs(dT)[:, None] * 2
    assert np.all(np.abs(got - exact) <= bound * np.abs(raw - b) + quant + 1e-15)


def test_batched_golden_temperature_call_is_the_per_calibration_call():
    """bitexact.golden_temp (one golden call over all the calibrations'
    rows) gives every output word of the golden model called once per
    calibration on its own rows, as the comparison did before: edge and
    random vectors, edge and random temperatures, terms of order 1 and 2,
    calibrations with no terms and with terms of order 0 among them."""
    from inclino.engines.firmware import FixedCal

    rng = np.random.default_rng(5)
    base = bitexact.random_cals(rng, 12)
    tc = bitexact.random_temp_cals(rng, base)
    order0 = FixedCal(tc[1].acc_m, tc[1].acc_b, tc[1].mag_m, tc[1].mag_b,
                      type(tc[1].temp)(*([tc[1].temp.t_ref, 0] + list(tc[1].temp.__dict__.values())[2:])))
    cals = tc[:5] + [base[5], order0] + tc[7:]
    assert {c.temp.order for c in cals if c.temp is not None} == {0, 1, 2} and any(c.temp is None for c in cals)
    ea, em = bitexact.edge_vectors()
    ra, rm = bitexact.random_vectors(rng, 4000)
    acc, mag = np.concatenate([ea, ra]), np.concatenate([em, rm])
    temps = np.concatenate([np.resize(np.array(bitexact.EDGE_TEMPS), len(ea)), bitexact.random_temps(rng, 4000)])
    got = bitexact.golden_temp(acc, mag, temps, cals)
    idx = np.arange(len(acc)) % len(cals)
    for k, cal in enumerate(cals):
        sel = idx == k
        want = golden.survey_compute(acc[sel], mag[sel], *cal.arrays(), temp=cal.temp, temp_q6=temps[sel])
        assert set(want) == set(got)
        for key, v in want.items():
            assert np.array_equal(got[key][sel], v) and got[key].dtype == v.dtype, (k, key)
