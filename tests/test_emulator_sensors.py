"""Register-level ADIS16210 and ADS1256 models over byte/word SPI."""
import math

import numpy as np
import pytest

from inclino_emu import adis16210 as ad
from inclino_emu import ads1256 as A
from inclino_emu.clock import Clock
from inclino.model.scenario import load_scenario

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
    c.advance(0.23)  # past start-up (220 ms)
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
    c.advance(0.2)                              # 210 ms: still starting (220 ms, model)
    assert read(c, dev, ad.PROD_ID) == 0
    c.advance(0.01)
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
    assert read(c, dev, ad.SUPPLY_OUT) == 0x5479              # 3.3 V / 152.6 uV = 21625 (ADI's map)
    dev.supply_v = 5.5
    assert read(c, dev, ad.SUPPLY_OUT) == 36042               # 16 bits: no 14-bit clip
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
    assert T == pytest.approx(512 / 4250.0)      # AVG_CNT resets to 9 (ADI's map)
    read(c, dev, ad.XACCL_OUT)
    n = len(src.calls)
    read(c, dev, ad.XACCL_OUT)                  # same window: no new sample
    assert len(src.calls) == n
    c.advance(T)
    read(c, dev, ad.XACCL_OUT)
    assert len(src.calls) == n + 1 and src.calls[-1][1] == 512
    xfer(c, dev, 0xB800 | 0x02)                 # AVG_CNT = 2 -> 4 samples
    c.advance(4 / 4250.0)
    read(c, dev, ad.YACCL_OUT)
    assert src.calls[-1][1] == 4
    xfer(c, dev, 0xB800 | 0x0F)                 # above 9: acts as 9 (model)
    assert dev.n_avg() == 512


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
    c.advance(0.22)
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


# ---- ADIS16210: the whole register map ----------------------------------------
def _incl_counts(v):
    ax, ay, az = v
    return [round(math.degrees(math.atan2(a, b)) / (180 / 32768)) & 0xFFFF
            for a, b in ((ay, az), (az, ax), (ax, ay))]


V0 = (0.25, -0.5, 0.75)
# (name, address, value after power-on with the source V0 at 25 degC, mask of
# the bits a write keeps -- None: read-only / write-only, writes ignored)
ADIS_MAP = [
    ("FLASH_CNT", ad.FLASH_CNT, 0x0000, None),
    ("SUPPLY_OUT", ad.SUPPLY_OUT, 0x5479, None),
    ("XACCL_OUT", ad.XACCL_OUT, 0x1000, None),
    ("YACCL_OUT", ad.YACCL_OUT, 0xE000, None),
    ("ZACCL_OUT", ad.ZACCL_OUT, 0x3000, None),
    ("TEMP_OUT", ad.TEMP_OUT, 1278, None),
    ("XINCL_OUT", ad.XINCL_OUT, _incl_counts(V0)[0], None),
    ("YINCL_OUT", ad.YINCL_OUT, _incl_counts(V0)[1], None),
    ("ZINCL_OUT", ad.ZINCL_OUT, _incl_counts(V0)[2], None),
    ("XACCL_NULL", ad.XACCL_NULL, 0, 0xFFFF),
    ("YACCL_NULL", ad.YACCL_NULL, 0, 0xFFFF),
    ("ZACCL_NULL", ad.ZACCL_NULL, 0, 0xFFFF),
    ("X_ALIGN_REF", ad.X_ALIGN_REF, 0, None),
    ("Y_ALIGN_REF", ad.Y_ALIGN_REF, 0, None),
    ("Z_ALIGN_REF", ad.Z_ALIGN_REF, 0, None),
    ("ALM_MAG_X", ad.ALM_MAG_X, 0, 0xFFFF),
    ("ALM_MAG_Y", ad.ALM_MAG_Y, 0, 0xFFFF),
    ("ALM_MAG_Z", ad.ALM_MAG_Z, 0, 0xFFFF),
    ("ALM_MAG_S", ad.ALM_MAG_S, 0, 0xFFFF),
    ("ALM_SMPL_X", ad.ALM_SMPL_X, 0, 0x00FF),
    ("ALM_SMPL_Y", ad.ALM_SMPL_Y, 0, 0x00FF),
    ("ALM_SMPL_Z", ad.ALM_SMPL_Z, 0, 0x00FF),
    ("ALM_CTRL", ad.ALM_CTRL, 0, 0xFFFF),
    ("GPIO_CTRL", ad.GPIO_CTRL, 0, 0x00FF),
    ("MSC_CTRL", ad.MSC_CTRL, 0x0002, 0x05FF),
    ("DIO_CTRL", ad.DIO_CTRL, 0x0007, 0x00FF),
    ("AVG_CNT", ad.AVG_CNT, 0x0009, 0x000F),
    ("SLP_CNT", ad.SLP_CNT, 0, 0x00FF),
    ("DIAG_STAT", ad.DIAG_STAT, 0, None),
    ("GLOB_CMD", ad.GLOB_CMD, 0, None),
    ("LOT_ID1", ad.LOT_ID1, 0x1234, None),
    ("LOT_ID2", ad.LOT_ID2, 0x5678, None),
    ("PROD_ID", ad.PROD_ID, 0x3F52, None),
    ("SERIAL_NUM", ad.SERIAL_NUM, 0x1234, None),
    ("X_NULL_BIAS", ad.X_NULL_BIAS, 0, 0xFFFF),
    ("Y_NULL_BIAS", ad.Y_NULL_BIAS, 0, 0xFFFF),
    ("Z_NULL_BIAS", ad.Z_NULL_BIAS, 0, 0xFFFF),
]


