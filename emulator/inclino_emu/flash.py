"""The MC9S12XEP100 P-Flash as the firmware's flash HAL sees it, with
power-cut injection.

Semantics (S12XFTM1024K5 chapter of the MC9S12XE reference manual, its
Program P-Flash / Erase P-Flash Sector error tables; docs/flash.md):

* global addresses 0x700000..0x7FFFFF (1 MiB), erased cells read 0xFF;
* Program P-Flash writes one aligned 8-byte phrase (4 words);
  Erase P-Flash Sector erases 1024 bytes;
* ACCERR (nothing changes): an address outside the P-Flash, a phrase
  address with bits [2:0] != 000;
* FPVIOL (nothing changes): a target inside a protected range;
* programming can only take bits from 1 to 0, and each phrase carries ECC
  bits programmed with it.  The command does not check that the phrase is
  erased: on a non-erased phrase whose content differs from the new data the
  cells end up holding old AND new and the verify that ends the command
  fails: MGSTAT1 | MGSTAT0 (cumulative programming is not allowed; NXP: the
  ECC is damaged).  Programming exactly the data already there changes
  nothing and passes (same data, same ECC) -- a model choice.

Power cuts: `cut_power_at(n)` arms a cut at the n-th program or erase
command from now (n = 1: the next one).  That command is applied partly
(mode "random": each bit it would change changes with a probability drawn
per cut; "none": not at all; "full": completely), then the flash is
unpowered: every later command and read fails (`None`) until
`restore_power()`.  Everything is seeded: the same seed and the same
commands give the same cells.
"""
from __future__ import annotations

import random
from dataclasses import dataclass, field

PFLASH_START = 0x700000
PFLASH_END = 0x800000          # exclusive
PHRASE = 8
SECTOR = 1024
ERASED = 0xFF

# FSTAT error bits (MC9S12XE FTM)
ACCERR = 0x20
FPVIOL = 0x10
MGSTAT1 = 0x02
MGSTAT0 = 0x01

CUT_MODES = ("random", "none", "full")


@dataclass
class FlashTiming:
    """Command durations charged to the emulator clock (seconds).  Model
    choices of the order of the FTM's typical figures (not checked)."""
    program_s: float = 150e-6
    erase_s: float = 20e-3


@dataclass
class FlashOp:
    kind: str        # "program" or "erase"
    addr: int
    status: int      # FSTAT error bits, or -1 when cut
    cut: bool = False


class S12XFlash:
    """P-Flash cells plus the command interface's error behaviour."""

    def __init__(self, seed: int = 0, protected=(), timing: FlashTiming = None):
        self.mem = bytearray([ERASED]) * (PFLASH_END - PFLASH_START)
        self.protected = [tuple(r) for r in protected]   # [(start, end_exclusive)]
        self.timing = timing or FlashTiming()
        self.rng = random.Random(seed)
        self.ops = 0                 # program + erase commands launched since creation
        self.history: list[FlashOp] = []
        self.powered = True
        self.cuts = 0
        self._cut_in = None          # commands left before the cut (1 = next)
        self._cut_mode = "random"

    # ---- helpers -------------------------------------------------------
    @staticmethod
    def in_range(addr: int, n: int = 1) -> bool:
        return PFLASH_START <= addr and addr + n <= PFLASH_END and n >= 0

    def _protected(self, start: int, end: int) -> bool:
        return any(s < end and start < e for s, e in self.protected)

    def _count(self):
        """Count a launched command; True when it is the one that loses power."""
        self.ops += 1
        if self._cut_in is None:
            return False
        self._cut_in -= 1
        if self._cut_in > 0:
            return False
        self._cut_in = None
        return True

    def _lose_power(self):
        self.powered = False
        self.cuts += 1

    # ---- power ---------------------------------------------------------
    def cut_power_at(self, n: int, mode: str = "random"):
        """Arm a power cut at the n-th program/erase command from now."""
        if n < 1:
            raise ValueError("n counts commands from 1")
        if mode not in CUT_MODES:
            raise ValueError(f"mode must be one of {CUT_MODES}")
        self._cut_in = int(n)
        self._cut_mode = mode

    def disarm(self):
        self._cut_in = None

    @property
    def armed(self) -> bool:
        return self._cut_in is not None

    def restore_power(self):
        self.powered = True

    # ---- access --------------------------------------------------------
    def read(self, addr: int, n: int):
        """n bytes at global address addr; None when unpowered or outside."""
        if not self.powered or not self.in_range(addr, n):
            return None
        o = addr - PFLASH_START
        return bytes(self.mem[o:o + n])

    def peek(self, addr: int, n: int) -> bytes:
        """Read regardless of power (tests, tools)."""
        o = addr - PFLASH_START
        return bytes(self.mem[o:o + n])

    def load(self, addr: int, data: bytes):
        """Write cells directly (a programmer's image load: factory data)."""
        if not self.in_range(addr, len(data)):
            raise ValueError("outside the P-Flash")
        o = addr - PFLASH_START
        self.mem[o:o + len(data)] = data

    def program(self, addr: int, data: bytes):
        """Program P-Flash: one phrase.  Returns the FSTAT error bits (0 =
        success) or None when the flash is unpowered."""
        if not self.powered:
            return None
        data = bytes(data)
        if len(data) != PHRASE:
            raise ValueError("a phrase is 8 bytes")
        cut = self._count()
        if not self.in_range(addr, PHRASE) or addr % PHRASE:
            st = ACCERR
        elif self._protected(addr, addr + PHRASE):
            st = FPVIOL
        else:
            o = addr - PFLASH_START
            old = bytes(self.mem[o:o + PHRASE])
            target = bytes(a & b for a, b in zip(old, data))
            if cut:
                target = self._partial(old, target)
            self.mem[o:o + PHRASE] = target
            erased = all(b == ERASED for b in old)
            st = 0 if (erased or old == data) else (MGSTAT1 | MGSTAT0)
        self.history.append(FlashOp("program", addr, -1 if cut else st, cut))
        if cut:
            self._lose_power()
            return None
        return st

    def erase(self, addr: int):
        """Erase P-Flash Sector: the 1024-byte sector holding addr.  Returns
        the FSTAT error bits or None when unpowered."""
        if not self.powered:
            return None
        cut = self._count()
        if not self.in_range(addr) or addr % PHRASE:
            st = ACCERR
        else:
            start = addr - addr % SECTOR
            if self._protected(start, start + SECTOR):
                st = FPVIOL
            else:
                o = start - PFLASH_START
                old = bytes(self.mem[o:o + SECTOR])
                target = bytes([ERASED]) * SECTOR
                if cut:
                    target = self._partial(old, target)
                self.mem[o:o + SECTOR] = target
                st = 0
        self.history.append(FlashOp("erase", addr, -1 if cut else st, cut))
        if cut:
            self._lose_power()
            return None
        return st

    def _partial(self, old: bytes, target: bytes) -> bytes:
        """What an interrupted command leaves: per mode, each bit that the
        command changes (old -> target) changes or not."""
        mode = self._cut_mode
        if mode == "none":
            return old
        if mode == "full":
            return target
        p = self.rng.random()
        out = bytearray(old)
        for i, (a, b) in enumerate(zip(old, target)):
            diff = a ^ b
            if diff:
                m = 0
                for bit in range(8):
                    if diff >> bit & 1 and self.rng.random() < p:
                        m |= 1 << bit
                out[i] = a ^ m
        return bytes(out)
