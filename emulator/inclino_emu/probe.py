"""The emulated probe: a scenario's world and sensor truth, the register
models of the ADIS16210 and the ADS1256, the MC9S12XEP100 flash, the SCI
byte queues, and the firmware application (firmware/src through the cffi
module inclino_emu._fw) running on them.

    p = EmulatedProbe("ideal")           # boots: probe_init()
    p.move_to(30, 45, 10)
    s = p.survey()                       # probe_survey() through the real C
    p.cut_power_at(5)                    # the 5th flash program/erase loses power
    p.cal_write(image)                   # ... the firmware restarts after the cut
    p.sci_push(b"...")                   # host -> probe bytes (hal_sci_getc)
    p.step(0.01)                         # run 10 ms of emulated time
    p.sci_pull()                         # probe -> host bytes (hal_sci_putc)

The bootloader (firmware/src/boot*.c, docs/bootloader.md) decides at every
boot, as on the probe: `boot()` asks `boot_select()` whether the application
image in flash is valid (and whether BOOTLOADER was answered); if so the
application runs (`app_main_init`, `mode == "app"`), else the bootloader
(`boot_main_init`, `mode == "boot"`, and step() calls `boot_main_poll`
instead of `poll`).  What is emulated: the application that runs is the host
build of firmware/src; the application *image* in flash is data whose
descriptor and CRCs the bootloader checks.  A fresh probe gets the factory's
bootloader area (placeholder bytes, protected like FPROT does on the part)
and a small factory application image (`factory_app=False`: none, so it
boots into the bootloader).

The firmware's C state is global in the extension module, so one
EmulatedProbe owns the firmware at a time: creating another takes it over
and the older object refuses further firmware calls.  Everything is
deterministic: the scenario seed drives the sensor noise, `flash_seed` the
partial effects of power cuts.
"""
from __future__ import annotations

from dataclasses import dataclass
from typing import Callable, Optional

from .adis16210 import ADIS16210, AdisFaults
from .ads1256 import ADS1256, FluxgateFrontEnd
from .clock import Clock
from .flash import S12XFlash
from .hal import Board, SciPort, attach, ffi, gil_held_lib, lib
from inclino.model.scenario import Scenario, load_scenario

# probe.h
PROBE_ID_ADDR = 0x7A0000
PROBE_CAL_A_ADDR = 0x7A0400
PROBE_CAL_B_ADDR = 0x7A0800
PROBE_QC_A_ADDR = 0x7A0C00
PROBE_QC_B_ADDR = 0x7A1000
PROBE_SLOT_A, PROBE_SLOT_B, PROBE_SLOT_ACTIVE, PROBE_SLOT_NONE = 0, 1, 2, 0xFF
PROBE_QC_NO_REF = 0x80
CALIMG_SIZE = 192  # calimg.h: the largest image (version 2); version 1 is 120 bytes
CALIMG_SIZES = (120, 192)
# boot.h (docs/bootloader.md)
BOOT_LOADER_START, BOOT_LOADER_END = 0x7FF000, 0x800000
BOOT_DESC_ADDR = 0x7FEC00
BOOT_COMMIT_OFFSET = 0x3F8
BOOT_SEL_APP, BOOT_SEL_LOADER = 0, 1
FACTORY_APP_ADDR = 0x7C0000
FACTORY_APP_SIZE = 2048


def factory_app_image() -> bytes:
    """The factory application image (stands for the application's code)."""
    text = b"INCLINO-PROBE application image (emulated: the host build of firmware/src runs)\0"
    return (text + bytes((i * 37 + 11) & 0xFF for i in range(FACTORY_APP_SIZE)))[:FACTORY_APP_SIZE]


def bootloader_placeholder() -> bytes:
    """Bytes standing for the bootloader's code in its protected 4 KiB."""
    text = b"INCLINO-BOOT 1.0 (emulated: the host build of firmware/src/boot*.c runs)\0"
    n = BOOT_LOADER_END - BOOT_LOADER_START
    return (text + bytes((i * 101 + 7) & 0xFF for i in range(n)))[:n]

_owner = None


@dataclass
class CallResult:
    status: int
    power_cut: bool = False   # the flash lost power during the call; the firmware restarted
    boot_status: Optional[int] = None


