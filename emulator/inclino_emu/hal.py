"""The firmware's hardware abstraction layer (firmware/include/inclino/hal.h)
in the emulator: cffi `extern "Python+C"` callbacks of the module
`inclino_emu._fw` (emulator/inclino_emu/_build_fw.py), bound to one `Board` at a time.

A Board wires the HAL to the register models and the emulator clock:

* SPI: HAL_DEV_ADIS -> ADIS16210.transfer16, HAL_DEV_ADC -> ADS1256.transfer8;
  each frame happens at clock.now, then the clock advances by the frame's
  bit times (781.25 kHz SCLK: 20.48 us per 16-bit frame, 10.24 us per byte).
  Deselecting the ADC calls ADS1256.cs_high().  Nothing selected, or the
  wrong frame size for the device, reads as an undriven MISO (all ones); a
  byte frame to the ADIS16210 is a malformed frame (ADIS16210.frame_error).
* DRDY: ADS1256.drdy().
* time: hal_millis = floor(clock.now * 1000) mod 2^32; hal_delay_us
  advances the clock.
* flash: S12XFlash (emulator/inclino_emu/flash.py) with its FSTAT bits mapped to
  HAL_FLASH_*; each program / erase charges its duration to the clock.
* SCI: `SciPort`, one byte queue per direction (see its docstring).

When the flash loses power (a power cut injected at the n-th program or
erase), the board goes dead: from then on SPI reads all ones, DRDY stays
high, flash commands fail with HAL_FLASH_E_TIMEOUT and SCI is silent, so
the interrupted firmware call runs to its end quickly without changing
anything; EmulatedProbe then restarts the firmware.

An exception inside a callback cannot cross the C stack: it is stored in
Board.error (the first one) and the callback returns a safe value;
EmulatedProbe re-raises it when the C call returns.

Cost: a survey makes ~1700 callbacks, so each one is kept to a single
Python call: `attach(board)` binds the 13 `hal_*` externs directly to the
board's bound methods (once per board change), and the methods do their
work inline.
"""
from __future__ import annotations

import ctypes
import math
from collections import deque
from typing import Optional

from . import _fw as _fw_module
from . import flash as fl
from ._fw import ffi, lib

# hal.h constants
HAL_DEV_ADIS = 0
HAL_DEV_ADC = 1
HAL_FLASH_OK = 0
HAL_FLASH_E_ACCESS = 1
HAL_FLASH_E_PROTECT = 2
HAL_FLASH_E_VERIFY = 3
HAL_FLASH_E_TIMEOUT = 4
HAL_SCI_RX_BUF = 64
HAL_SCI_TX_BUF = 128

SPI_HZ = 781250.0


def fstat_to_hal(st) -> int:
    """S12XFlash FSTAT error bits (None = unpowered) to a HAL_FLASH_* code."""
    if st is None:
        return HAL_FLASH_E_TIMEOUT
    if st & fl.ACCERR:
        return HAL_FLASH_E_ACCESS
    if st & fl.FPVIOL:
        return HAL_FLASH_E_PROTECT
    if st & (fl.MGSTAT1 | fl.MGSTAT0):
        return HAL_FLASH_E_VERIFY
    return HAL_FLASH_OK


