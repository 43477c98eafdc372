"""Register-level model of the ADIS16210 triaxial inclinometer on SPI.

The firmware talks to it only through `transfer16(word) -> word`, one
16-bit frame per call (SPI mode 3, MSB first, chip select framing each
word).  The frame happens at `clock.now`: the caller owns the clock and
advances it (frame time, stall time, delays); the model never sleeps.

Protocol (ADIS16210 data sheet):
* read: DIN = (address & 0x7F) << 8 (bit 15 = 0, low byte ignored); the
  16-bit register comes back big-endian on DOUT during the *next* frame,
  which may itself carry the next read command;
* write: DIN = ((address | 0x80) << 8) | byte, one byte per frame, the even
  address holding the low byte and address + 1 the high byte.

Everything the data sheet search did not settle is a documented model
choice; docs/sensors.md has the table (register map, reset values, bits,
timing, unmapped addresses, fault injection).
"""
from __future__ import annotations

import math
from dataclasses import dataclass, field
from typing import Callable, Optional

import numpy as np

from .clock import Clock

# Register addresses (even = low byte)
FLASH_CNT = 0x00
SUPPLY_OUT = 0x02
XACCL_OUT = 0x04
YACCL_OUT = 0x06
ZACCL_OUT = 0x08
TEMP_OUT = 0x0A
XINCL_OUT = 0x0C
YINCL_OUT = 0x0E
ZINCL_OUT = 0x10
XACCL_NULL = 0x12
YACCL_NULL = 0x14
ZACCL_NULL = 0x16
X_ALIGN_REF = 0x18   # ADI's register map (iSensor-FX3-Eval RegMaps/ADIS16210_RegMap.csv)
Y_ALIGN_REF = 0x1A
Z_ALIGN_REF = 0x1C
ALM_MAG_X = 0x20
ALM_MAG_Y = 0x22
ALM_MAG_Z = 0x24
ALM_MAG_S = 0x26
ALM_SMPL_X = 0x28
ALM_SMPL_Y = 0x2A
ALM_SMPL_Z = 0x2C
ALM_CTRL = 0x2E
GPIO_CTRL = 0x32
MSC_CTRL = 0x34
DIO_CTRL = 0x36
AVG_CNT = 0x38
SLP_CNT = 0x3A
DIAG_STAT = 0x3C
GLOB_CMD = 0x3E
LOT_ID1 = 0x52
LOT_ID2 = 0x54
PROD_ID = 0x56
SERIAL_NUM = 0x58
X_NULL_BIAS = 0x70   # ADI's register map
Y_NULL_BIAS = 0x72
Z_NULL_BIAS = 0x74

PROD_ID_VALUE = 0x3F52  # 16210

ACC_LSB_G = 1.0 / 16384.0
INCL_LSB_DEG = 180.0 / 32768.0
SUPPLY_LSB_V = 152.6e-6           # ADI's register map: 0.0001526 V/LSB, 16 bits
TEMP_LSB_C = -0.47                # ADI's ADIS16210 FX3 example: T = (raw - 1331) * -0.47
TEMP_RAW_AT_0C = 1331

# MSC_CTRL bits (model, docs/sensors.md)
MSC_SELF_TEST_MANUAL = 1 << 8     # electrostatic self-test force on while set
MSC_SELF_TEST_AUTO = 1 << 10      # write 1: run the automatic self-test; clears when done
# GLOB_CMD bits (model)
GLOB_FACTORY_RESTORE = 1 << 1     # clear the NULL registers
GLOB_FLASH_UPDATE = 1 << 3        # save writable registers to flash, FLASH_CNT += 1
GLOB_SW_RESET = 1 << 7            # software reset: restore from flash, restart
# DIAG_STAT bits (model)
DIAG_SUPPLY_LOW = 1 << 0
DIAG_SUPPLY_HIGH = 1 << 1
DIAG_FLASH_FAIL = 1 << 2
DIAG_SPI_FAIL = 1 << 3
DIAG_SELF_TEST_FAIL = 1 << 5
DIAG_LATCHED = DIAG_FLASH_FAIL | DIAG_SPI_FAIL | DIAG_SELF_TEST_FAIL

