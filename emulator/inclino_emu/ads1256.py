"""Register-level model of the TI ADS1256 24-bit delta-sigma ADC digitising
the three fluxgate channels.

The firmware talks to it only through `transfer8(byte) -> byte`, one byte
per call (SPI mode 1, MSB first, CS low for a whole command), plus the DRDY
line (`drdy()`: True = high = no new data).  Each byte happens at
`clock.now`; the caller advances the clock (byte time, the t6 delay before
reading data, waiting for DRDY) -- the model never sleeps.

Facts taken from the data sheet (SBAS288K): the command set and opcodes,
the register map and reset values, DRATE codes, settling times t18 (Table
13), t6 = 50 tCLKIN, the calibration equation (Output = (PGA Vin/(2 VREF) -
OFC/alpha) FSC beta, alpha = 400000h, ideal OFC 0 and FSC 44AC08h at the
high rates), RREG wrap-around, RDATAC monitoring DIN for SDATAC/RESET.
Everything else is a documented model choice (docs/sensors.md).

Wiring (this probe, docs/sensors.md): fluxgate X, Y, Z on AIN0, AIN1, AIN2,
their common reference on AINCOM; the firmware selects MUX = 08h, 18h, 28h.
The front end scales the field so that one count = 1 nT at PGA = 1:
Vin = B * 2 VREF / 2**23 (0.596 uV/nT with VREF = 2.5 V).
"""
from __future__ import annotations

import math
from collections import deque
from dataclasses import dataclass
from typing import Callable

import numpy as np

from .clock import Clock

# Commands
WAKEUP = 0x00
RDATA = 0x01
RDATAC = 0x03
SDATAC = 0x0F
RREG = 0x10
WREG = 0x50
SELFCAL = 0xF0
SELFOCAL = 0xF1
SELFGCAL = 0xF2
SYSOCAL = 0xF3
SYSGCAL = 0xF4
SYNC = 0xFC
STANDBY = 0xFD
RESET = 0xFE
WAKEUP_FF = 0xFF

# Registers
STATUS, MUX, ADCON, DRATE, IO, OFC0, OFC1, OFC2, FSC0, FSC1, FSC2 = range(11)
NREGS = 11
STATUS_ID = 0x3  # ID3..0 as read on an ADS1256
RESET_REGS = [(STATUS_ID << 4) | 0x01, 0x01, 0x20, 0xF0, 0xE0, 0, 0, 0, 0, 0, 0]

F_CLKIN = 7.68e6
T_CLKIN = 1.0 / F_CLKIN
T6_S = 50 * T_CLKIN          # command -> first data bit (RDATA, RDATAC, RREG)
T11_SYNC_S = 24 * T_CLKIN    # SYNC -> WAKEUP
ALPHA = 0x400000
FSC_IDEAL = 0x44AC08
BETA = 2**23 / FSC_IDEAL     # so that FSC_IDEAL * BETA = 2**23 exactly (model)
CODE_MIN, CODE_MAX = -(2**23), 2**23 - 1

# DRATE code -> (samples per second, settling time t18 in seconds), Table 13
DRATES = {0xF0: (30000.0, 0.21e-3), 0xE0: (15000.0, 0.25e-3), 0xD0: (7500.0, 0.31e-3),
          0xC0: (3750.0, 0.44e-3), 0xB0: (2000.0, 0.68e-3), 0xA1: (1000.0, 1.18e-3),
          0x92: (500.0, 2.18e-3), 0x82: (100.0, 10.18e-3), 0x72: (60.0, 16.84e-3),
          0x63: (50.0, 20.18e-3), 0x53: (30.0, 33.51e-3), 0x43: (25.0, 40.18e-3),
          0x33: (15.0, 66.84e-3), 0x23: (10.0, 100.18e-3), 0x13: (5.0, 200.18e-3),
          0x03: (2.5, 400.18e-3)}
STANDBY_WAKE_S = 256 * T_CLKIN  # extra modulator power-up after STANDBY


def cal_time_s(drate_code: int) -> float:
    """Self-calibration duration (model): 3 settling times (2.5 SPS: 1.2 s;
    30 kSPS: 0.63 ms), DRDY high throughout, settled data at the end."""
    return 3.0 * DRATES.get(drate_code, DRATES[0xF0])[1]


