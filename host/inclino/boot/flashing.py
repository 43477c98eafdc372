"""Flash-and-verify: `inclino flash --port P IMAGE.s19` (docs/bootloader.md).

`flash(link_or_port, image_path, progress=None)` reads an S-record file
with bincopy, refuses it before anything is erased when a record is bad or
an address lies outside the P-Flash or inside a protected area (the
bootloader, the application descriptor, the probe's data sectors), brings
the probe into its bootloader, erases the sectors the image touches,
programs the image in whole phrases, reads every range back and has the
probe compute its CRC-32, and only then commits the descriptor that makes
the application valid; finally it starts the application.

A power cut or a broken link in the middle never leaves the probe without
something that boots (the bootloader keeps the old application until the
first erase, and runs itself until the commit).  The host says what
happened -- the probe restarted (power lost or reset), the link lost an
exchange, the probe came back in its application or its bootloader -- and
starts the whole flash again once (`attempts`), reporting whether the retry
succeeded.

Exit statuses of the command: 0 flashed and verified; 1 a range failed
verification (nothing committed: the probe stays in its bootloader); 2 bad
image file (DataError); 4 port, link or probe problem (ProbeError).
"""
from __future__ import annotations

import struct
import time
from dataclasses import asdict, dataclass, field
from typing import Callable, Optional

from inclino.errors import DataError, InclinoError
from inclino.link.serial_link import ProbeError, ProbeLink, ProbeNak
from inclino.link.protocol import BOOT_KEY, CMD, ERRORS
from inclino.boot.image import DEFAULT_MAP, NO_ENTRY, FlashMap, Image, check_entry, load_image
from inclino.formats.jsonout import dumps

# ---- the bootloader's commands and codes (boot.h, docs/protocol.md) -------------------
B_IDENTIFY, B_ERASE, B_PROGRAM, B_READ, B_CRC, B_COMMIT, B_RUN = range(0x40, 0x47)
CMD_BOOTLOADER = CMD["BOOTLOADER"]  # the application's commands and codes: protocol.py, one place
CMD_IDENTIFY = CMD["IDENTIFY"]
CMD_STOP = CMD["STOP"]
_CODE = {name: code for code, name in ERRORS.items()}
E_COMMAND, E_ARGUMENT, E_BUSY, E_FLASH, E_IMAGE, E_STATE, E_PROTECTED = (
    _CODE[n] for n in ("E_COMMAND", "E_ARGUMENT", "E_BUSY", "E_FLASH", "E_IMAGE", "E_STATE", "E_PROTECTED"))
APP_STATUS = {0: "valid", 1: "none (no commit record: empty, or a flash did not finish)",
              2: "descriptor header damaged", 3: "descriptor ranges invalid",
              4: "image CRC mismatch", 5: "flash unreadable"}
NO_ANSWER_STATE = ("the probe does not answer; once the link is back it runs its bootloader (or the old "
                   "application if nothing was erased yet): run inclino flash again")


@dataclass
class BootIdentity:
    product: str
    version: tuple
    proto_version: int
    app_status: int
    serial: int
    fmap: FlashMap
    entry: int
    total: int
    hdr_crc: int
    executed: int      # requests the bootloader executed since it started
    mark: int          # the host's mark as it was before this IDENTIFY (0 after a restart)

    FMT = struct.Struct(">16sBBBBIIIHHHIIIIIIIIII")

    @classmethod
    def unpack(cls, data: bytes) -> "BootIdentity":
        if len(data) != cls.FMT.size:
            raise ProbeError(f"bootloader identity of {len(data)} bytes, expected {cls.FMT.size}")
        v = cls.FMT.unpack(data)
        fmap = FlashMap(flash_start=v[6], flash_end=v[7], phrase=v[8], sector=v[9], max_data=v[10],
                        loader=(v[11], v[12]), descriptor=(v[13], v[11]), data=(v[14], v[15]))
        return cls(v[0].rstrip(b"\0").decode("ascii", "replace"), (v[1], v[2]), v[3], v[4], v[5], fmap,
                   v[16], v[17], v[18], v[19], v[20])


