"""Register-level ADIS16210 and ADS1256 models over byte/word SPI."""
import math

import numpy as np
import pytest

from inclino_emu import adis16210 as ad
from inclino_emu import ads1256 as A
from inclino_emu.clock import Clock
from inclino_emu.scenario import load_scenario

STALL = 50e-6


class Const:
    """A settable constant acceleration source (g)."""
    def __init__(self, v):
        self.v = np.asarray(v, float)
        self.calls = []

    def __call__(self, t, n_avg=None):
        self.calls.append((t, n_avg))
        return self.v


def make_adis(v=(0.25, -0.5, 0.75), **kw):
    c = Clock()
    src = Const(v)
    dev = ad.ADIS16210(c, src, lambda t: 25.0, serial=0x1234, **kw)
    c.advance(0.2)  # past start-up
    return c, dev, src


def xfer(c, dev, w):
    c.advance(STALL)
    return dev.transfer16(w)


def read(c, dev, addr):
    xfer(c, dev, addr << 8)
    return xfer(c, dev, 0x0000)


def test_prod_id_and_pipelining():
    c, dev, _ = make_adis()
    assert xfer(c, dev, 0x5600) == 0x0000          # nothing queued yet
    assert xfer(c, dev, 0x5800) == 0x3F52          # PROD_ID arrives one frame late
    assert xfer(c, dev, 0x0400) == 0x1234          # SERIAL_NUM
    assert xfer(c, dev, 0x0600) == 0x1000          # XACCL: 0.25 g * 16384 = 4096
    assert xfer(c, dev, 0x0800) == 0xE000          # YACCL: -0.5 g -> -8192 two's complement
    assert xfer(c, dev, 0x0000) == 0x3000          # ZACCL: 0.75 g = 12288


def test_startup_blanking_and_missing_part():
    c = Clock()
    dev = ad.ADIS16210(c, Const((0, 0, 1)))
    c.advance(0.01)
    assert dev.transfer16(0x5600) == 0 and (c.advance(STALL), dev.transfer16(0))[1] == 0
    c.advance(0.2)
    assert read(c, dev, ad.PROD_ID) == 0x3F52
    c2 = Clock()
    gone = ad.ADIS16210(c2, Const((0, 0, 1)), faults=ad.AdisFaults(absent=True))
    c2.advance(1.0)
    assert gone.transfer16(0x5600) == 0xFFFF and gone.transfer16(0) == 0xFFFF
    wrong = ad.ADIS16210(c2, Const((0, 0, 1)), faults=ad.AdisFaults(prod_id=0x3F51))
    c2.advance(1.0)
    assert read(c2, wrong, ad.PROD_ID) == 0x3F51


def test_saturation_of_output_registers():
    c, dev, _ = make_adis((3.0, -3.0, 1.99997))
    assert read(c, dev, ad.XACCL_OUT) == 0x7FFF
    assert read(c, dev, ad.YACCL_OUT) == 0x8000
    assert read(c, dev, ad.ZACCL_OUT) == 0x7FFF  # 1.99997 g rounds to 32767.5 -> rail


def test_byte_writes_null_register_and_readback():
    c, dev, _ = make_adis()
    xfer(c, dev, 0x9200 | 0x34)  # XACCL_NULL low byte
    xfer(c, dev, 0x9300 | 0xFF)  # high byte -> 0xFF34 = -204
    assert read(c, dev, ad.XACCL_NULL) == 0xFF34
    assert ad._s16(read(c, dev, ad.XACCL_OUT)) == 4096 - 204
    xfer(c, dev, 0x9200 | 0x00)  # changing only the low byte keeps the high one
    assert read(c, dev, ad.XACCL_NULL) == 0xFF00


def test_writes_to_read_only_and_unmapped_are_ignored():
    c, dev, _ = make_adis()
    xfer(c, dev, 0xD600 | 0x00)
    xfer(c, dev, 0xD700 | 0x00)
    assert read(c, dev, ad.PROD_ID) == 0x3F52
    assert read(c, dev, 0x40) == 0x0000
    xfer(c, dev, 0xC000 | 0x55)
    assert read(c, dev, 0x40) == 0x0000


