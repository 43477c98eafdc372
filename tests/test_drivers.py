"""The firmware drivers (firmware/src/adis16210.c, ads1256.c, acquire.c) in
C, through the emulator's HAL, against the register-level models: start-up
checks, faults as statuses with bounded waits, pipelining, stall and t6
timing, channel conversions, averaging with its documented rounding."""
import random

import numpy as np
import pytest

from inclino_emu import adis16210 as ad
from inclino_emu import ads1256 as A
from inclino_emu.probe import EmulatedProbe

ADIS_OK, ADIS_E_ABSENT, ADIS_E_PROD_ID, ADIS_E_NO_RESPONSE, ADIS_E_SELF_TEST = 0, 0x11, 0x12, 0x13, 0x14
ADS_OK, ADS_E_ABSENT, ADS_E_TIMEOUT = 0, 0x21, 0x23
ACQ_E_ARG = 0x31


def unbooted(**kw):
    p = EmulatedProbe("ideal", boot=False, **kw)
    return p, p.lib, p.ffi


def s16(u):
    return u - 0x10000 if u & 0x8000 else u


# ---- ADIS16210 ---------------------------------------------------------------
def test_adis_init_checks_prod_id_and_configures_averaging():
    p, lib, ffi = unbooted()
    pid = ffi.new("uint16_t *")
    assert lib.adis_init(pid) == ADIS_OK
    assert pid[0] == 0x3F52
    assert p.clock.now >= 0.220                   # it waited for the start-up time, no longer than needed
    assert p.clock.now < 0.250
    assert p.adis.regs[ad.AVG_CNT] == 4           # AVG_CNT written as documented
    assert p.adis.stall_violations == 0


def test_missing_adis_is_a_status_not_a_hang():
    p, lib, ffi = unbooted(adis_faults=ad.AdisFaults(absent=True))
    pid = ffi.new("uint16_t *")
    t0 = p.clock.now
    assert lib.adis_init(pid) == ADIS_E_ABSENT
    assert pid[0] == 0xFFFF
    assert p.clock.now - t0 < 0.1                 # three 0xFFFF reads, not the whole start-up window
    assert lib.adis_self_test() == ADIS_E_ABSENT
    s = ffi.new("adis_sample_t *")
    assert lib.adis_read(s) == ADIS_E_ABSENT


def test_wrong_prod_id_reported_with_the_value():
    p, lib, ffi = unbooted(adis_faults=ad.AdisFaults(prod_id=0x3F51))
    pid = ffi.new("uint16_t *")
    assert lib.adis_init(pid) == ADIS_E_PROD_ID
    assert pid[0] == 0x3F51


def test_adis_init_waits_for_a_slower_start_up():
    """The start-up time of this part is not published: the driver's bound
    (400 ms) leaves room beyond the model's 220 ms."""
    p, lib, ffi = unbooted()
    p.adis._ready_at = 0.35
    assert lib.adis_init(ffi.NULL) == ADIS_OK
    assert 0.35 <= p.clock.now < 0.37


def test_silent_adis_times_out_bounded():
    """A part that never leaves start-up (MISO low) -> NO_RESPONSE after the
    bounded poll (40 x 10 ms)."""
    p, lib, ffi = unbooted()
    p.adis._ready_at = float("inf")
    t0 = p.clock.now
    assert lib.adis_init(ffi.NULL) == ADIS_E_NO_RESPONSE
    assert 0.4 <= p.clock.now - t0 < 0.45


def test_self_test_pass_and_fail():
    p, lib, ffi = unbooted()
    assert lib.adis_init(ffi.NULL) == ADIS_OK
    assert lib.adis_self_test() == ADIS_OK
    assert not p.adis.regs[ad.MSC_CTRL] & ad.MSC_SELF_TEST_AUTO
    p2, lib2, ffi2 = unbooted(adis_faults=ad.AdisFaults(self_test_fails=True))
    assert lib2.adis_init(ffi2.NULL) == ADIS_OK
    assert lib2.adis_self_test() == ADIS_E_SELF_TEST