# ---- the result ------------------------------------------------------------------------------
@dataclass
class RangeResult:
    addr: int
    length: int
    crc_expected: int
    crc_probe: Optional[int] = None
    readback_ok: Optional[bool] = None

    @property
    def passed(self) -> bool:
        return bool(self.readback_ok) and self.crc_probe == self.crc_expected

    def to_dict(self) -> dict:
        return {"address": f"0x{self.addr:06X}", "length": self.length,
                "crc_expected": f"{self.crc_expected:08X}",
                "crc_probe": None if self.crc_probe is None else f"{self.crc_probe:08X}",
                "readback_ok": self.readback_ok, "passed": self.passed}


@dataclass
class FlashResult:
    ok: bool
    image: str
    port: str
    serial: int = 0
    ranges: list = field(default_factory=list)
    entry: int = NO_ENTRY
    bytes_image: int = 0          # data bytes in the file
    bytes_programmed: int = 0     # data bytes sent in PROGRAM requests (last attempt)
    bytes_on_wire: int = 0        # both directions, all attempts
    sectors_erased: int = 0
    retries: int = 0              # requests the link had to send again
    attempts: int = 0             # whole flashes started
    retry_succeeded: bool = False  # an attempt failed and a later one succeeded
    restarts_detected: int = 0    # the probe restarted during the flash (power lost or reset)
    committed: bool = False
    app_running: bool = False
    events: list = field(default_factory=list)
    duration_s: float = 0.0

    def to_dict(self) -> dict:
        d = asdict(self)
        d["ranges"] = [r.to_dict() for r in self.ranges]
        d["entry"] = None if self.entry == NO_ENTRY else f"0x{self.entry:06X}"
        return d

    def to_json(self) -> str:
        return dumps(self.to_dict())


class _Retry(Exception):
    """An attempt failed in a way a new attempt may fix."""


class _Refused(ProbeError):
    """The bootloader refused an address the host thought allowed: the two
    flash maps disagree; another attempt would not help."""


Progress = Optional[Callable[[str, int, int], None]]