def test_write_frame_returns_previous_read_then_zero():
    c, dev, _ = make_adis()
    xfer(c, dev, 0x5600)
    assert xfer(c, dev, 0xB800 | 0x04) == 0x3F52  # write AVG_CNT; PROD_ID still comes out
    assert xfer(c, dev, 0x3800) == 0x0000        # nothing pending after a write
    assert xfer(c, dev, 0x0000) == 0x0004


def test_incl_temp_supply_scales():
    c, dev, _ = make_adis((0.0, 0.5, 0.5))
    x = ad._s16(read(c, dev, ad.XINCL_OUT))
    assert x * 180 / 32768 == pytest.approx(45.0, abs=0.006)  # atan2(ay, az)
    assert read(c, dev, ad.TEMP_OUT) == 1278                  # 25 C: 1331 - 25/0.47
    assert read(c, dev, ad.SUPPLY_OUT) == 0x2A3D              # 3.3 V / 305.18 uV
    dev.supply_v = 2.9
    assert read(c, dev, ad.DIAG_STAT) & ad.DIAG_SUPPLY_LOW


def test_stall_violation_flags_spi_error_and_clears_on_read():
    c, dev, _ = make_adis()
    c.advance(1e-3)
    dev.transfer16(0x5600)
    c.advance(10e-6)            # too soon: 10 us < 40 us stall
    dev.transfer16(0x0000)
    assert dev.stall_violations == 1
    d = read(c, dev, ad.DIAG_STAT)
    assert d & ad.DIAG_SPI_FAIL
    assert read(c, dev, ad.DIAG_STAT) == 0      # latched flag cleared by the read


def test_output_rate_and_averaging():
    c, dev, src = make_adis()
    T = dev.output_period_s()
    assert T == pytest.approx(256 / 4250.0)
    read(c, dev, ad.XACCL_OUT)
    n = len(src.calls)
    read(c, dev, ad.XACCL_OUT)                  # same window: no new sample
    assert len(src.calls) == n
    c.advance(T)
    read(c, dev, ad.XACCL_OUT)
    assert len(src.calls) == n + 1 and src.calls[-1][1] == 256
    xfer(c, dev, 0xB800 | 0x02)                 # AVG_CNT = 2 -> 4 samples
    c.advance(4 / 4250.0)
    read(c, dev, ad.YACCL_OUT)
    assert src.calls[-1][1] == 4


def test_self_test_manual_and_automatic():
    c, dev, _ = make_adis((0.0, 0.0, 1.0))
    z0 = ad._s16(read(c, dev, ad.ZACCL_OUT))
    xfer(c, dev, 0xB500 | 0x01)                 # MSC_CTRL[8] = 1 (manual)
    z1 = ad._s16(read(c, dev, ad.ZACCL_OUT))
    assert z1 - z0 == round(0.1 * 16384)
    xfer(c, dev, 0xB500 | 0x00)
    xfer(c, dev, 0xB500 | 0x04)                 # MSC_CTRL[10]: automatic self-test
    assert read(c, dev, ad.MSC_CTRL) & ad.MSC_SELF_TEST_AUTO
    c.advance(0.05)
    assert not read(c, dev, ad.MSC_CTRL) & ad.MSC_SELF_TEST_AUTO
    assert not read(c, dev, ad.DIAG_STAT) & ad.DIAG_SELF_TEST_FAIL
    c2, bad, _ = make_adis(faults=ad.AdisFaults(self_test_fails=True))
    xfer(c2, bad, 0xB500 | 0x04)
    c2.advance(0.05)
    assert read(c2, bad, ad.DIAG_STAT) & ad.DIAG_SELF_TEST_FAIL


def test_flash_update_and_software_reset():
    c, dev, _ = make_adis()
    xfer(c, dev, 0x9400 | 0x10)                 # YACCL_NULL = 0x0010
    xfer(c, dev, 0xBE00 | ad.GLOB_FLASH_UPDATE)
    c.advance(0.06)
    assert read(c, dev, ad.FLASH_CNT) == 1
    xfer(c, dev, 0x9400 | 0x20)                 # not saved
    xfer(c, dev, 0xBE00 | ad.GLOB_SW_RESET)
    assert xfer(c, dev, 0x5600) == 0           # restarting
    c.advance(0.2)
    assert read(c, dev, ad.YACCL_NULL) == 0x0010
    xfer(c, dev, 0xBE00 | ad.GLOB_FACTORY_RESTORE)
    assert read(c, dev, ad.YACCL_NULL) == 0