def test_burst_read_pipelining_and_stall():
    p, lib, ffi = unbooted()
    p.move_to(30.0, 45.0, 10.0)
    assert lib.adis_init(ffi.NULL) == ADIS_OK
    p.clock.advance(0.01)
    frames0 = p.adis.frames
    seen = []
    orig = p.adis.read_register

    def spy(addr):
        v = orig(addr)
        seen.append((addr & 0x7E, v))
        return v
    p.adis.read_register = spy
    s = ffi.new("adis_sample_t *")
    assert lib.adis_read(s) == ADIS_OK
    assert p.adis.frames - frames0 == 6           # 4 registers + PROD_ID + the frame clocking it out
    # the commands went out in the documented order, each answer one frame later
    assert [a for a, _ in seen] == [ad.XACCL_OUT, ad.YACCL_OUT, ad.ZACCL_OUT, ad.TEMP_OUT, ad.PROD_ID,
                                    ad.FLASH_CNT]
    vals = dict(seen)
    assert list(s.acc) == [s16(vals[r]) for r in (ad.XACCL_OUT, ad.YACCL_OUT, ad.ZACCL_OUT)]
    assert s.temp_raw == vals[ad.TEMP_OUT]
    g, _ = p.truth()
    np.testing.assert_array_equal(list(s.acc), np.round(g * 16384))
    assert p.adis.stall_violations == 0


def test_adis_disappearing_mid_run_is_detected_in_the_burst():
    p, lib, ffi = unbooted()
    assert lib.adis_init(ffi.NULL) == ADIS_OK
    p.adis.faults.absent = True
    assert lib.adis_read(ffi.new("adis_sample_t *")) == ADIS_E_ABSENT


def test_temperature_conversion():
    p, lib, _ = unbooted()
    for raw in (0, 1278, 1331, 4095):
        assert lib.adis_temp_centi_c(raw) == (1331 - raw) * 47


def test_byte_frame_to_the_adis_is_a_malformed_frame():
    p, lib, ffi = unbooted()
    assert lib.adis_init(ffi.NULL) == ADIS_OK
    lib.hal_spi_select(0)
    assert lib.hal_spi_xfer8(0x3C) == 0xFF
    lib.hal_spi_deselect()
    p.clock.advance(1e-3)
    assert lib.adis_read_reg(ad.DIAG_STAT) & ad.DIAG_SPI_FAIL


# ---- ADS1256 ------------------------------------------------------------------
def test_ads_init_configures_and_calibrates():
    p, lib, ffi = unbooted()
    assert lib.ads_init() == ADS_OK
    assert p.adc.regs[A.DRATE] == 0xA1 and p.adc.regs[A.ADCON] & 0x07 == 0
    assert p.adc.regs[A.STATUS] & 0x06 == 0       # no auto-calibration, no buffer
    assert p.adc.mode == "convert"                # the self-calibration finished inside ads_init
    assert p.adc.t6_violations == 0 and p.adc.ignored_bytes == 0


def test_ads_reads_each_channel_signed():
    p, lib, ffi = unbooted()
    assert lib.ads_init() == ADS_OK
    p.move_to(120.0, 200.0, 300.0)                # negative components on some axes
    code = ffi.new("int32_t *")
    _, b = p.truth()
    assert np.any(b < 0)
    for k, mux in enumerate((0x08, 0x18, 0x28)):
        t0 = p.clock.now
        assert lib.ads_read_channel(mux, code) == ADS_OK
        assert code[0] == round(p.phys.true_mag(p.clock.now)[k])
        assert 1.18e-3 <= p.clock.now - t0 < 1.5e-3   # one settled conversion, no more
    assert p.adc.t6_violations == 0