# ---- the flash itself --------------------------------------------------------------------
class _Flasher:
    def __init__(self, link: ProbeLink, image: Image, progress: Progress, result: FlashResult):
        self.link, self.image, self.progress, self.res = link, image, progress, result
        self.mark = 0          # the mark the bootloader holds since our last IDENTIFY
        self.in_bootloader = False   # the bootloader answered: the probe no longer runs its application
        self.asked_bootloader = False  # BOOTLOADER was sent: the probe may be restarting into its bootloader
        self.erase_started = False   # an ERASE was sent: the bootloader invalidates the application first
        self.erase_done = False      # an ERASE was answered: the old application is gone
        self.commit_sent = False     # COMMIT was sent: the new application may be valid from now on
        self.run_sent = False        # RUN was sent: the new application may be starting
        self.restart_seen = False
        self.readback = {}

    def _req(self, cmd: int, payload: bytes = b"", timeout: Optional[float] = None) -> bytes:
        return self.link.request(cmd, payload, timeout=timeout)

    def _long(self, nbytes: int) -> float:
        # a CRC over nbytes: ~400 kB/s on the probe, plus the link's own wait
        return self.link.timeout * 2 + nbytes * 2.5e-6

    def _tick(self, phase: str, done: int, total: int):
        if self.progress is not None:
            self.progress(phase, done, total)

    # ------------------------------------------------------------ state of the probe
    def identify(self) -> BootIdentity:
        """IDENTIFY with a new mark; the answer carries the previous one: a
        probe that restarted since our last IDENTIFY answers 0 (its RAM was
        cleared), not the mark we gave it."""
        new = (self.mark * 1103515245 + 12345 + int(time.monotonic_ns())) & 0xFFFFFFFF or 1
        i = BootIdentity.unpack(self.link.request(B_IDENTIFY, struct.pack(">I", new)))
        self.restart_seen = self.mark != 0 and i.mark != self.mark
        self.mark = new
        return i

    def enter_bootloader(self) -> BootIdentity:
        asked = False
        for _ in range(4):
            try:
                i = self.identify()
            except ProbeNak as e:
                if e.code == E_BUSY:        # the application is streaming surveys: stop it first
                    self.link.request(CMD_STOP)
                    self.res.events.append("the application was streaming surveys: stopped the stream")
                    continue
                if e.code != E_COMMAND or asked:
                    raise
                # the application answered: ask it to start the bootloader
                self.res.events.append("the probe ran its application: asked it to start the bootloader")
                self.asked_bootloader = True
                self.link.request(CMD_BOOTLOADER, struct.pack(">I", BOOT_KEY))
                asked = True
                time.sleep(0.05)
                continue
            if i.product != "INCLINO-BOOT":
                raise ProbeError(f"the device on {self.link.port_name} is not an inclino bootloader "
                                 f"(it says {i.product!r})")
            self.in_bootloader = True
            return i
        raise ProbeError("the probe did not start its bootloader")

    def check_map(self, ident: BootIdentity):
        fm = ident.fmap
        if (fm.phrase, fm.sector) != (DEFAULT_MAP.phrase, DEFAULT_MAP.sector) or fm.max_data < 8:
            raise ProbeError(f"the bootloader reports phrase {fm.phrase}, sector {fm.sector}, "
                             f"{fm.max_data} bytes per request: not an MC9S12XEP100 inclino probe")
        for r in self.image.ranges:
            why = fm.check(r.addr, r.end)
            if why:
                raise DataError(f"{self.image.path}: bytes 0x{r.addr:06X}-0x{r.end - 1:06X} are {why} "
                                "on this probe; nothing was erased")

    # ------------------------------------------------------------ one attempt
    def attempt(self, fmap: FlashMap):
        img, res = self.image, self.res
        sect = fmap.sector
        sectors = sorted({a for r in img.ranges for a in range(r.addr - r.addr % sect, r.end, sect)})
        chunks = []
        step = fmap.max_data - fmap.max_data % fmap.phrase
        for r in img.ranges:
            run = None
            for off in range(0, len(r.data), fmap.phrase):
                ph = r.data[off:off + fmap.phrase]
                if ph == b"\xff" * fmap.phrase:   # erased already: nothing to program
                    run = None
                    continue
                if run is None or len(run[1]) >= step:
                    run = [r.addr + off, bytearray()]
                    chunks.append(run)
                run[1] += ph
        total_prog = sum(len(c[1]) for c in chunks)
        total_verify = sum(len(r.data) for r in img.ranges)
        res.bytes_programmed = 0
        for k, a in enumerate(sectors):
            self.erase_started = True
            self._nak_to_retry(B_ERASE, struct.pack(">I", a), timeout=self.link.timeout + 0.2)
            self.erase_done = True
            self._tick("erase", k + 1, len(sectors))
        res.sectors_erased = len(sectors)
        done = 0
        for addr, data in chunks:
            self._nak_to_retry(B_PROGRAM, struct.pack(">I", addr) + bytes(data))
            done += len(data)
            res.bytes_programmed = done
            self._tick("program", done, total_prog)
        res.ranges = []
        self.readback = {}
        done = 0
        for r in img.ranges:
            rr = RangeResult(r.addr, len(r.data), r.crc)
            back = bytearray()
            for off in range(0, len(r.data), step):
                n = min(step, len(r.data) - off)
                p = self._nak_to_retry(B_READ, struct.pack(">IH", r.addr + off, n))
                if len(p) != 4 + n or struct.unpack(">I", p[:4])[0] != r.addr + off:
                    raise ProbeError(f"READ at 0x{r.addr + off:06X}: malformed answer")
                back += p[4:]
                done += n
                self._tick("verify", done, total_verify)
            rr.readback_ok = bytes(back) == r.data
            p = self._nak_to_retry(B_CRC, struct.pack(">II", r.addr, len(r.data)), timeout=self._long(len(r.data)))
            rr.crc_probe = struct.unpack(">III", p)[2]
            res.ranges.append(rr)
            self.readback[r.addr] = bytes(back)
        bad = [r for r in res.ranges if not r.passed]
        if bad:
            res.events.append("verify failed on " + ", ".join(
                f"0x{r.addr:06X} (+{r.length}: read-back {'ok' if r.readback_ok else 'differs'}, "
                f"CRC {r.crc_probe:08X} expected {r.crc_expected:08X})" for r in bad))
            raise _Retry("verify failed")
        ident = self.identify_after("programming")
        payload = struct.pack(">IB", img.entry, len(img.ranges)) + b"".join(
            struct.pack(">III", r.addr, len(r.data), r.crc) for r in img.ranges)
        self.commit_sent = True
        p = self._nak_to_retry(B_COMMIT, payload, timeout=self._long(total_verify))
        hdr_crc, total = struct.unpack(">II", p)
        ident = self.identify_after("the commit")
        if ident.app_status != 0 or ident.hdr_crc != hdr_crc:
            raise _Retry(f"after the commit the bootloader reports the application "
                         f"{APP_STATUS.get(ident.app_status, ident.app_status)}")
        res.committed = True

    def identify_after(self, what: str) -> BootIdentity:
        try:
            i = self.identify()
        except ProbeNak as e:
            if e.code in (E_COMMAND, E_STATE):
                self.res.restarts_detected += 1
                raise _Retry(f"the application answered after {what}: the probe had restarted") from None
            raise
        if self.restart_seen:
            self.res.restarts_detected += 1
            self.res.events.append(
                f"the probe restarted before {what} was done (power lost or reset); the link's retries "
                f"carried the flash on and " + ("every range read back right" if what == "programming"
                                                 else "the commit was checked"))
        return i

    def _nak_to_retry(self, cmd: int, payload: bytes, timeout: Optional[float] = None) -> bytes:
        try:
            return self._req(cmd, payload, timeout=timeout)
        except ProbeNak as e:
            if e.code in (E_PROTECTED, E_ARGUMENT):   # a map disagreement: not worth another try
                raise _Refused(f"the bootloader refused command 0x{cmd:02X} at "
                                 f"0x{struct.unpack('>I', payload[:4])[0]:06X}: "
                                 f"{'protected area' if e.code == E_PROTECTED else 'bad argument'}") from None
            raise _Retry(f"{_cmd_name(cmd)} refused: {_nak_text(e)}") from None