class SciPort:
    """The probe's SCI as two byte queues.

    Host -> probe: `push(data)` puts bytes on the line; each byte arrives
    10 bit times (8N1) after the previous one, or after the push for the
    first byte on an idle line, when `baud` is set,
    at once when `baud` is None (unthrottled).  The firmware takes arrived
    bytes with hal_sci_getc.  With a baud rate the probe's receive buffer
    holds `rx_capacity` (HAL_SCI_RX_BUF) arrived, unread bytes; bytes
    arriving beyond that are lost and counted in `overruns` (as the
    interrupt-filled ring of the real probe).  Unthrottled input waits on
    the line and is never lost.

    Probe -> host: hal_sci_putc hands a byte to the transmitter; with a
    baud rate the transmitter holds `tx_depth` bytes (the HAL's
    interrupt-emptied ring of HAL_SCI_TX_BUF bytes, less the one slot a ring
    keeps free, plus the data and shift registers) and each byte leaves 10
    bit times after the previous one, whatever the firmware is doing; when
    it is full putc reports 0.  Unthrottled, every byte leaves at
    once.  `pull()` returns the bytes that have left by clock.now.
    """

    def __init__(self, clock, baud: Optional[float] = None, rx_capacity: int = HAL_SCI_RX_BUF,
                 tx_depth: int = HAL_SCI_TX_BUF + 1):
        self.clock = clock
        self.baud = baud
        self.rx_capacity = rx_capacity
        self.tx_depth = tx_depth
        self.reset()

    def reset(self):
        self.rx = deque()           # (t_arrival, byte) on the line / in the buffer
        self.tx = deque()           # (t_leaves, byte) in the transmitter
        self.out = bytearray()      # bytes that have left, waiting for pull()
        self.overruns = 0
        self._rx_last = -math.inf
        self._tx_last = -math.inf

    @property
    def byte_time(self) -> float:
        return 0.0 if self.baud is None else 10.0 / float(self.baud)

    # host side
    def push(self, data: bytes):
        now = self.clock.now
        for b in bytes(data):
            t = max(now, self._rx_last) + self.byte_time if self.baud else now
            self._rx_last = t
            self.rx.append((t, b))

    def pull(self, max_bytes: Optional[int] = None) -> bytes:
        self._drain_tx()
        n = len(self.out) if max_bytes is None else min(max_bytes, len(self.out))
        data = bytes(self.out[:n])
        del self.out[:n]
        return data

    def next_event(self) -> float:
        """Time of the next byte arrival or departure (inf if none)."""
        t = math.inf
        if self.rx and self.rx[0][0] > self.clock.now:
            t = self.rx[0][0]
        if self.tx:
            t = min(t, self.tx[0][0])
        return t

    # firmware side
    def _overrun(self):
        if self.baud is None:
            return
        now = self.clock.now
        arrived = 0
        for t, _ in self.rx:
            if t > now:
                break
            arrived += 1
        if arrived > self.rx_capacity:
            keep = list(self.rx)
            # the oldest rx_capacity arrived bytes are in the buffer; later arrivals were lost
            lost = arrived - self.rx_capacity
            self.overruns += lost
            self.rx = deque(keep[:self.rx_capacity] + keep[arrived:])

    def getc(self) -> int:
        self._overrun()
        if self.rx and self.rx[0][0] <= self.clock.now:
            return self.rx.popleft()[1]
        return -1

    def _drain_tx(self):
        now = self.clock.now
        while self.tx and self.tx[0][0] <= now:
            self.out.append(self.tx.popleft()[1])

    def putc(self, b: int) -> int:
        if self.baud is None:
            self.out.append(b & 0xFF)
            return 1
        self._drain_tx()
        if len(self.tx) >= self.tx_depth:
            return 0
        t = max(self.clock.now, self._tx_last) + self.byte_time
        self._tx_last = t
        self.tx.append((t, b & 0xFF))
        return 1


class Board:
    """Everything the HAL of one emulated probe reaches.  Its methods are
    the HAL callbacks (`attach`); each frame or wait advances the clock
    exactly as Clock.advance would (same additions, in the same order)."""

    def __init__(self, clock, adis, adc, flash: fl.S12XFlash, sci: SciPort, spi_hz: float = SPI_HZ):
        self.clock = clock
        self.adis = adis
        self.adc = adc
        self.flash = flash
        self.sci = sci
        self.bit_s = 1.0 / spi_hz
        self.selected = None
        self.error: Optional[BaseException] = None

    @property
    def bit_s(self) -> float:
        return self._bit_s

    @bit_s.setter
    def bit_s(self, v: float):
        self._bit_s = v
        self._t8 = 8 * v        # one byte frame
        self._t16 = 16 * v      # one word frame

    @property
    def dead(self) -> bool:
        return not self.flash.powered

    # ---- the HAL ----------------------------------------------------------
    def init(self):
        pass

    def spi_select(self, dev):
        if self.selected == HAL_DEV_ADC and dev != HAL_DEV_ADC:
            self.adc.cs_high()
        self.selected = dev if dev == HAL_DEV_ADIS or dev == HAL_DEV_ADC else None

    def spi_deselect(self):
        if self.selected == HAL_DEV_ADC:
            self.adc.cs_high()
        self.selected = None

    def spi_xfer16(self, out):
        r = 0xFFFF
        if self.flash.powered:
            sel = self.selected
            if sel == HAL_DEV_ADIS:
                r = self.adis.transfer16(out)
            elif sel == HAL_DEV_ADC:
                self.adc.cs_high()      # 16 clocks into a byte-command part: the command is lost
        self.clock.now += self._t16
        return r & 0xFFFF

    def spi_xfer8(self, out):
        if self.selected == HAL_DEV_ADC and self.flash.powered:   # the usual case first
            r = self.adc.transfer8(out)
        else:
            r = 0xFF
            if self.selected == HAL_DEV_ADIS and self.flash.powered:
                self.adis.frame_error()  # 8 clocks under CS: malformed frame
        self.clock.now += self._t8
        return r & 0xFF

    def adc_drdy(self):
        return 1 if not self.flash.powered or self.adc.drdy() else 0

    def millis(self):
        return math.floor(self.clock.now * 1000.0 + 1e-9) & 0xFFFFFFFF

    def delay_us(self, us):
        self.clock.now += us * 1e-6

    def sci_getc(self):
        return -1 if self.dead else self.sci.getc()

    def sci_putc(self, b):
        return 0 if self.dead else self.sci.putc(b)

    def flash_read(self, addr, dst, n):
        data = self.flash.read(addr, n)
        if data is None:
            return HAL_FLASH_E_TIMEOUT if self.dead else HAL_FLASH_E_ACCESS
        ffi.memmove(dst, data, n)
        return HAL_FLASH_OK

    def flash_program(self, addr, data):
        st = self.flash.program(addr, bytes(ffi.buffer(data, fl.PHRASE)))
        self.clock.advance(self.flash.timing.program_s)
        return fstat_to_hal(st)

    def flash_erase(self, addr):
        st = self.flash.erase(addr)
        self.clock.advance(self.flash.timing.erase_s)
        return fstat_to_hal(st)