def test_adis_map_is_the_models_map():
    """The table below is the model's register map (and every other address
    reads 0 and ignores writes: test_unmapped_addresses...)."""
    assert all(getattr(ad, n) == a for n, a, *_ in ADIS_MAP)
    assert {a: m for _, a, _, m in ADIS_MAP if m is not None} == ad.WRITABLE


@pytest.mark.parametrize("name,addr,reset,mask", ADIS_MAP, ids=[m[0] for m in ADIS_MAP])
def test_every_mapped_register_reads_its_reset_value_and_keeps_its_writable_bits(name, addr, reset, mask):
    c, dev, _ = make_adis(V0)
    assert read(c, dev, addr) == reset
    assert read(c, dev, addr | 1) == reset                  # the odd address reads the same register
    if name == "GLOB_CMD":
        return                                              # commands: test_flash_update..., test_glob_cmd...
    xfer(c, dev, ((addr | 0x80) << 8) | 0xA5)               # low byte
    xfer(c, dev, (((addr + 1) | 0x80) << 8) | 0xFF)         # high byte
    if mask is None:
        assert read(c, dev, addr) == reset                  # read-only: the writes are ignored
    else:
        assert read(c, dev, addr) == 0xFFA5 & mask
        xfer(c, dev, ((addr | 0x80) << 8) | 0x00)
        assert read(c, dev, addr) == 0xFF00 & mask          # a byte write leaves the other byte
    assert dev.stall_violations == 0


def test_glob_cmd_high_byte_and_unknown_bits_do_nothing():
    c, dev, _ = make_adis(V0)
    xfer(c, dev, 0x9200 | 0x07)                             # XACCL_NULL = 7
    xfer(c, dev, 0xBF00 | 0xFF)                             # GLOB_CMD high byte: ignored
    xfer(c, dev, 0xBE00 | 0x01)                             # bit 0: not a command of the model
    assert read(c, dev, ad.XACCL_NULL) == 7 and read(c, dev, ad.FLASH_CNT) == 0
    assert read(c, dev, ad.PROD_ID) == 0x3F52               # no reset happened