def _cmd_name(cmd: int) -> str:
    return {B_IDENTIFY: "IDENTIFY", B_ERASE: "ERASE", B_PROGRAM: "PROGRAM", B_READ: "READ", B_CRC: "CRC",
            B_COMMIT: "COMMIT", B_RUN: "RUN"}.get(cmd, f"0x{cmd:02X}")


def _nak_text(e: ProbeNak) -> str:
    names = {E_COMMAND: "unknown command (the application answered)", E_FLASH: "flash command failed",
             E_IMAGE: "the flash does not hold the image", E_STATE: "not possible now (phrase not erased, "
             "or no valid application)", E_PROTECTED: "protected area", E_ARGUMENT: "bad argument"}
    s = names.get(e.code, f"error {e.code}")
    return s + (f" (detail {e.detail})" if e.detail is not None else "")


def _open(link_or_port, baud: int, timeout: float):
    if isinstance(link_or_port, str):
        return ProbeLink(link_or_port, baud=baud, timeout=timeout), True
    return link_or_port, False


def flash(link_or_port, image_path: str, progress: Progress = None, *, attempts: int = 2, run: bool = True,
          baud: int = 115200, timeout: float = 0.5, readback_path: Optional[str] = None) -> FlashResult:
    """Flash IMAGE (S-records) into the probe and verify it.

    link_or_port: a ProbeLink (kept open) or a port name / pyserial URL.
    progress: called as progress(phase, done, total) with phase "erase"
    (sectors), "program" or "verify" (bytes).  attempts: whole flashes
    started at most (a power cut or a broken link in the middle starts the
    flash again).  run: start the application at the end.  readback_path:
    also write what was read back as an S-record file.

    Returns a FlashResult (ok False: a range failed verification in every
    attempt; nothing was committed).  Raises DataError for an image refused
    before anything was erased, ProbeError for a port, link or probe
    problem (its message says what happened and in which state the probe
    was left)."""
    t0 = time.monotonic()
    image = load_image(image_path)
    check_entry(image)
    link, own = _open(link_or_port, baud, timeout)
    res = FlashResult(ok=False, image=image_path, port=link.port_name, entry=image.entry,
                      bytes_image=image.data_bytes)
    bytes0 = link.stats.bytes_out + link.stats.bytes_in
    retries0 = link.stats.retries
    fl = _Flasher(link, image, progress, res)
    try:
        return _flash(fl, link, image, res, attempts, run, readback_path, t0)
    except KeyboardInterrupt:
        raise KeyboardInterrupt(_interrupted_state(fl, res)) from None
    finally:
        res.bytes_on_wire = link.stats.bytes_out + link.stats.bytes_in - bytes0
        res.retries = link.stats.retries - retries0
        if res.retries:
            res.events.append(f"the link sent {res.retries} request(s) again (lost, corrupt or unanswered "
                              "exchanges)")
        res.duration_s = time.monotonic() - t0
        if own:
            link.close()