def test_adis_on_scenario_probe_matches_truth():
    s = load_scenario("ideal")
    p = s.probe()
    p.move_to(30.0, 45.0, 10.0)
    c = Clock()
    dev = ad.ADIS16210(c, p.acc_analog, p.temperature)
    c.advance(0.3)
    g = p.true_acc(c.now)
    got = [ad._s16(read(c, dev, r)) for r in (ad.XACCL_OUT, ad.YACCL_OUT, ad.ZACCL_OUT)]
    np.testing.assert_array_equal(got, np.round(g * 16384))


# ---- ADS1256 ---------------------------------------------------------------
class Inputs:
    def __init__(self, b=(12345.0, -54321.0, 45000.0)):
        self.b = np.asarray(b, float)

    def __call__(self, t):
        return A.FluxgateFrontEnd(lambda t: self.b)(t)


def make_adc(**kw):
    c = Clock()
    inp = Inputs()
    adc = A.ADS1256(c, inp, **kw)
    return c, adc, inp


def send(c, adc, bs, dt=2e-6):
    out = []
    for b in bs:
        out.append(adc.transfer8(b))
        c.advance(dt)
    return out


def s24(bs):
    v = (bs[0] << 16) | (bs[1] << 8) | bs[2]
    return v - (1 << 24) if v & 0x800000 else v


def wait_drdy(c, adc, limit=5.0):
    t_end = c.now + limit
    while adc.drdy():
        c.advance_to(min(adc.next_drdy_time(), t_end))
        if c.now >= t_end:
            raise AssertionError("DRDY never fell")


def rdata(c, adc):
    send(c, adc, [A.RDATA])
    c.advance(A.T6_S)
    return s24(send(c, adc, [0, 0, 0]))


def test_reset_values_and_id():
    c, adc, _ = make_adc()
    assert adc.drdy()                            # calibrating after power-on
    wait_drdy(c, adc)
    send(c, adc, [A.RREG | 0, 0x0A])
    c.advance(A.T6_S)
    regs = send(c, adc, [0] * 11)
    assert regs[0] >> 4 == 3                      # ADS1256 ID
    assert regs[1:5] == [0x01, 0x20, 0xF0, 0xE0]
    assert s24(regs[7:4:-1]) == 0                 # OFC after an ideal self-cal
    assert regs[8] | regs[9] << 8 | regs[10] << 16 == 0x44AC08


def test_power_on_calibration_time_and_rate():
    c, adc, _ = make_adc()
    assert adc.next_drdy_time() == pytest.approx(3 * 0.21e-3)
    wait_drdy(c, adc)
    t0 = c.now
    rdata(c, adc)
    assert adc.drdy()
    wait_drdy(c, adc)
    assert c.now - t0 == pytest.approx(1 / 30000.0, abs=1e-9)


def test_mux_channels_give_field_in_counts_and_sync_settling():
    c, adc, inp = make_adc()
    wait_drdy(c, adc)
    send(c, adc, [A.WREG | A.DRATE, 0x00, 0x82])  # 100 SPS
    for ch, mux in enumerate((0x08, 0x18, 0x28)):
        send(c, adc, [A.WREG | A.MUX, 0x00, mux])
        send(c, adc, [A.SYNC])
        c.advance(5e-6)
        send(c, adc, [A.WAKEUP])
        t0 = c.now - 2e-6
        c.advance(10.0e-3)
        assert adc.drdy()                        # not settled before t18 = 10.18 ms
        wait_drdy(c, adc)
        assert c.now - t0 == pytest.approx(10.18e-3, abs=1e-6)
        assert rdata(c, adc) == round(inp.b[ch])


def test_negative_code_and_clipping():
    c, adc, inp = make_adc()
    inp.b = np.array([-1.0, 0.0, 0.0])
    wait_drdy(c, adc)
    send(c, adc, [A.WREG | A.MUX, 0x00, 0x08])
    c.advance(1e-3)
    wait_drdy(c, adc)
    send(c, adc, [A.RDATA])
    c.advance(A.T6_S)
    assert send(c, adc, [0, 0, 0]) == [0xFF, 0xFF, 0xFF]
    inp.b = np.array([9e6, 0.0, 0.0])            # beyond +2 VREF
    c.advance(1e-3)
    wait_drdy(c, adc)
    assert rdata(c, adc) == 2**23 - 1