def test_unmapped_addresses_read_zero_and_ignore_writes():
    c, dev, _ = make_adis(V0)
    mapped = {a for _, a, *_ in ADIS_MAP}
    for addr in range(0, 0x80, 2):
        if addr in mapped:
            continue
        xfer(c, dev, ((addr | 0x80) << 8) | 0x5A)
        xfer(c, dev, (((addr + 1) | 0x80) << 8) | 0x5A)
        assert read(c, dev, addr) == 0x0000, hex(addr)
    assert [read(c, dev, a) for _, a, r, _ in ADIS_MAP[9:12]] == [0, 0, 0]  # neighbours untouched


def test_frames_while_the_flash_update_is_busy_are_ignored():
    c, dev, _ = make_adis(V0)
    xfer(c, dev, 0x9400 | 0x10)                             # YACCL_NULL = 0x0010
    xfer(c, dev, 0xBE00 | ad.GLOB_FLASH_UPDATE)             # busy for 50 ms
    assert xfer(c, dev, 0x5600) == 0x0000                   # DOUT low, the read is not taken
    xfer(c, dev, 0x9400 | 0x20)                             # a write while busy: dropped
    assert xfer(c, dev, 0x0000) == 0x0000
    c.advance(0.05)
    assert xfer(c, dev, 0x1400) == 0x0000                   # the pipeline still holds the GLOB_CMD write's 0
    assert xfer(c, dev, 0x0000) == 0x0010                   # YACCL_NULL as it was before the busy time
    assert read(c, dev, ad.FLASH_CNT) == 1


def test_strict_stall_drops_the_too_early_command():
    c, dev, _ = make_adis(V0, strict_stall=True)
    xfer(c, dev, 0x5600)                                    # PROD_ID queued
    c.advance(10e-6)                                        # 10 us < 40 us
    assert dev.transfer16(0x5800) == 0x3F52                 # what was queued still comes out ...
    c.advance(STALL)
    assert dev.transfer16(0x0000) == 0x0000                 # ... but SERIAL_NUM was never queued
    assert dev.stall_violations == 1
    assert read(c, dev, ad.DIAG_STAT) & ad.DIAG_SPI_FAIL


def test_frame_error_discards_the_pipeline_and_latches_spi_fail():
    c, dev, _ = make_adis(V0)
    xfer(c, dev, 0x5600)
    dev.frame_error()                                       # a frame that was not 16 clocks
    assert xfer(c, dev, 0x3C00) == 0x0000                   # PROD_ID was lost
    assert xfer(c, dev, 0x0000) & ad.DIAG_SPI_FAIL
    assert read(c, dev, ad.DIAG_STAT) == 0


def test_software_reset_while_a_read_is_pending():
    c, dev, _ = make_adis(V0)
    xfer(c, dev, 0x5600)
    assert xfer(c, dev, 0xBE00 | ad.GLOB_SW_RESET) == 0x3F52  # the reset frame still clocks out PROD_ID
    assert xfer(c, dev, 0x5600) == 0x0000                   # restarting: 220 ms of zeros
    c.advance(0.16)
    assert xfer(c, dev, 0x5600) == 0x0000                   # still starting at 160 ms
    c.advance(0.06)
    assert xfer(c, dev, 0x5600) == 0x0000                   # the pipeline restarted empty
    assert xfer(c, dev, 0x0000) == 0x3F52


# ---- the HAL's framing (Board) ---------------------------------------------------
def make_board():
    from inclino_emu.flash import S12XFlash
    from inclino_emu.hal import Board, SciPort
    c = Clock()
    dev = ad.ADIS16210(c, Const(V0), serial=0x1234)
    adc = A.ADS1256(c, Inputs())
    b = Board(c, dev, adc, S12XFlash(), SciPort(c))
    c.advance(0.3)
    wait_drdy(c, adc)
    return c, b


def test_board_nothing_selected_reads_all_ones_and_takes_the_frame_time():
    c, b = make_board()
    t0 = c.now
    assert b.spi_xfer16(0x5600) == 0xFFFF and b.spi_xfer8(A.RDATA) == 0xFF
    assert c.now - t0 == pytest.approx(24 / 781250.0)
    b.spi_select(7)                                         # not a device: nothing selected
    assert b.selected is None and b.spi_xfer16(0x5600) == 0xFFFF
    assert b.adis.frames == 0 and not b.adc.out