_board: Optional[Board] = None

# the HAL functions of hal.h and the Board methods behind them
HAL_FUNCTIONS = ("init", "spi_select", "spi_deselect", "spi_xfer16", "spi_xfer8", "adc_drdy",
                 "millis", "delay_us", "sci_getc", "sci_putc", "flash_read", "flash_program",
                 "flash_erase")


def _onerror(exc_type, exc_value, tb):
    if _board is not None and _board.error is None:
        _board.error = exc_value if exc_value is not None else exc_type()


def _unattached(*args):
    raise RuntimeError("no emulated board attached to the firmware HAL")


def _bind(board: Optional[Board]):
    for name in HAL_FUNCTIONS:
        fn = _unattached if board is None else getattr(board, name)
        ffi.def_extern(name="hal_" + name, onerror=_onerror)(fn)


def attach(board: Optional[Board]):
    """Bind the HAL callbacks to `board` (None: detach).  Cheap when
    `board` is already attached."""
    global _board
    if board is _board:
        return
    _board = board
    _bind(board)


def current() -> Optional[Board]:
    return _board


class counting:
    """Context manager: count the HAL callbacks made while it is open (per
    function name, in `.counts`), for cost accounting (bench emulator).
    The counting wrappers cost time; do not time code inside it."""

    def __init__(self, board: Board):
        self.board = board
        self.counts = {name: 0 for name in HAL_FUNCTIONS}

    def __enter__(self):
        def wrap(name, fn):
            def counted(*args):
                self.counts[name] += 1
                return fn(*args)
            return counted
        global _board
        _board = self.board
        for name in HAL_FUNCTIONS:
            ffi.def_extern(name="hal_" + name, onerror=_onerror)(wrap(name, getattr(self.board, name)))
        return self

    def __exit__(self, *exc):
        _bind(_board)

    @property
    def total(self) -> int:
        return sum(self.counts.values())


_bind(None)


# --------------------------------------------------------------------------
# Firmware calls that keep the GIL
_INT_RANGES = {f"{s}int{n}_t": ((-(1 << (n - 1)), (1 << (n - 1)) - 1) if s == "" else (0, (1 << n) - 1))
               for n in (8, 16, 32, 64) for s in ("", "u")}
_CTYPES = {f"{s}int{n}_t": getattr(ctypes, f"c_{s}int{n}") for n in (8, 16, 32, 64) for s in ("", "u")}


class GilHeldLib:
    """The firmware's C functions, called without releasing the GIL.

    cffi releases the GIL around every call into C, so each HAL callback
    the call makes takes the GIL back and drops it again (~60 ns of the
    ~200 ns a callback costs, ~1700 callbacks a survey).  This calls the
    same functions -- the exported symbols of the `inclino_emu._fw` shared
    object -- through ctypes.PyDLL, which keeps the GIL held, so the
    callbacks find it held.  Same arguments as `lib` (ints, cffi pointers
    and arrays), same results (int, None for void); anything else (bytes,
    an out-of-range int, a function with other types) goes through `lib`
    itself, so errors are cffi's.  Other threads run only while a callback
    runs Python code, as before."""

    def __init__(self):
        self._dll = ctypes.PyDLL(_fw_module.__file__)

    def __getattr__(self, name):
        fn = self._wrap(name)
        setattr(self, name, fn)
        return fn

    def _wrap(self, name):
        cfn = getattr(lib, name)
        try:
            ft = ffi.typeof(cfn)
            f = getattr(self._dll, name)
        except (TypeError, AttributeError):
            return cfn
        res = None if ft.result.cname == "void" else _CTYPES.get(ft.result.cname)
        kinds = []
        for a in ft.args:
            if a.kind == "pointer":
                kinds.append(a)
            elif a.cname in _INT_RANGES:
                kinds.append(_INT_RANGES[a.cname])
            else:
                return cfn
        if ft.result.cname != "void" and res is None:
            return cfn
        f.restype = res
        f.argtypes = [ctypes.c_void_p if type(k) is not tuple else _CTYPES[a.cname]
                      for k, a in zip(kinds, ft.args)]
        CData, cast, typeof, nargs = ffi.CData, ffi.cast, ffi.typeof, len(kinds)

        def call(*args):
            if len(args) != nargs:
                return cfn(*args)
            conv = []
            for a, k in zip(args, kinds):
                if type(k) is not tuple:    # a pointer parameter: the same type or an array of its items
                    if not isinstance(a, CData):
                        return cfn(*args)
                    t = typeof(a)
                    if t is not k and not (t.kind == "array" and t.item is k.item):
                        return cfn(*args)
                    conv.append(int(cast("uintptr_t", a)))
                elif type(a) is int and k[0] <= a <= k[1]:
                    conv.append(a)
                else:
                    return cfn(*args)
            return f(*conv)
        call.__name__ = name
        return call


gil_held_lib = GilHeldLib()


__all__ = ["Board", "SciPort", "attach", "current", "ffi", "lib", "fstat_to_hal", "gil_held_lib"]