def test_ads_sign_extension():
    _, lib, _ = unbooted()
    for raw, v in ((0x000000, 0), (0x000001, 1), (0x7FFFFF, 2**23 - 1), (0x800000, -2**23),
                   (0xFFFFFF, -1), (0xFF800000, -2**23), (0x12FFFFFF, -1)):
        assert lib.ads_sign_extend24(raw) == v


def test_missing_adc_and_stuck_drdy_are_statuses():
    p, lib, ffi = unbooted(adc_absent=True)
    t0 = p.clock.now
    assert lib.ads_init() == ADS_E_ABSENT
    assert p.clock.now - t0 < 0.05
    p2, lib2, ffi2 = unbooted()
    assert lib2.ads_init() == ADS_OK
    p2.adc.absent = True                          # DRDY high for ever
    t0 = p2.clock.now
    assert lib2.ads_read_channel(0x08, ffi2.new("int32_t *")) == ADS_E_TIMEOUT
    assert p2.clock.now - t0 < 0.01               # 1.1 ms settle + 5 ms bounded poll


# ---- acquisition ----------------------------------------------------------------
def _floor_half_up(s, n):
    return (2 * s + n) // (2 * n)                 # Python's // floors: floor(s/n + 1/2)


def test_acq_avg_rounds_half_up_exactly():
    _, lib, _ = unbooted()
    rng = random.Random(7)
    cases = [(s, n) for n in (1, 2, 3, 4, 16, 64) for s in range(-3 * n, 3 * n + 1)]
    cases += [(rng.randint(-2**29, 2**29), rng.randint(1, 64)) for _ in range(3000)]
    cases += [(-2**29, 64), (2**29, 64), (-2**30, 1), (2**30, 255)]
    for s, n in cases:
        assert lib.acq_avg(s, n) == _floor_half_up(s, n), (s, n)


def test_acq_avg_q6_is_the_mean_with_six_fraction_bits():
    """floor(64 sum / n + 1/2) for every small sum and random sums over the
    contract's range (|sum| <= 2^30, |sum / n| < 2^24)."""
    _, lib, _ = unbooted()
    rng = random.Random(8)
    cases = [(s, n) for n in (1, 2, 3, 5, 7, 16, 63, 64, 255) for s in range(-3 * n, 3 * n + 1)]
    for _ in range(4000):
        n = rng.randint(1, 255)
        lim = min(2**30, n * (2**24 - 1))
        cases.append((rng.randint(-lim, lim), n))
    cases += [(-2**29, 64), (2**29, 64), (-(2**24 - 1), 1), (2**24 - 1, 1), (-2**30, 255), (2**30, 255)]
    for s, n in cases:
        assert lib.acq_avg_q6(s, n) == _floor_half_up(64 * s, n), (s, n)


def test_acq_avg_ties_round_half_up_on_both_sides_of_zero():
    """Every exact tie, by construction rather than by chance: a mean whose
    fraction is exactly 1/2 goes up (toward +inf), -2.5 -> -2 and 2.5 -> 3
    (acquire.h: floor(x + 1/2)).  acq_avg: sums n k + n/2 at every even n.
    acq_avg_q6: 64 sum / n has fraction 1/2 only when 128 r = n (2j + 1)
    for the remainder r = sum mod n, i.e. n = 128 and r odd within 1..255."""
    from fractions import Fraction

    _, lib, _ = unbooted()
    assert (lib.acq_avg(5, 2), lib.acq_avg(-5, 2), lib.acq_avg(3, 6), lib.acq_avg(-3, 6)) == (3, -2, 1, 0)
    assert (lib.acq_avg_q6(1, 128), lib.acq_avg_q6(-1, 128), lib.acq_avg_q6(3, 128)) == (1, 0, 2)
    ties = 0
    for n in range(2, 256, 2):
        for k in (-70000, -3, -1, 0, 1, 2, 70000):
            s = n * k + n // 2
            want = int((Fraction(s, n) + Fraction(1, 2)).__floor__())
            assert lib.acq_avg(s, n) == want == _floor_half_up(s, n), (s, n)
            ties += 1
    q6_ties = [(n, r) for n in range(1, 256) for r in range(n) if (128 * r) % (2 * n) == n]
    assert q6_ties and {n for n, _ in q6_ties} == {128} and all(r % 2 for _, r in q6_ties)
    for n, r in q6_ties:
        for q in (0, 1, 5, 1000, 130000):
            for s in (q * n + r, -(q * n + r)):
                want = int((Fraction(64 * s, n) + Fraction(1, 2)).__floor__())
                assert Fraction(64 * s, n) - int(Fraction(64 * s, n).__floor__()) == Fraction(1, 2)
                assert lib.acq_avg_q6(s, n) == want, (s, n)
                ties += 1
    assert ties > 1000