def test_board_word_frame_into_the_adc_drops_its_command():
    c, b = make_board()
    b.spi_select(1)
    b.spi_xfer8(A.WREG | A.MUX)
    b.spi_xfer8(0x00)
    assert b.spi_xfer16(0x2800) == 0xFFFF                   # 16 clocks into a byte part: lost
    b.spi_xfer8(0x28)                                       # now taken as a command: not an opcode
    b.spi_deselect()
    assert b.adc.regs[A.MUX] == 0x01 and b.adc.ignored_bytes == 1


def test_board_switching_chip_select_mid_command_drops_it():
    c, b = make_board()
    b.spi_select(1)
    b.spi_xfer8(A.RDATA)
    c.advance(A.T6_S)
    assert b.spi_xfer8(0) == A._to_u24(b.adc.data_code)[0]
    b.spi_select(0)                                         # ADC deselected after one data byte
    assert b.spi_xfer16(0x5600) == 0x0000
    b.spi_select(1)
    assert b.spi_xfer8(0x00) == 0x00                        # not the second data byte: a new command
    assert not b.adc.out


def test_board_dead_after_a_power_cut():
    c, b = make_board()
    b.flash.cut_power_at(1, "none")
    assert b.flash_erase(0x7A0000) == 4                     # HAL_FLASH_E_TIMEOUT: the cut
    b.spi_select(0)
    assert b.spi_xfer16(0x5600) == 0xFFFF
    b.spi_select(1)
    assert b.spi_xfer8(A.RDATA) == 0xFF and b.adc_drdy() == 1
    assert b.sci_getc() == -1 and b.sci_putc(0x41) == 0
    assert b.adis.frames == 0


# ---- ADS1256: the whole register map and malformed sequences -------------------
def rreg(c, adc, reg, n=1):
    send(c, adc, [A.RREG | reg, n - 1])
    c.advance(A.T6_S)
    return send(c, adc, [0] * n)


# (register, reset, byte written, read back)
ADS_MAP = [
    (A.MUX, 0x01, 0x5A, 0x5A),
    (A.ADCON, 0x20, 0xFF, 0x7F),     # bit 7 reads 0
    (A.DRATE, 0xF0, 0x23, 0x23),
    (A.IO, 0xE0, 0x5A, 0x5A),        # stored only
    (A.OFC0, 0x00, 0x12, 0x12),
    (A.OFC1, 0x00, 0x34, 0x34),
    (A.OFC2, 0x00, 0x56, 0x56),
    (A.FSC0, 0x08, 0x9A, 0x9A),
    (A.FSC1, 0xAC, 0xBC, 0xBC),
    (A.FSC2, 0x44, 0x40, 0x40),
]


@pytest.mark.parametrize("reg,reset,wr,back", ADS_MAP, ids=[f"reg{r[0]}" for r in ADS_MAP])
def test_every_adc_register_resets_writes_and_reads_back(reg, reset, wr, back):
    c, adc, _ = make_adc()
    wait_drdy(c, adc)
    assert rreg(c, adc, reg) == [reset]
    send(c, adc, [A.WREG | reg, 0x00, wr])
    assert rreg(c, adc, reg) == [back]
    assert adc.ignored_bytes == 0


def test_adc_status_id_and_drdy_bits_are_read_only():
    c, adc, _ = make_adc()
    wait_drdy(c, adc)
    send(c, adc, [A.WREG | A.DRATE, 0x00, 0x82])            # 100 SPS: no new data while we look
    wait_drdy(c, adc)
    assert rreg(c, adc, A.STATUS) == [0x30]                 # ID 3, DRDY low (data waiting)
    send(c, adc, [A.WREG | A.STATUS, 0x00, 0x09])           # try ID 0 and DRDY 1; ORDER = 1
    assert rreg(c, adc, A.STATUS) == [0x38]
    rdata(c, adc)
    assert rreg(c, adc, A.STATUS)[0] & 0x01 == 1            # data read: DRDY high