def _interrupted_state(fl: "_Flasher", res: FlashResult) -> str:
    """What Ctrl-C left on the probe, for `inclino: interrupted: ...`: true
    in every window of the flash (docs/bootloader.md, "Interrupted").  Where
    the host cannot know (a request sent, its answer not yet back), it asks
    the probe once."""
    if res.committed:
        if res.app_running:
            return "the new application is flashed and runs"
        if fl.run_sent:
            return ("the new application is flashed and committed, and was told to start: power-cycle the probe "
                    "if it does not answer")
        return "the new application is flashed and committed; power-cycle the probe to start it"
    if not fl.in_bootloader and not fl.asked_bootloader:
        return "nothing was changed on the probe"
    status, app = _ask_status(fl)
    if app:
        return "nothing was changed on the probe: it runs its application"
    if not fl.erase_started:
        if status is None:
            return ("nothing was erased: the probe was asked to start its bootloader; power-cycle it to start its "
                    "old application, or run inclino flash again")
        return ("nothing was erased: the probe waits in its bootloader with its old application; power-cycle "
                "it to start that, or run inclino flash again")
    if status == 0:
        if fl.commit_sent:
            return ("the new application is flashed and committed (the commit finished as Ctrl-C came); "
                    "power-cycle the probe to start it, or run inclino flash again to check it")
        if not fl.erase_done:
            return ("nothing was erased (the first erase had not run): the probe waits in its bootloader with "
                    "its old application; power-cycle it to start that, or run inclino flash again")
        return ("the bootloader reports a valid application although an erase ran: run inclino flash again "
                "before using the probe")
    if status is None:
        if fl.commit_sent:
            return ("the commit was under way and the probe does not answer: it holds either the new application "
                    "or none; run inclino flash again")
        return ("an erase was under way, so the application is probably erased: the probe stays in its "
                "bootloader until inclino flash is run again")
    return ("the application is erased: the probe stays in its bootloader (no application) until inclino "
            "flash is run again")


def _ask_status(fl: "_Flasher"):
    """(bootloader's application status or None when it does not answer,
    True when the application answered instead): one quick question."""
    old = fl.link.retries
    try:
        fl.link.retries = 0
        return fl.identify().app_status, False
    except ProbeNak as e:
        return None, e.code in (E_COMMAND, E_STATE)
    except (ProbeError, KeyboardInterrupt):
        return None, False
    finally:
        fl.link.retries = old