@dataclass
class FluxgateFrontEnd:
    """Fluxgate outputs on AIN0..AIN2 around a common-mode voltage, AINCOM
    at the common mode; other inputs at the common mode.

        V(AINk) = vcm + b_k * volts_per_nT,   V(AINCOM) = vcm
    """
    mag_source: Callable  # t -> (3,) nT
    vref: float = 2.5
    vcm: float = 2.5

    @property
    def volts_per_nT(self):
        return 2.0 * self.vref / 2**23

    def __call__(self, t):
        v = np.full(9, self.vcm)
        v[:3] += np.asarray(self.mag_source(t), float).reshape(3) * self.volts_per_nT
        return v

    def differential(self, t, p: int, n: int) -> float:
        """V(AINp) - V(AINn) at t, p, n in 0..8 (8 = AINCOM): the same
        number as v[p] - v[n] with v = __call__(t), from one mag_source
        call, without the (9,) array."""
        b = self.mag_source(t)
        if type(b) is not tuple:
            b = tuple(np.asarray(b, float).reshape(3).tolist())
        k = 2.0 * self.vref / 2**23
        vcm = self.vcm
        return (vcm + b[p] * k if p < 3 else vcm) - (vcm + b[n] * k if n < 3 else vcm)


def _to_u24(code: int) -> list:
    c = code & 0xFFFFFF
    return [(c >> 16) & 0xFF, (c >> 8) & 0xFF, c & 0xFF]


def _bitrev8(b: int) -> int:
    return int(f"{b:08b}"[::-1], 2)