def test_adc_rreg_and_wreg_wrap_around_after_the_last_register():
    c, adc, _ = make_adc()
    wait_drdy(c, adc)
    assert rreg(c, adc, A.FSC1, 4) == [0xAC, 0x44, 0x30, 0x01]   # FSC1, FSC2, STATUS, MUX
    send(c, adc, [A.WREG | A.FSC2, 0x01, 0x45, 0x00])       # FSC2, then STATUS
    assert rreg(c, adc, A.FSC2) == [0x45] and rreg(c, adc, A.STATUS)[0] & 0x0E == 0


def test_adc_order_bit_sends_each_data_byte_lsb_first():
    c, adc, inp = make_adc()
    wait_drdy(c, adc)
    send(c, adc, [A.WREG | A.MUX, 0x00, 0x08])
    c.advance(1e-3)
    wait_drdy(c, adc)
    msb_first = A._to_u24(adc.data_code)
    send(c, adc, [A.WREG | A.STATUS, 0x00, 0x08])           # ORDER = 1
    send(c, adc, [A.RDATA])
    c.advance(A.T6_S)
    assert send(c, adc, [0, 0, 0]) == [A._bitrev8(b) for b in msb_first]


def test_adc_auto_calibration_on_pga_change():
    c, adc, _ = make_adc()
    wait_drdy(c, adc)
    send(c, adc, [A.WREG | A.STATUS, 0x00, 0x04])           # ACAL on
    assert not adc.drdy()                                   # (no change of PGA/DRATE/BUFEN yet)
    send(c, adc, [A.WREG | A.ADCON, 0x00, 0x21])            # PGA 2: self-calibration starts
    assert adc.mode == "cal" and adc.drdy()
    assert adc.next_drdy_time() == pytest.approx(c.now - 2e-6 + A.cal_time_s(0xF0))


def test_adc_commands_during_a_calibration_are_ignored():
    c, adc, _ = make_adc()
    wait_drdy(c, adc)
    send(c, adc, [A.WREG | A.DRATE, 0x00, 0x03])            # 2.5 SPS: a 1.2 s calibration
    send(c, adc, [A.SELFCAL])
    assert adc.drdy()
    out = send(c, adc, [A.WREG | A.MUX, 0x00, 0x18, A.RDATA, A.STANDBY])
    assert out == [0] * 5 and adc.ignored_bytes == 5
    assert adc.regs[A.MUX] == 0x01 and adc.mode == "cal"
    wait_drdy(c, adc)
    assert adc.mode == "convert" and adc.regs[A.MUX] == 0x01


def test_adc_clocking_without_a_command_reads_zeros_and_changes_nothing():
    c, adc, _ = make_adc()
    wait_drdy(c, adc)
    send(c, adc, [A.WREG | A.DRATE, 0x00, 0x82])            # 100 SPS: no new data meanwhile
    wait_drdy(c, adc)
    code = adc.data_code
    assert send(c, adc, [0x00, 0x00, 0x00]) == [0, 0, 0]   # DIN 0x00 = WAKEUP: nothing to wake
    assert send(c, adc, [0xFF]) == [0]                      # 0xFF = WAKEUP too
    assert not adc.drdy() and adc.data_code == code         # the waiting data are still there
    assert rdata(c, adc) == s24(A._to_u24(code))
    assert send(c, adc, [0x00]) == [0]                      # a fourth data byte: nothing left to send


def test_adc_din_is_not_decoded_while_an_answer_is_clocked_out():
    c, adc, _ = make_adc()
    wait_drdy(c, adc)
    send(c, adc, [A.WREG | A.DRATE, 0x00, 0x82])
    wait_drdy(c, adc)
    want = A._to_u24(adc.data_code)
    send(c, adc, [A.RDATA])
    c.advance(A.T6_S)
    assert send(c, adc, [A.SYNC, A.STANDBY, A.RESET]) == want
    assert adc.mode == "convert" and adc.ignored_bytes == 0