def _flash(fl, link, image, res, attempts, run, readback_path, t0) -> FlashResult:
    """The flash itself (flash() keeps the accounting and the Ctrl-C report)."""
    ident = fl.enter_bootloader()
    fl.check_map(ident)
    res.serial = ident.serial
    if ident.app_status != 0:
        res.events.append(f"the bootloader runs with no valid application "
                          f"({APP_STATUS.get(ident.app_status, ident.app_status)})")
    last = None
    for k in range(1, max(1, attempts) + 1):
        res.attempts = k
        try:
            fl.attempt(ident.fmap)
            if k > 1:
                res.retry_succeeded = True
                res.events.append(f"attempt {k} succeeded")
            last = None
            break
        except _Refused:
            raise
        except (_Retry, ProbeError) as e:
            last = e
            res.events.append(f"attempt {k} failed: {e}")
            if k == attempts:
                break
            try:
                ident = _recover(fl, res)
            except ProbeError as e2:
                raise ProbeError(f"flash failed in attempt {k}: {e}; then the probe did not answer "
                                 f"({e2}); {NO_ANSWER_STATE}") from None
    if last is not None:
        if str(last) == "verify failed":
            res.duration_s = time.monotonic() - t0
            return res
        state = _state(fl)
        raise ProbeError(f"flash failed after {res.attempts} attempt(s): {last}; {state}")
    if readback_path:
        _write_readback(fl, image, readback_path)
    if run:
        _run(fl, res)
    res.ok = all(r.passed for r in res.ranges) and res.committed
    return res


def _recover(fl: _Flasher, res: FlashResult) -> BootIdentity:
    """After a failed attempt: find the probe again and say what happened."""
    try:
        i = fl.identify()
    except ProbeNak as e:
        if e.code not in (E_COMMAND, E_STATE):
            raise
        res.restarts_detected += 1
        res.events.append("the probe had restarted into its application (the old image was still "
                          "complete): power lost or reset before anything of it was erased")
        return fl.enter_bootloader()
    if fl.restart_seen:
        res.restarts_detected += 1
        res.events.append(f"the probe had restarted (power lost or reset): it runs its bootloader, "
                          f"application {APP_STATUS.get(i.app_status, i.app_status)}")
    else:
        res.events.append("the probe kept running: the link lost the exchange")
    return i


def _state(fl: _Flasher) -> str:
    try:
        i = fl.identify()
    except ProbeNak as e:
        if e.code in (E_COMMAND, E_STATE):
            return "the probe runs its old application"
        return f"the probe answers {_nak_text(e)}"
    except ProbeError:
        return NO_ANSWER_STATE
    if i.app_status == 0:
        return "the probe runs its bootloader with a valid application"
    return "the probe runs its bootloader with no valid application: run inclino flash again"


def _run(fl: _Flasher, res: FlashResult):
    fl.run_sent = True
    fl.link.request(B_RUN)
    deadline = time.monotonic() + max(2.0, fl.link.timeout * 4)
    while time.monotonic() < deadline:
        try:
            p = fl.link.request(CMD_IDENTIFY)
        except ProbeNak:
            time.sleep(0.05)
            continue
        res.app_running = p[:16].rstrip(b"\0").decode("ascii", "replace") == "INCLINO-PROBE"
        res.events.append("the application runs" if res.app_running else "an unknown application answered")
        return
    res.events.append("the application did not answer after RUN")


def _write_readback(fl: _Flasher, image: Image, path: str):
    import bincopy

    bf = bincopy.BinFile()
    for r in image.ranges:
        bf.add_binary(fl.readback.get(r.addr, b""), address=r.addr)
    if image.entry != NO_ENTRY:
        bf.execution_start_address = image.entry
    from inclino.formats import safeio

    safeio.write_output(path, bf.as_srec(number_of_data_bytes=32, address_length_bits=24), [image.path])




__all__ = ["flash", "load_image", "FlashResult", "RangeResult", "FlashMap", "BootIdentity",
           "InclinoError"]