class ADS1256:
    """The part.  `inputs(t) -> (9,)` gives the voltages on AIN0..AIN7 and
    AINCOM (FluxgateFrontEnd); `offset_v` and `gain_error` are the ADC's own
    errors, which self-calibration removes."""

    def __init__(self, clock: Clock, inputs: Callable, vref: float = 2.5,
                 offset_v: float = 0.0, gain_error: float = 0.0, strict_timing: bool = False,
                 absent: bool = False):
        self.clock = clock
        self.inputs = inputs
        self.vref = vref
        self.offset_v = offset_v
        self.gain_error = gain_error
        self.strict_timing = strict_timing
        self.absent = absent
        self.t6_violations = 0
        self.ignored_bytes = 0
        self.reset()

    # ---- state ------------------------------------------------------------
    def reset(self):
        """RESET command / pin / power-on: registers to reset values, then
        a self-calibration (data sheet: after a reset the part calibrates)."""
        now = self.clock.now
        self.regs = list(RESET_REGS)
        self._set_ofc(0)
        self._set_fsc(FSC_IDEAL)
        self.mode = "convert"
        self.rdatac = False
        self._rdatac_ready_at = now
        self.out = deque()
        self._out_ready_at = now
        self._data_read_marks = 0
        self._expect = None
        self.data_code = 0
        self._last_tc = -math.inf
        self.unread = False
        self._mux_changed_at = -math.inf
        self._prev_mux = self.regs[MUX]
        self._sync_at = -math.inf
        self._start_cal(now, "self")

    # _update() does nothing before `_guard` (no calibration end, first
    # conversion or next conversion can fall before it); every state change
    # that may bring those instants earlier (WAKEUP, a DRATE change, a
    # calibration, RESET) sets it again.
    _guard = -math.inf

    def _rate(self):
        return DRATES.get(self.regs[DRATE], DRATES[0xF0])

    def _pga(self):
        return 1 << (self.regs[ADCON] & 0x07 if (self.regs[ADCON] & 0x07) < 7 else 6)

    def _ofc(self):
        v = self.regs[OFC0] | (self.regs[OFC1] << 8) | (self.regs[OFC2] << 16)
        return v - (1 << 24) if v & 0x800000 else v

    def _fsc(self):
        return self.regs[FSC0] | (self.regs[FSC1] << 8) | (self.regs[FSC2] << 16)

    def _set_ofc(self, v):
        v &= 0xFFFFFF
        self.regs[OFC0], self.regs[OFC1], self.regs[OFC2] = v & 0xFF, (v >> 8) & 0xFF, (v >> 16) & 0xFF

    def _set_fsc(self, v):
        v = int(min(max(v, 0), 0xFFFFFF))
        self.regs[FSC0], self.regs[FSC1], self.regs[FSC2] = v & 0xFF, (v >> 8) & 0xFF, (v >> 16) & 0xFF

    def _start_cal(self, now, kind):
        self.mode = "cal"
        self.unread = False
        self._cal_end = now + cal_time_s(self.regs[DRATE])
        self._cal_kind = kind
        self._guard = self._cal_end   # nothing happens before the calibration ends

    def _finish_cal(self):
        pga = self._pga()
        k = self._cal_kind
        if k in ("self", "selfo"):
            self._set_ofc(round(pga * self.offset_v / (2 * self.vref) * ALPHA))
        if k in ("self", "selfg"):
            self._set_fsc(round(FSC_IDEAL / (1.0 + self.gain_error)))
        if k == "syso":  # present input is the system zero
            self._set_ofc(round(pga * self._vin(self._cal_end) / (2 * self.vref) * ALPHA))
        if k == "sysg":  # present input is the system full scale (+2 VREF / PGA)
            x = pga * self._vin(self._cal_end) / (2 * self.vref) - self._ofc() / ALPHA
            if x > 0:
                self._set_fsc(round(FSC_IDEAL / x))
        self.mode = "convert"
        self._conv_first = self._cal_end  # settled data ready when calibration ends

    def _vin(self, t, mux=None):
        mux = self.regs[MUX] if mux is None else mux
        p, n = (mux >> 4) & 0xF, mux & 0xF
        diff = getattr(self.inputs, "differential", None)
        if diff is not None:     # FluxgateFrontEnd: floats, no (9,) array
            d = diff(t, 8 if p & 0x8 else p, 8 if n & 0x8 else n)
        else:
            v = np.asarray(self.inputs(t), float)
            d = (v[8] if p & 0x8 else v[p]) - (v[8] if n & 0x8 else v[n])
        return d * (1.0 + self.gain_error) + self.offset_v

    def code_for(self, vin: float) -> int:
        """Output code for a differential input (volts), data sheet eq. 3."""
        r = self.regs
        a = r[ADCON] & 0x07
        pga = 1 << (a if a < 7 else 6)                      # _pga()
        ofc = r[OFC0] | (r[OFC1] << 8) | (r[OFC2] << 16)    # _ofc()
        if ofc & 0x800000:
            ofc -= 1 << 24
        fsc = r[FSC0] | (r[FSC1] << 8) | (r[FSC2] << 16)    # _fsc()
        x = (pga * vin / (2 * self.vref) - ofc / ALPHA) * fsc * BETA
        c = round(x)
        return CODE_MIN if c < CODE_MIN else (CODE_MAX if c > CODE_MAX else int(c))

    def _update(self):
        """Bring conversions up to clock.now."""
        now = self.clock.now
        if now < self._guard:
            return
        if self.mode == "cal" and now >= self._cal_end:
            self._finish_cal()
        mode = self.mode
        if mode != "convert" or now < self._conv_first:
            self._guard = self._cal_end if mode == "cal" else (
                self._conv_first if mode == "convert" else math.inf)
            return
        period = 1.0 / DRATES.get(self.regs[DRATE], DRATES[0xF0])[0]   # _rate()
        k = math.floor((now - self._conv_first) / period + 1e-9)
        tc = self._conv_first + k * period
        if tc > self._last_tc:
            if tc - period < self._mux_changed_at <= tc and self._mux_changed_at > self._conv_first:
                vin = 0.5 * (self._vin(tc, self._prev_mux) + self._vin(tc))  # unsettled mix
            else:
                vin = self._vin(tc)
            self.data_code = self.code_for(vin)
            self._last_tc = tc
            self.unread = True
        # no conversion k + 1 before this (1e-6 periods early, beyond rounding)
        self._guard = self._conv_first + (k + 1 - 1e-6) * period

    # ---- pins -------------------------------------------------------------
    def drdy(self) -> bool:
        """DRDY pin level: False (low) while unread conversion data wait."""
        if self.absent:
            return True
        if self.clock.now >= self._guard:
            self._update()
        return not self.unread

    def next_drdy_time(self) -> float:
        """When DRDY will next fall (for an emulator loop that jumps the
        clock); inf while stopped (SYNC, STANDBY)."""
        self._update()
        now = self.clock.now
        if self.mode == "cal":
            return self._cal_end
        if self.mode != "convert":
            return math.inf
        if now < self._conv_first:
            return self._conv_first
        period = 1.0 / self._rate()[0]
        return self._last_tc + period

    def cs_high(self):
        """CS taken high: a partly sent command is dropped (RDATAC stays)."""
        self._expect = None
        self.out.clear()

    # ---- SPI --------------------------------------------------------------
    def _data_bytes(self):
        c = self.data_code & 0xFFFFFF
        b = [(c >> 16) & 0xFF, (c >> 8) & 0xFF, c & 0xFF]   # _to_u24
        if self.regs[STATUS] & 0x08:  # ORDER: LSB first within each byte
            b = [_bitrev8(x) for x in b]
        return b

    def transfer8(self, byte: int) -> int:
        """One byte on SPI at clock.now: returns DOUT, acts on DIN."""
        byte &= 0xFF
        if self.absent:
            return 0xFF
        now = self.clock.now
        if now >= self._guard:
            self._update()
        out = self.out
        if out:
            if now < self._out_ready_at:
                self.t6_violations += 1
                if self.strict_timing:
                    return 0x00
            o = out.popleft()
            if self.rdatac and (byte == SDATAC or byte == RESET):
                self._command(byte, now)
            return o
        if self.mode == "cal":
            self.ignored_bytes += 1
            return 0x00
        if self.rdatac:
            if byte in (SDATAC, RESET):
                self._command(byte, now)
                return 0x00
            if self.unread:
                if now < self._rdatac_ready_at:
                    self.t6_violations += 1
                data = self._data_bytes()
                self.unread = False
                self.out.extend(data[1:])
                self._out_ready_at = now
                return data[0]
            return self._data_bytes()[0]  # no new data: stale MSB, DRDY unchanged
        exp = self._expect
        if exp is None:
            self._command(byte, now)
        elif exp[0] == "wdata":        # _continue, inline for the common cases
            r, left = exp[1], exp[2]
            self._write_reg(r % NREGS, byte, now)
            self._expect = ("wdata", r + 1, left - 1) if left > 1 else None
        elif exp[0] == "wreg":
            self._expect = ("wdata", exp[1], (byte & 0x0F) + 1)
        else:
            self._continue(byte, now)
        return 0x00

    def _continue(self, byte, now):
        kind = self._expect[0]
        if kind == "rreg":
            r, n = self._expect[1], (byte & 0x0F) + 1
            self._expect = None
            st = self.regs[STATUS] & 0xFE | (0 if self.unread else 1)
            for i in range(n):
                a = (r + i) % NREGS
                self.out.append(st if a == STATUS else self.regs[a])
            self._out_ready_at = now + T6_S
        elif kind == "wreg":
            self._expect = ("wdata", self._expect[1], (byte & 0x0F) + 1)
        elif kind == "wdata":
            _, r, left = self._expect
            self._write_reg(r % NREGS, byte, now)
            self._expect = ("wdata", r + 1, left - 1) if left > 1 else None

    def _write_reg(self, r, byte, now):
        old = self.regs[r]
        if r == STATUS:
            byte = (old & 0xF1) | (byte & 0x0E)  # ID and DRDY read-only
        elif r == ADCON:
            byte &= 0x7F
        self.regs[r] = byte
        if r == MUX and byte != old:
            self._prev_mux = old
            self._mux_changed_at = now
        if r == DRATE and byte != old and self.mode == "convert":
            self._conv_first = now + self._rate()[1]  # new rate: restart the filter
            self._last_tc = -math.inf
            self.unread = False
            self._guard = self._conv_first
        acal = self.regs[STATUS] & 0x04
        changed = ((r == ADCON and (byte ^ old) & 0x07) or (r == DRATE and byte != old)
                   or (r == STATUS and (byte ^ old) & 0x02))
        if acal and changed:
            self._start_cal(now, "self")

    def _command(self, c, now):
        # (the guard: SYNC and STANDBY only stop conversions, so only
        # WAKEUP, DRATE, calibrations and RESET need _guard reset)
        if (c & 0xF0) == WREG:
            self._expect = ("wreg", c & 0x0F)
        elif c == SYNC:
            self.mode = "sync"
            self.unread = False
            self._sync_at = now
        elif c == WAKEUP or c == WAKEUP_FF:
            if self.mode in ("sync", "standby"):
                extra = STANDBY_WAKE_S if self.mode == "standby" else 0.0
                if self.mode == "sync" and now - self._sync_at < T11_SYNC_S:
                    self.t6_violations += 1
                self.mode = "convert"
                self._conv_first = now + self._rate()[1] + extra
                self._last_tc = -math.inf
                self._guard = self._conv_first   # no conversion before the first
        elif c == RDATA:
            self.out.extend(self._data_bytes())
            self._out_ready_at = now + T6_S
            self.unread = False
        elif c == RDATAC:
            self.rdatac = True
            self._rdatac_ready_at = now + T6_S
        elif c == SDATAC:
            self.rdatac = False
            self.out.clear()
        elif (c & 0xF0) == RREG:
            self._expect = ("rreg", c & 0x0F)
        elif c in (SELFCAL, SELFOCAL, SELFGCAL, SYSOCAL, SYSGCAL):
            self._start_cal(now, {SELFCAL: "self", SELFOCAL: "selfo", SELFGCAL: "selfg",
                                  SYSOCAL: "syso", SYSGCAL: "sysg"}[c])
        elif c == STANDBY:
            self.mode = "standby"
            self.unread = False
        elif c == RESET:
            self.reset()
        else:
            self.ignored_bytes += 1