def test_adc_undefined_opcodes_are_counted_and_ignored():
    c, adc, _ = make_adc()
    wait_drdy(c, adc)
    send(c, adc, [0x02, 0x20, 0x40, 0x60, 0xE0, 0xF5])
    assert adc.ignored_bytes == 6 and adc.mode == "convert" and not adc.rdatac


def test_adc_chip_select_dropped_mid_command_or_mid_data():
    c, adc, _ = make_adc()
    wait_drdy(c, adc)
    send(c, adc, [A.WREG | A.DRATE, 0x00, 0x82])
    wait_drdy(c, adc)
    send(c, adc, [A.WREG | A.MUX, 0x00])
    adc.cs_high()                                           # the WREG is dropped ...
    send(c, adc, [0x28])                                    # ... and this byte is a command (none)
    assert adc.regs[A.MUX] == 0x01 and adc.ignored_bytes == 1
    code = adc.data_code
    send(c, adc, [A.RDATA])
    c.advance(A.T6_S)
    assert send(c, adc, [0x00]) == [A._to_u24(code)[0]]
    adc.cs_high()                                           # the other two data bytes are dropped
    assert send(c, adc, [0x00, 0x00]) == [0, 0] and not adc.out
    send(c, adc, [A.RREG | A.MUX, 0x00])
    adc.cs_high()                                           # an RREG answer dropped likewise
    assert send(c, adc, [0x00]) == [0]


def test_adc_rdatac_ignores_other_commands():
    c, adc, _ = make_adc()
    wait_drdy(c, adc)
    send(c, adc, [A.RDATAC])
    c.advance(A.T6_S)
    send(c, adc, [0, 0, 0])
    wait_drdy(c, adc)
    send(c, adc, [A.WREG | A.MUX, 0x00, 0x18])              # clocked as data, not executed
    assert adc.regs[A.MUX] == 0x01 and adc.rdatac
    send(c, adc, [A.SDATAC])
    assert not adc.rdatac


def test_adc_mux_change_without_sync_mixes_the_next_conversion():
    c, adc, inp = make_adc()
    wait_drdy(c, adc)
    send(c, adc, [A.WREG | A.MUX, 0x00, 0x08])
    c.advance(1e-3)
    wait_drdy(c, adc)
    rdata(c, adc)
    send(c, adc, [A.WREG | A.MUX, 0x00, 0x18])              # no SYNC/WAKEUP
    wait_drdy(c, adc)
    assert rdata(c, adc) == round((inp.b[0] + inp.b[1]) / 2)  # the unsettled mix
    wait_drdy(c, adc)
    assert rdata(c, adc) == round(inp.b[1])                  # settled one conversion later


def test_adc_system_offset_and_gain_calibration():
    c, adc, inp = make_adc()
    wait_drdy(c, adc)
    send(c, adc, [A.WREG | A.MUX, 0x00, 0x08])
    c.advance(1e-3)
    wait_drdy(c, adc)
    send(c, adc, [A.SYSOCAL])                               # the present input is the zero
    wait_drdy(c, adc)
    assert abs(rdata(c, adc)) <= 1
    inp.b = np.array([inp.b[0] + 1000.0, 0.0, 0.0])
    c.advance(1e-3)
    wait_drdy(c, adc)
    assert rdata(c, adc) == pytest.approx(1000, abs=1)
    inp.b = np.array([4.0e6, 0.0, 0.0])                     # about half of +2 VREF
    send(c, adc, [A.SYSGCAL])                               # the present input is full scale
    wait_drdy(c, adc)
    assert rdata(c, adc) == pytest.approx(2**23 - 1, abs=1)
    inp.b = np.array([2.0e6, 0.0, 0.0])
    c.advance(1e-3)
    wait_drdy(c, adc)
    z = 12345.0                                             # the system zero taken above
    assert rdata(c, adc) == pytest.approx((2.0e6 - z) / (4.0e6 - z) * 2**23, abs=2)