# Writable registers and the bits that stick (others read 0)
WRITABLE = {XACCL_NULL: 0xFFFF, YACCL_NULL: 0xFFFF, ZACCL_NULL: 0xFFFF,
            ALM_MAG_X: 0xFFFF, ALM_MAG_Y: 0xFFFF, ALM_MAG_Z: 0xFFFF, ALM_MAG_S: 0xFFFF,
            ALM_SMPL_X: 0x00FF, ALM_SMPL_Y: 0x00FF, ALM_SMPL_Z: 0x00FF, ALM_CTRL: 0xFFFF,
            GPIO_CTRL: 0x00FF, MSC_CTRL: 0x05FF, DIO_CTRL: 0x00FF, AVG_CNT: 0x000F,
            SLP_CNT: 0x00FF, X_NULL_BIAS: 0xFFFF, Y_NULL_BIAS: 0xFFFF, Z_NULL_BIAS: 0xFFFF}
# Reset values: ADI's register map ("Default" column); the NULL_BIAS
# registers have none there and reset to 0 (model).
RESET_VALUES = {reg: 0 for reg in WRITABLE}
RESET_VALUES[MSC_CTRL] = 0x0002
RESET_VALUES[DIO_CTRL] = 0x0007
RESET_VALUES[AVG_CNT] = 0x0009
AVG_CNT_MAX = 9   # model: the reset value 9 is the largest setting; larger values act as 9
ALIGN_REF = (X_ALIGN_REF, Y_ALIGN_REF, Z_ALIGN_REF)  # read-only, reset 0; model: stay 0


@dataclass
class AdisTiming:
    """Timing of the model (seconds / hertz).  Defaults: docs/sensors.md."""
    stall_s: float = 40e-6            # minimum CS-high time between frames
    startup_s: float = 0.220          # power-on / reset until the SPI answers (model: the
                                      # ADIS16201/16203/16209 Linux drivers' wait)
    internal_rate_hz: float = 4250.0  # internal sample rate; ODR = rate / 2**AVG_CNT
    self_test_s: float = 0.040        # automatic self-test duration
    flash_update_s: float = 0.050     # GLOB_CMD flash update busy time


@dataclass
class AdisFaults:
    """Fault injection: a missing part (MISO pulled up: every frame reads
    0xFFFF), a wrong PROD_ID, a failing self-test, a failing flash update."""
    absent: bool = False
    prod_id: int = PROD_ID_VALUE
    self_test_fails: bool = False
    flash_fails: bool = False


def _s16(x: int) -> int:
    return x - 0x10000 if x & 0x8000 else x


def _u16(x: int) -> int:
    return int(x) & 0xFFFF