class EmulatedProbe:
    """An emulated probe.  scenario: a Scenario or a built-in name / TOML
    path; seed overrides the scenario's; serial overrides the probe serial
    written in the flash identity record (factory data; default: the
    scenario's serial, None in the record when `serial=0` is given: no
    record); adis_faults / adc_absent inject part faults; baud None runs the
    SCI unthrottled; flash: an S12XFlash to reuse (e.g. after a test built
    it), else a fresh erased one."""

    def __init__(self, scenario="ideal", seed: Optional[int] = None, serial: Optional[int] = None,
                 adis_faults: Optional[AdisFaults] = None, adc_absent: bool = False,
                 baud: Optional[float] = None, flash: Optional[S12XFlash] = None, flash_seed: int = 0,
                 strict_stall: bool = False, boot: bool = True, off_time_s: float = 0.5,
                 factory_app: bool = True):
        global _owner
        self.scenario: Scenario = scenario if isinstance(scenario, Scenario) else load_scenario(scenario)
        self.clock = Clock()
        self.phys = self.scenario.probe(seed)
        self.adis = ADIS16210(self.clock, self.phys.acc_sample, self.phys.temperature,
                              serial=self.scenario.serial, faults=adis_faults, strict_stall=strict_stall)
        self.front = FluxgateFrontEnd(self.phys.mag_sample)
        self.adc = ADS1256(self.clock, self.front, absent=adc_absent)
        self.flash = flash if flash is not None else S12XFlash(seed=flash_seed)
        self.sci = SciPort(self.clock, baud)
        self.board = Board(self.clock, self.adis, self.adc, self.flash, self.sci)
        self.off_time_s = off_time_s
        self.poll: Optional[Callable[[], object]] = None   # firmware main-loop body for step()
        self.ffi, self.lib = ffi, lib
        self.power_cuts = 0
        self.restarts = 0
        self.boot_status: Optional[int] = None
        self.mode = "app"          # "app" or "boot": what boot() started
        _owner = self
        attach(self.board)
        serial = self.scenario.serial if serial is None else serial
        if serial and all(b == 0xFF for b in self.flash.peek(PROBE_ID_ADDR, 16)):
            self.factory_program(serial)
        self.factory_bootloader(factory_app)
        if boot:
            self.boot()

    # ---- ownership and calls -----------------------------------------------
    def _own(self):
        if _owner is not self:
            raise RuntimeError("another EmulatedProbe owns the firmware now")
        attach(self.board)

    def _check(self):
        err, self.board.error = self.board.error, None
        if err is not None:
            raise err

    def call(self, name: str, *args) -> CallResult:
        """Call firmware function `name`; if the flash lost power during it,
        restart the firmware (power off `off_time_s`, then boot)."""
        self._own()
        r = getattr(gil_held_lib, name)(*args)   # lib's function, the GIL kept (hal.GilHeldLib)
        self._check()
        res = CallResult(int(r) if r is not None else 0)
        if not self.flash.powered:
            self.power_cuts += 1
            res.power_cut = True
            res.boot_status = self.power_cycle()
        return res

    # ---- power -----------------------------------------------------------------
    def factory_program(self, serial: int, hw_rev: int = 1):
        """Write the identity record (what the factory programmer does)."""
        self._own()
        buf = ffi.new("uint8_t[16]")
        lib.probe_id_build(serial & 0xFFFFFFFF, hw_rev, buf)
        self.flash.load(PROBE_ID_ADDR, bytes(buf))

    def factory_bootloader(self, app: bool = True):
        """What the factory programmer leaves on a fresh part: the bootloader
        area (placeholder bytes; protected, as its FPROT setting does on the
        probe) and, with `app`, the factory application image and its
        descriptor.  Areas that are not blank are left as they are."""
        self._own()
        if (BOOT_LOADER_START, BOOT_LOADER_END) not in self.flash.protected:
            self.flash.protected.append((BOOT_LOADER_START, BOOT_LOADER_END))
        n = BOOT_LOADER_END - BOOT_LOADER_START
        if self.flash.peek(BOOT_LOADER_START, n) == b"\xff" * n:
            self.flash.load(BOOT_LOADER_START, bootloader_placeholder())
        if not app or self.flash.peek(BOOT_DESC_ADDR, 1024) != b"\xff" * 1024 or \
                self.flash.peek(FACTORY_APP_ADDR, FACTORY_APP_SIZE) != b"\xff" * FACTORY_APP_SIZE:
            return
        img = factory_app_image()
        a = ffi.new("boot_app_t *")
        a.entry, a.count = FACTORY_APP_ADDR, 1
        a.range[0].addr, a.range[0].len = FACTORY_APP_ADDR, len(img)
        a.range[0].crc = lib.crc32_update(0, img, len(img))
        hdr, commit = ffi.new("uint8_t[120]"), ffi.new("uint8_t[8]")
        n_hdr = lib.boot_desc_build(a, hdr, commit)
        self.flash.load(FACTORY_APP_ADDR, img)
        self.flash.load(BOOT_DESC_ADDR, bytes(hdr)[:n_hdr])
        self.flash.load(BOOT_DESC_ADDR + BOOT_COMMIT_OFFSET, bytes(commit))

    def boot(self, bootloader: bool = False) -> int:
        """Run the firmware's reset path on the present state: the
        bootloader's choice (boot_select), then the application's start
        (hal_init, probe_init, protocol reset: app_main_init) or the
        bootloader's (boot_main_init).  `bootloader`: the application asked
        for it (BOOTLOADER answered).  Returns the started one's status."""
        self._own()
        self.board.selected = None
        sel = int(lib.boot_select(1 if bootloader else 0))
        self._check()
        if sel == BOOT_SEL_APP:
            self.mode = "app"
            self.boot_status = int(lib.app_main_init())
        else:
            self.mode = "boot"
            self.boot_status = int(lib.boot_main_init())
        self._check()
        return self.boot_status

    def power_cycle(self) -> int:
        """Power off for off_time_s, then on: the parts restart, the SCI
        queues empty, the flash keeps its cells, the firmware boots."""
        self._own()
        self.flash.restore_power()
        self.clock.advance(self.off_time_s)
        self.adis.power_on()
        self.adc.reset()
        self.sci.reset()
        return self.boot()

    def cut_power_at(self, n: int, mode: str = "random"):
        """Lose power during the n-th flash program or erase from now
        (applied partly per `mode`, see S12XFlash); the firmware restarts
        when the interrupted call returns."""
        self.flash.cut_power_at(n, mode)

    # ---- world ----------------------------------------------------------------
    def move_to(self, inc: float, azi: float, tf: float):
        self.phys.move_to(inc, azi, tf)

    def set_temperature(self, temp_c: Optional[float]):
        self.phys.set_temperature(temp_c)

    def truth(self):
        """(g (3,), b (3,)) true body-frame readings now."""
        return self.phys.true_acc(self.clock.now), self.phys.true_mag(self.clock.now)

    # ---- time and SCI ----------------------------------------------------------
    def step(self, dt: float, quantum: float = 1e-3):
        """Run dt seconds of emulated time: call `poll` (the firmware's
        main-loop body, if set; boot_main_poll instead while the bootloader
        runs) repeatedly; between calls the clock jumps to
        the next SCI event or by `quantum`, whichever is sooner."""
        self._own()
        t_end = self.clock.now + dt
        while self.clock.now < t_end:
            t0 = self.clock.now
            if self.poll is not None:
                if self.mode == "boot":  # the bootloader runs its own loop
                    lib.boot_main_poll()
                    self._check()
                    req = int(lib.boot_main_restart_requested())
                else:
                    self.poll()
                    self._check()
                    req = int(lib.app_main_restart_requested())
                if req:
                    self.restarts += 1
                    # RESET / RUN / BOOTLOADER answered: the firmware restarts (2 from
                    # the application: BOOTLOADER, stay in the bootloader)
                    self.boot(bootloader=(self.mode == "app" and req == 2))
                if not self.flash.powered:
                    self.power_cuts += 1
                    self.power_cycle()
            if self.clock.now == t0:
                if self.poll is None:
                    self.clock.advance_to(t_end)
                    break
                nxt = min(t_end, t0 + quantum)
                ne = self.sci.next_event()
                if t0 < ne < nxt:
                    nxt = ne
                self.clock.advance_to(nxt)

    def sci_push(self, data: bytes):
        self.sci.push(data)

    def sci_pull(self, max_bytes: Optional[int] = None) -> bytes:
        return self.sci.pull(max_bytes)

    # ---- firmware API conveniences ----------------------------------------------
    def set_average(self, n: int) -> int:
        return self.call("probe_set_average", n).status

    def survey(self) -> dict:
        """probe_survey: status, qc flags, corrected vectors, angles (degrees)
        and the raw readings used (acc, mag: the means in Q6 counts, 64 per
        count, as survey_compute takes them)."""
        self._own()
        s = ffi.new("survey_t *")
        q = ffi.new("uint8_t *")
        st = self.call("probe_survey", s, q).status
        raw = self.last_raw()
        a = s.att
        return {"status": st, "qc": int(q[0]), "g": list(s.g), "b": list(s.b),
                "inc": a.inc / 65536.0, "azi": a.azi / 65536.0, "gtf": a.gtf / 65536.0,
                "mtf": a.mtf / 65536.0, "dip": a.dip / 65536.0, "gt": a.gt / 2.0**27,
                "bt": a.bt / 256.0, "flags": int(a.flags), "att_raw": {k: int(getattr(a, k)) for k in (
                    "inc", "azi", "gtf", "mtf", "gt", "bt", "dip", "flags")}, "raw": raw}

    def raw(self) -> dict:
        r = ffi.new("probe_raw_t *")
        st = self.call("probe_raw", r).status
        return {"status": st, "acc": list(r.acc), "mag": list(r.mag), "temp_c": r.temp_cc / 100.0,
                "n": int(r.n), "temp_q6": int(r.temp_q6)}

    def last_raw(self) -> dict:
        self._own()
        r = ffi.new("probe_raw_t *")
        lib.probe_last_raw(r)
        return {"acc": list(r.acc), "mag": list(r.mag), "temp_c": r.temp_cc / 100.0, "n": int(r.n),
                "temp_q6": int(r.temp_q6)}

    def identity(self) -> dict:
        self._own()
        i = ffi.new("probe_identity_t *")
        lib.probe_identity(i)
        slot = {PROBE_SLOT_A: "A", PROBE_SLOT_B: "B"}.get(i.cal_slot, "none")
        qslot = {PROBE_SLOT_A: "A", PROBE_SLOT_B: "B"}.get(i.qc_slot, "none")
        return {"product": i.product, "fw_version": i.fw_version, "serial": i.serial, "hw_rev": i.hw_rev,
                "adis_status": i.adis_status, "ads_status": i.ads_status, "adis_prod_id": i.adis_prod_id,
                "cal_slot": slot, "cal_seq": i.cal_seq, "cal_crc": i.cal_crc, "cal_serial": i.cal_serial,
                "cal_time": i.cal_time, "cal_method": i.cal_method, "qc_slot": qslot}

    def active_cal(self):
        self._own()
        c = ffi.new("corr_cal_t *")
        lib.probe_active_cal(c)
        return (list(c.acc.m), list(c.acc.bias), list(c.mag.m), list(c.mag.bias))

    def active_temp(self):
        """The active calibration's temperature terms: (t_order, t_ref Q7,
        then c1, c2, r1, r2 of acc and of mag as lists); order 0 and zeros
        for an image without them (version 1)."""
        self._own()
        c = ffi.new("corr_cal_t *")
        lib.probe_active_cal(c)
        return (int(c.t_order), int(c.t_ref)) + tuple(
            list(getattr(tc, k)) for tc in (c.acc_tc, c.mag_tc) for k in ("c1", "c2", "r1", "r2"))

    def cal_write(self, image: bytes, force: bool = False) -> CallResult:
        if len(image) not in CALIMG_SIZES:
            raise ValueError("a calibration image is 120 (version 1) or 192 bytes (version 2)")
        buf = ffi.new(f"uint8_t[{CALIMG_SIZE}]", bytes(image))
        return self.call("probe_cal_write", buf, 1 if force else 0)

    def cal_activate(self) -> CallResult:
        return self.call("probe_cal_activate")

    def cal_read(self, slot="active"):
        """(status, bytes) of slot "A", "B" or "active"."""
        sel = {"A": PROBE_SLOT_A, "B": PROBE_SLOT_B, "active": PROBE_SLOT_ACTIVE}[slot]
        buf = ffi.new(f"uint8_t[{CALIMG_SIZE}]")
        st = self.call("probe_cal_read", sel, buf).status
        n = int(lib.calimg_length(buf))  # the image's own length; all bytes when it has none
        return st, bytes(buf)[:n or CALIMG_SIZE]

    def qc_set(self, gt_ref, gt_tol, bt_ref, bt_tol, dip_ref, dip_tol) -> CallResult:
        r = ffi.new("qc_ref_t *", (gt_ref, gt_tol, bt_ref, bt_tol, dip_ref, dip_tol))
        return self.call("probe_qc_set", r)

    def qc_get(self):
        r = ffi.new("qc_ref_t *")
        st = self.call("probe_qc_get", r).status
        return st, (r.gt_ref, r.gt_tol, r.bt_ref, r.bt_tol, r.dip_ref, r.dip_tol)


__all__ = ["EmulatedProbe", "CallResult", "factory_app_image", "bootloader_placeholder", "PROBE_ID_ADDR", "PROBE_CAL_A_ADDR", "PROBE_CAL_B_ADDR",
           "PROBE_QC_A_ADDR", "PROBE_QC_B_ADDR"]