def test_pga_scales_counts():
    c, adc, inp = make_adc()
    wait_drdy(c, adc)
    send(c, adc, [A.WREG | A.MUX, 0x01, 0x08, 0x21])  # MUX and ADCON (PGA = 2) in one WREG
    c.advance(1e-3)
    wait_drdy(c, adc)
    assert rdata(c, adc) == round(2 * inp.b[0])


def test_rdatac_stream_and_sdatac():
    c, adc, inp = make_adc()
    wait_drdy(c, adc)
    send(c, adc, [A.WREG | A.MUX, 0x00, 0x18])
    c.advance(1e-3)
    wait_drdy(c, adc)
    send(c, adc, [A.RDATAC])
    c.advance(A.T6_S)
    assert s24(send(c, adc, [0, 0, 0])) == round(inp.b[1])
    assert adc.drdy()
    for _ in range(3):
        wait_drdy(c, adc)
        assert s24(send(c, adc, [0, 0, 0])) == round(inp.b[1])
    wait_drdy(c, adc)
    send(c, adc, [A.SDATAC, 0, 0])               # SDATAC in the first data byte ends it
    assert not adc.rdatac
    send(c, adc, [A.RREG | A.MUX, 0x00])         # commands work again
    c.advance(A.T6_S)
    assert send(c, adc, [0]) == [0x18]


def test_t6_violation_counted_and_strict_mode():
    c, adc, _ = make_adc(strict_timing=True)
    wait_drdy(c, adc)
    adc.transfer8(A.RDATA)
    assert adc.transfer8(0) == 0x00              # no t6 wait
    assert adc.t6_violations == 1


def test_standby_stops_and_wakeup_resumes():
    c, adc, _ = make_adc()
    wait_drdy(c, adc)
    rdata(c, adc)
    send(c, adc, [A.STANDBY])
    assert adc.next_drdy_time() == math.inf
    c.advance(0.1)
    assert adc.drdy()
    send(c, adc, [A.WAKEUP])
    t0 = c.now - 2e-6
    wait_drdy(c, adc)
    assert c.now - t0 == pytest.approx(0.21e-3 + 256 / 7.68e6, abs=1e-7)


def test_selfcal_removes_adc_offset_and_gain_error():
    c, adc, inp = make_adc(offset_v=1e-3, gain_error=0.01)
    wait_drdy(c, adc)                            # the power-on self-cal already ran
    send(c, adc, [A.WREG | A.MUX, 0x00, 0x28])
    c.advance(1e-3)
    wait_drdy(c, adc)
    assert abs(rdata(c, adc) - inp.b[2]) <= 1
    # zeroing the calibration registers exposes the raw ADC errors
    send(c, adc, [A.WREG | A.OFC0, 0x05, 0, 0, 0, 0x08, 0xAC, 0x44])
    c.advance(1e-3)
    wait_drdy(c, adc)
    raw = rdata(c, adc)
    expected = (inp.b[2] * A.FluxgateFrontEnd(None).volts_per_nT * 1.01 + 1e-3) / 5.0 * 2**23
    assert raw == pytest.approx(expected, abs=1)
    send(c, adc, [A.SELFCAL])
    assert adc.drdy()
    wait_drdy(c, adc)
    assert abs(rdata(c, adc) - inp.b[2]) <= 1


def test_reset_command_restores_registers():
    c, adc, _ = make_adc()
    wait_drdy(c, adc)
    send(c, adc, [A.WREG | A.DRATE, 0x00, 0x03])
    send(c, adc, [A.RESET])
    assert adc.drdy()
    wait_drdy(c, adc)
    send(c, adc, [A.RREG | A.DRATE, 0x00])
    c.advance(A.T6_S)
    assert send(c, adc, [0]) == [0xF0]


def test_absent_adc_reads_ff():
    c, adc, _ = make_adc(absent=True)
    c.advance(1.0)
    assert adc.transfer8(A.RDATA) == 0xFF and adc.drdy()