class ADIS16210:
    """The part.  `acc_source(t, n_avg) -> (3,) g` gives the analog
    acceleration with every sensor effect except quantisation
    (scenario.Probe.acc_analog); `temp_source(t) -> degC` the probe
    temperature; `supply_v` the supply voltage (settable)."""

    def __init__(self, clock: Clock, acc_source: Callable, temp_source: Callable = None,
                 serial: int = 0x0001, timing: AdisTiming = None, faults: AdisFaults = None,
                 supply_v: float = 3.3, self_test_delta_g=(0.1, 0.1, 0.1), strict_stall: bool = False):
        self.clock = clock
        self.acc_source = acc_source
        self.temp_source = temp_source or (lambda t: 25.0)
        self.serial = serial & 0xFFFF
        self.timing = timing or AdisTiming()
        self.faults = faults or AdisFaults()
        self.supply_v = supply_v
        self.self_test_delta_g = np.asarray(self_test_delta_g, float)
        self.strict_stall = strict_stall
        self.flash = dict(RESET_VALUES)   # non-volatile copy (flash update / restore)
        self.flash_cnt = 0
        self.stall_violations = 0
        self.frames = 0
        self.power_on()

    # ---- power, reset -----------------------------------------------------
    def power_on(self):
        """Power cycle: registers from flash, start-up time, empty pipeline."""
        self.regs = dict(self.flash)
        self.diag = 0
        self._pending = 0x0000
        self._last_frame_t = -math.inf
        self._ready_at = self.clock.now + self.timing.startup_s
        self._filter_start = self._ready_at
        self._sample_k = None
        self._sample = None
        self._busy_until = -math.inf
        self._auto_test_end = None

    def ready(self) -> bool:
        return self.clock.now >= self._ready_at

    # ---- sampling ---------------------------------------------------------
    def n_avg(self) -> int:
        return 1 << min(self.regs[AVG_CNT] & 0xF, AVG_CNT_MAX)

    def output_period_s(self) -> float:
        return self.n_avg() / self.timing.internal_rate_hz

    def _acc_g(self):
        """Acceleration in the output registers now (3 floats, g): the
        sample of the last completed averaging window (taken once per
        window), plus the self-test force while a self-test runs."""
        t = self.clock.now
        n = 1 << min(self.regs[AVG_CNT] & 0xF, AVG_CNT_MAX)   # n_avg()
        T = n / self.timing.internal_rate_hz                  # output_period_s()
        k = math.floor((t - self._filter_start) / T)
        if k < 0:
            return (0.0, 0.0, 0.0)
        if k != self._sample_k:
            tk = self._filter_start + k * T
            a = self.acc_source(tk, n)
            if type(a) is not tuple:
                a = tuple(np.asarray(a, float).reshape(3).tolist())
            self._sample = a
            self._sample_k = k
        a = self._sample
        if self.regs[MSC_CTRL] & MSC_SELF_TEST_MANUAL or (
                self._auto_test_end is not None and t < self._auto_test_end):  # _auto_test_running()
            if not self.faults.self_test_fails:
                d = self.self_test_delta_g
                a = (a[0] + float(d[0]), a[1] + float(d[1]), a[2] + float(d[2]))
        return a

    def _auto_test_running(self):
        return self._auto_test_end is not None and self.clock.now < self._auto_test_end

    def _update_auto_test(self):
        if self._auto_test_end is not None and self.clock.now >= self._auto_test_end:
            self._auto_test_end = None
            self.regs[MSC_CTRL] &= ~MSC_SELF_TEST_AUTO
            if self.faults.self_test_fails:
                self.diag |= DIAG_SELF_TEST_FAIL

    def _acc_count(self, a: float, null_reg: int) -> int:
        """One ACCL_OUT value: clip(clip(round(a / LSB)) + NULL), int16."""
        try:
            raw = round(a / ACC_LSB_G)           # round half to even, as np.round
        except (OverflowError, ValueError):     # inf clips to the rail; nan reads -32768
            raw = -32768 if a != a else (32767 if a > 0 else -32768)
        raw = -32768 if raw < -32768 else (32767 if raw > 32767 else raw)
        v = self.regs[null_reg]
        raw += v - 0x10000 if v & 0x8000 else v
        return -32768 if raw < -32768 else (32767 if raw > 32767 else raw)

    def acc_counts(self):
        """[x, y, z] ACCL_OUT counts (ints)."""
        a = self._acc_g()
        return [self._acc_count(a[0], XACCL_NULL), self._acc_count(a[1], YACCL_NULL),
                self._acc_count(a[2], ZACCL_NULL)]

    def incl_counts(self):
        ax, ay, az = (c * ACC_LSB_G for c in self.acc_counts())
        ang = (math.degrees(math.atan2(ay, az)), math.degrees(math.atan2(az, ax)),
               math.degrees(math.atan2(ax, ay)))
        return [int(np.clip(round(a / INCL_LSB_DEG), -32768, 32767)) for a in ang]

    # ---- registers --------------------------------------------------------
    def read_register(self, addr: int) -> int:
        """The 16-bit value of the register holding byte `addr` (now)."""
        reg = addr & 0x7E
        if self._auto_test_end is not None:
            self._update_auto_test()
        # (most frequent first: the firmware's burst reads ACCL x3, TEMP,
        # PROD_ID, FLASH_CNT)
        if XACCL_OUT <= reg <= ZACCL_OUT:
            i = (reg - XACCL_OUT) >> 1
            return self._acc_count(self._acc_g()[i], XACCL_NULL + 2 * i) & 0xFFFF
        if reg == TEMP_OUT:
            temp = self.temp_source(self.clock.now)
            if type(temp) is not float:
                temp = float(np.asarray(temp))
            raw = round(TEMP_RAW_AT_0C + temp / TEMP_LSB_C)
            return 0 if raw < 0 else (4095 if raw > 4095 else raw)
        if reg == PROD_ID:
            return self.faults.prod_id & 0xFFFF
        if reg == FLASH_CNT:
            return self.flash_cnt & 0xFFFF
        if reg in (XINCL_OUT, YINCL_OUT, ZINCL_OUT):
            return _u16(self.incl_counts()[(reg - XINCL_OUT) // 2])
        if reg == SUPPLY_OUT:
            return int(np.clip(round(self.supply_v / SUPPLY_LSB_V), 0, 0xFFFF))
        if reg == DIAG_STAT:
            v = self.diag & DIAG_LATCHED
            if self.supply_v < 3.0:
                v |= DIAG_SUPPLY_LOW
            if self.supply_v > 3.6:
                v |= DIAG_SUPPLY_HIGH
            self.diag &= ~DIAG_LATCHED  # reading clears the latched flags
            return v
        if reg == SERIAL_NUM:
            return self.serial
        if reg == LOT_ID1:
            return 0x1234
        if reg == LOT_ID2:
            return 0x5678
        if reg == GLOB_CMD or reg in ALIGN_REF:
            return 0x0000
        if reg in WRITABLE:
            return self.regs[reg]
        return 0x0000  # unmapped

    def write_byte(self, addr: int, byte: int):
        reg = addr & 0x7E
        high = addr & 1
        if reg == GLOB_CMD:
            if not high:
                self._command(byte)
            return
        if reg not in WRITABLE:
            return  # read-only or unmapped: ignored
        v = self.regs[reg]
        v = (v & 0x00FF) | (byte << 8) if high else (v & 0xFF00) | byte
        v &= WRITABLE[reg]
        old = self.regs[reg]
        self.regs[reg] = v
        if reg == AVG_CNT and v != old:
            self._filter_start = self.clock.now  # filter restarts
            self._sample_k = None
        if reg == MSC_CTRL and (v & MSC_SELF_TEST_AUTO) and not (old & MSC_SELF_TEST_AUTO):
            self._auto_test_end = self.clock.now + self.timing.self_test_s

    def _command(self, byte: int):
        if byte & GLOB_FACTORY_RESTORE:
            for r in (XACCL_NULL, YACCL_NULL, ZACCL_NULL):
                self.regs[r] = 0
            self._sample_k = None
        if byte & GLOB_FLASH_UPDATE:
            if self.faults.flash_fails:
                self.diag |= DIAG_FLASH_FAIL
            else:
                self.flash = {r: self.regs[r] & (~MSC_SELF_TEST_AUTO if r == MSC_CTRL else 0xFFFF)
                              for r in WRITABLE}
                self.flash_cnt += 1
            self._busy_until = self.clock.now + self.timing.flash_update_s
        if byte & GLOB_SW_RESET:
            self.power_on()

    # ---- SPI --------------------------------------------------------------
    def frame_error(self):
        """The HAL reports a malformed frame (not 16 clocks under CS): the
        frame is discarded and DIAG_STAT[3] latches."""
        self.diag |= DIAG_SPI_FAIL
        self._pending = 0x0000

    def transfer16(self, word: int) -> int:
        """One 16-bit SPI frame at clock.now: returns DOUT, acts on DIN."""
        word &= 0xFFFF
        self.frames += 1
        if self.faults.absent:
            return 0xFFFF
        now = self.clock.now
        if now < self._ready_at or now < self._busy_until:
            self._last_frame_t = now
            return 0x0000  # starting up / busy: DOUT low, command ignored
        stall_ok = now - self._last_frame_t >= self.timing.stall_s
        self._last_frame_t = now
        out = self._pending
        if not stall_ok:
            self.stall_violations += 1
            self.diag |= DIAG_SPI_FAIL
            if self.strict_stall:
                self._pending = 0x0000
                return out
        if word & 0x8000:
            self.write_byte((word >> 8) & 0x7F, word & 0xFF)
            self._pending = 0x0000
        else:
            self._pending = self.read_register((word >> 8) & 0x7F)
        return out