def test_acq_run_rejects_bad_n():
    p, lib, ffi = unbooted()
    out = ffi.new("acq_result_t *")
    assert lib.acq_run(0, out) == ACQ_E_ARG
    assert lib.acq_run(65, out) == ACQ_E_ARG


def test_acq_run_averages_what_the_parts_returned():
    """Record every value the models hand out during an acquisition of a
    noisy probe (typical scenario); the firmware's result must be their
    averages rounded half up, each ADIS16210 burst must read a new output
    sample, and the fluxgate conversions must be one per channel per sample."""
    p = EmulatedProbe("typical", boot=False, seed=3)
    lib, ffi = p.lib, p.ffi
    p.move_to(60.0, 100.0, 200.0)
    assert lib.adis_init(ffi.NULL) == ADIS_OK and lib.ads_init() == ADS_OK
    acc, temp, mag, windows = [[], [], []], [], {0x08: [], 0x18: [], 0x28: []}, []
    orig_reg, orig_rdata = p.adis.read_register, p.adc._data_bytes

    def reg_spy(addr):
        v = orig_reg(addr)
        r = addr & 0x7E
        if r in (ad.XACCL_OUT, ad.YACCL_OUT, ad.ZACCL_OUT):
            acc[(r - ad.XACCL_OUT) // 2].append(s16(v))
            if r == ad.XACCL_OUT:
                windows.append(p.adis._sample_k)
        elif r == ad.TEMP_OUT:
            temp.append(v)
        return v

    def rdata_spy():
        mag[p.adc.regs[A.MUX]].append(p.adc.data_code)
        return orig_rdata()
    p.adis.read_register, p.adc._data_bytes = reg_spy, rdata_spy
    n = 13
    out = ffi.new("acq_result_t *")
    assert lib.acq_run(n, out) == 0
    assert all(len(a) == n for a in acc) and len(temp) == n
    assert all(len(v) == n for v in mag.values())
    assert len(set(windows)) == n                 # a fresh ADIS16210 output sample every time
    assert len({tuple(a) for a in zip(*acc)}) > 1  # and the noise made them differ
    # the triads' means keep 6 fraction bits (Q6 counts)
    assert list(out.acc) == [_floor_half_up(64 * sum(a), n) for a in acc]
    assert list(out.mag) == [_floor_half_up(64 * sum(mag[m]), n) for m in (0x08, 0x18, 0x28)]
    assert out.temp_raw == _floor_half_up(sum(temp), n)
    assert out.temp_cc == (1331 - out.temp_raw) * 47
    assert out.n == n
    assert p.adis.stall_violations == 0 and p.adc.t6_violations == 0


def test_acq_stops_at_the_first_driver_error():
    p, lib, ffi = unbooted()
    assert lib.adis_init(ffi.NULL) == ADIS_OK and lib.ads_init() == ADS_OK
    p.adc.absent = True
    out = ffi.new("acq_result_t *")
    out.n = 99
    assert lib.acq_run(8, out) == ADS_E_TIMEOUT
    assert out.n == 99                            # nothing written on error
