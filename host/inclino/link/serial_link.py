"""The host end of the probe's serial link (docs/protocol.md), over pyserial.

`ProbeLink(port)` accepts any pyserial port name or URL.  Every request is
retried with the same sequence number when its answer is lost, corrupt or a
CRC refusal, so the probe (which keeps its last answer) never executes a
command twice; what happened is counted in `link.stats`.

The port (docs/cli.md, "The port"):

* A local serial device is opened exclusively (pyserial's `exclusive=True`,
  an advisory lock every inclino command takes): a second command on the
  same port is refused with "port ... is busy", never shares it.
* A terminal that is the controlling terminal of a running session (a
  shell's window) is refused before a byte is written to it.
* A device that never answers with a valid frame gets its terminal settings
  back (those it had before the port was opened) when the link closes.
* An answer with a valid CRC but a payload of the wrong length for its
  command is a link error naming the command and the length (exit 4).
* When nothing answers, the error names any other process that holds the
  port open (it may be taking the answers).
"""
from __future__ import annotations

import math
import os
import struct
import time
from dataclasses import dataclass, field

from inclino.link import protocol
from inclino.errors import DataError, InclinoError
from inclino.link.protocol import CMD, ERRORS, NAK, STREAM_FRAME, Event, FrameParser


class ProbeError(InclinoError):
    """The port, the link or the probe failed (exit status 4)."""

    exit_code = 4


class ProbeNak(ProbeError):
    """The probe answered with a negative answer."""

    def __init__(self, cmd: int, code: int, detail: int | None = None):
        self.cmd, self.code, self.detail = cmd, code, detail
        name = ERRORS.get(code, f"error {code}")
        cname = next((k for k, v in CMD.items() if v == cmd), f"0x{cmd:02X}")
        extra = f" (detail {detail})" if detail is not None else ""
        super().__init__(f"probe refused {cname}: {name}{extra}")


E_STATE = 11
B_IDENTIFY = 0x40
BOOT_APP_STATUS = {0: "a valid application", 1: "no application (erased: a flash did not finish)",
                   2: "no application (its descriptor is damaged)", 3: "no application (its descriptor is damaged)",
                   4: "no application (its image is damaged)", 5: "no application (the flash is unreadable)"}
BAUD_RANGE = (300, 2_500_000)     # what the S12X's SCI makes at a 40 MHz bus
TIMEOUT_RANGE = (0.001, 3600.0)   # seconds


class ProbeInBootloader(ProbeNak):
    """The probe runs its bootloader, not the application: an application
    command cannot work.  A ProbeNak (E_STATE) so that callers that retry
    on negative answers keep working; its text says what to do."""

    def __init__(self, cmd: int, port: str, app_status: int):
        self.cmd, self.code, self.detail, self.app_status = cmd, E_STATE, None, app_status
        what = BOOT_APP_STATUS.get(app_status, f"application status {app_status}")
        if app_status == 0:
            todo = ("power-cycle the probe to start its application, or run `inclino flash` to "
                    "finish a firmware update")
        else:
            todo = f"run `inclino flash --port {port} IMAGE.s19` (again) to install the application"
        InclinoError.__init__(self, f"the probe on {port} is in its bootloader with {what}: {todo}")


def check_link_options(baud, timeout) -> None:
    """The rules for --baud and --timeout of every command that opens the
    link (DataError, exit 2)."""
    if isinstance(baud, bool) or not isinstance(baud, int) or not BAUD_RANGE[0] <= baud <= BAUD_RANGE[1]:
        raise DataError(f"--baud {baud}: a baud rate within {BAUD_RANGE[0]}-{BAUD_RANGE[1]}")
    try:
        t = float(timeout)
    except (TypeError, ValueError):
        raise DataError(f"--timeout {timeout}: not a number") from None
    if not (math.isfinite(t) and TIMEOUT_RANGE[0] <= t <= TIMEOUT_RANGE[1]):
        raise DataError(f"--timeout {timeout}: seconds within {TIMEOUT_RANGE[0]:g}-{TIMEOUT_RANGE[1]:g}")


@dataclass
class LinkStats:
    requests: int = 0
    retries: int = 0
    timeouts: int = 0
    bad_frames: int = 0
    stale_answers: int = 0
    naks: int = 0
    bytes_out: int = 0
    bytes_in: int = 0
    log: list = field(default_factory=list)


# lines the probe's own text console sends (docs/protocol.md, "Text console"): a
# request whose frame start (0xA5) the line lost reaches it as text and is
# answered with one of these -- the probe is there, the link loses bytes
PROBE_CONSOLE_LINES = ("? HELP lists the commands", "? bootloader:", "INCLINO-", "BUSY: streaming",
                       "ID identify  SV survey")


def _gone(e: Exception) -> str:
    """pyserial's words for a device that went away mid-command, in the
    bench's: which device and what to do."""
    text = str(e)
    if "returned no data" in text or getattr(e, "errno", None) == 5 or "Errno 5]" in text:
        return ("the device went away (a USB adapter unplugged, the probe's converter unpowered, or the "
                "emulator stopped); plug it back or restart it, then run the command again")
    return text


def _is_probe_console(line: str) -> bool:
    return line.startswith(PROBE_CONSOLE_LINES)


FLASH_EXTRA_S = 0.5  # flash commands may take this much longer than other answers


class ProbeLink:
    def __init__(self, port: str, baud: int = 115200, timeout: float = 0.5, retries: int = 4):
        import serial  # pyserial

        check_link_options(baud, timeout)
        self.port_name = port
        self.timeout = timeout
        self.retries = retries
        self.stats = LinkStats()
        self._seq = int(time.monotonic_ns() // 1000) & 0xFF
        self._parser = FrameParser()
        self._pending: list[Event] = []
        self.detect_bootloader = True   # an application command refused E_STATE: ask the bootloader
        self._saved_tty = None    # the device's terminal settings before the link changed them
        self._answered = False    # a valid frame came back: the device speaks the protocol
        self._lines: list[str] = []  # text the device sent outside frames (the last few lines)
        local = isinstance(port, str) and "://" not in port
        if local:
            self._saved_tty = _check_terminal(port)
        try:
            self._ser = serial.serial_for_url(port, baudrate=baud, timeout=0.01, write_timeout=2.0,
                                              **({"exclusive": True} if local and os.name == "posix" else {}))
        except (serial.SerialException, ValueError, OSError) as e:
            text = str(e)
            if "exclusively lock" in text:
                raise ProbeError(f"port {port} is busy: another program has it open and locked "
                                 f"(another inclino command?){_holders_text(port)}") from None
            raise ProbeError(f"cannot open port {port}: {e}") from None

    # ----------------------------------------------------------- plumbing
    def close(self) -> None:
        if self._saved_tty is not None and not self._answered:  # not a probe: its settings back
            try:
                import termios

                termios.tcsetattr(self._ser.fd, termios.TCSANOW, self._saved_tty)
            except Exception:  # pragma: no cover - a device that went away
                pass
        try:
            self._ser.close()
        except Exception:  # pragma: no cover - closing a dead port
            pass

    def __enter__(self):
        return self

    def __exit__(self, *exc):
        self.close()

    def _write(self, data: bytes) -> None:
        import serial

        try:
            self._ser.write(data)
            self._ser.flush()
        except (serial.SerialException, OSError) as e:
            raise ProbeError(f"port {self.port_name} failed while writing: {_gone(e)}") from None
        self.stats.bytes_out += len(data)

    def _events(self, deadline: float) -> Event | None:
        """Next parser event before the deadline, or None."""
        import serial

        last_rx = time.monotonic()
        while True:
            if self._pending:
                return self._pending.pop(0)
            now = time.monotonic()
            if now >= deadline:
                return None
            try:
                data = self._ser.read(max(1, min(4096, self._ser.in_waiting or 1)))
            except (serial.SerialException, OSError) as e:
                raise ProbeError(f"port {self.port_name} failed while reading: {_gone(e)}") from None
            if data:
                last_rx = now
                self.stats.bytes_in += len(data)
                for ev in self._parser.feed(data):
                    if ev.kind == "frame" and ev.frame.cmd >= STREAM_FRAME:  # a probe's frame, not a request's echo
                        self._answered = True
                    elif ev.kind == "line":
                        self._lines = (self._lines + [ev.line])[-3:]
                    self._pending.append(ev)
            elif self._parser.in_frame and now - last_rx > 0.02:
                self._parser.idle()

    def next_seq(self) -> int:
        self._seq = (self._seq + 1) & 0xFF
        return self._seq

    # ----------------------------------------------------------- requests
    def request(self, cmd: str | int, payload: bytes = b"", timeout: float | None = None,
                expect=None) -> bytes:
        """Send a request and return the answer's payload; retry lost or
        corrupt exchanges with the same sequence number.  expect: the
        answer's payload lengths this command allows (a set, or a (min,
        max) range; default protocol.ANSWER_SIZES for a named command): any
        other is a ProbeError naming the command and the length."""
        code = CMD[cmd] if isinstance(cmd, str) else cmd
        if expect is None and isinstance(cmd, str):
            expect = protocol.ANSWER_SIZES.get(cmd)
        seq = self.next_seq()
        frame = protocol.encode_frame(seq, code, payload)
        self.stats.requests += 1
        wait = self.timeout if timeout is None else timeout
        in0, bad0, hit0, echoed = self.stats.bytes_in, self.stats.bad_frames, 0, 0
        for attempt in range(self.retries + 1):
            if attempt:
                self.stats.retries += 1
            self._write(frame)
            deadline = time.monotonic() + wait
            while True:
                ev = self._events(deadline)
                if ev is None:
                    self.stats.timeouts += 1
                    self.stats.log.append(f"timeout on seq {seq} (try {attempt + 1})")
                    break
                if ev.kind != "frame":
                    if ev.kind in ("bad_crc", "bad_len"):
                        self.stats.bad_frames += 1
                        self.stats.log.append(f"corrupt answer on seq {seq}")
                    continue
                f = ev.frame
                if f.cmd == code and f.seq == seq and f.payload == payload:   # our own request came back
                    echoed += 1
                    continue
                if f.cmd == STREAM_FRAME or f.seq != seq:
                    self.stats.stale_answers += 1
                    continue
                if f.cmd == NAK:
                    if len(f.payload) >= 2 and f.payload[1] == 1:  # E_CRC: our request was hit
                        self.stats.log.append(f"probe saw a corrupt request on seq {seq}")
                        hit0 += 1
                        break
                    self.stats.naks += 1
                    if (len(f.payload) > 1 and f.payload[1] == E_STATE and code < B_IDENTIFY
                            and self.detect_bootloader):
                        self._raise_if_bootloader(code)
                    raise ProbeNak(f.payload[0] if f.payload else code, f.payload[1] if len(f.payload) > 1 else 0,
                                   f.payload[2] if len(f.payload) > 2 else None)
                if f.cmd == (code | 0x80):
                    _check_size(cmd if isinstance(cmd, str) else f"0x{code:02X}", f.payload, expect, self.port_name)
                    return f.payload
                self.stats.stale_answers += 1
        name = cmd if isinstance(cmd, str) else protocol.CMD_NAMES.get(code, hex(code))
        got, bad = self.stats.bytes_in - in0, self.stats.bad_frames - bad0
        console = any(_is_probe_console(line) for line in self._lines)
        if self._lines and not (bad or hit0 or self._answered or console):  # text, never a frame: not a probe
            raise ProbeError(f"the device on {self.port_name} answered {name} with text, not frames "
                             f"({self._lines[-1][:32]!r}): not an inclino probe, or the wrong baud rate")
        if echoed and not (bad or hit0 or self._answered):  # every request came back as sent
            raise ProbeError(f"the port {self.port_name} sends back every request as it was sent ({name}, "
                             f"{echoed} time(s)) and nothing else answers: a loopback or an echoing device, "
                             f"not a probe; check which port the probe is on (inclino ports)")
        if self._answered and not got:   # it answered before in this command: now silent
            raise ProbeError(f"no answer from the probe on {self.port_name} to {name} after {self.retries + 1} "
                             f"tries, though it answered earlier in this command: it stopped answering (the "
                             f"link broke or the probe lost power); check the cable and the probe's supply, "
                             f"then run the command again{_holders_text(self.port_name)}")
        if got or hit0:   # something came back: the probe is there, the line corrupts or loses bytes
            raise ProbeError(f"no valid answer from the probe on {self.port_name} to {name} after "
                             f"{self.retries + 1} tries: the link is noisy ({got} bytes received, {bad} "
                             f"corrupt answer(s), {hit0} request(s) the probe received corrupt); check the "
                             f"cable, its connectors and screening{_holders_text(self.port_name)}")
        raise ProbeError(f"no answer from the probe on {self.port_name} to {name} after "
                         f"{self.retries + 1} tries, nothing received (wrong port, wrong baud rate, or the "
                         f"probe is off){_holders_text(self.port_name)}")

    def _raise_if_bootloader(self, code: int) -> None:
        """An application command answered E_STATE: if the bootloader runs,
        raise ProbeInBootloader (else return: an ordinary E_STATE)."""
        self.detect_bootloader = False
        try:
            p = self.request(B_IDENTIFY)
        except ProbeError:
            return
        finally:
            self.detect_bootloader = True
        if p[:12] == b"INCLINO-BOOT" and len(p) > 19:
            raise ProbeInBootloader(code, self.port_name, p[19])

    # ----------------------------------------------------------- commands
    def identify(self) -> protocol.Identity:
        return protocol.Identity.unpack(self.request("IDENTIFY"))

    def survey(self) -> protocol.SurveyRecord:
        return protocol.SurveyRecord.unpack(self.request("SURVEY"))

    def raw(self) -> protocol.RawRecord:
        return protocol.RawRecord.unpack(self.request("RAW"))

    def qcref_read(self) -> tuple:
        return protocol.QCREF.unpack(self.request("QCREF_READ"))

    def qcref_write(self, values) -> None:
        self.request("QCREF_WRITE", protocol.QCREF.pack(*values))

    def cal_read(self, slot: int) -> tuple[int, bool, int, bytes]:
        p = self.request("CAL_READ", bytes([slot]))
        s, valid, seqn = struct.unpack(">BBI", p[:6])
        return s, bool(valid), seqn, p[6:]

    def cal_write(self, image: bytes, force: bool = False) -> tuple[int, int, int]:
        p = self.request("CAL_WRITE", bytes([1 if force else 0]) + image, timeout=self.timeout + FLASH_EXTRA_S)
        return struct.unpack(">BIH", p)

    def cal_activate(self, slot: int, sequence: int) -> tuple[int, int]:
        p = self.request("CAL_ACTIVATE", struct.pack(">BI", slot, sequence), timeout=self.timeout + FLASH_EXTRA_S)
        return struct.unpack(">BI", p)

    def set_average(self, n: int) -> int:
        """Samples the probe averages per survey (1..64)."""
        return self.request("SET_AVERAGE", bytes([n & 0xFF]))[0]

    def reset(self) -> None:
        self.request("RESET")

    def stream(self, period_ms: int, count: int, timeout: float = 2.0):
        """Start a stream and yield SurveyRecords until `count` arrived (or a
        gap longer than `timeout`); the stream is stopped at the end."""
        self.request("STREAM", struct.pack(">HH", period_ms, count))
        got = 0
        try:
            while count == 0 or got < count:
                ev = self._events(time.monotonic() + timeout)
                if ev is None:
                    raise ProbeError(f"survey stream stopped after {got} frames")
                if ev.kind == "frame" and ev.frame.cmd == STREAM_FRAME:
                    got += 1
                    _check_size("a streamed survey", ev.frame.payload, protocol.ANSWER_SIZES["SURVEY"],
                                self.port_name)
                    yield protocol.SurveyRecord.unpack(ev.frame.payload)
                elif ev.kind != "frame":
                    self.stats.bad_frames += 1
        finally:
            if count == 0 or got < count:
                try:
                    self.request("STOP")
                except ProbeError:
                    pass


# ---------------------------------------------------------------- the port
def _check_size(name: str, payload: bytes, expect, port: str) -> None:
    """A valid frame whose payload length this command never has: a link
    error (exit 4) naming the command and the length."""
    if expect is None:
        return
    n = len(payload)
    if isinstance(expect, tuple):
        ok = expect[0] <= n <= expect[1]
        want = f"{expect[0]}-{expect[1]}"
    else:
        ok = n in expect
        want = " or ".join(str(x) for x in sorted(expect))
    if not ok:
        raise ProbeError(f"the answer to {name} on {port} has a payload of {n} bytes, expected {want}: a valid "
                         "frame of the wrong length (another protocol version, or not an inclino probe)")


def _check_terminal(port: str):
    """Before the link touches a local device: refuse the controlling
    terminal of a running session (a shell's window: writing the protocol
    into it would type into that session); return the device's terminal
    settings to restore if it does not answer like a probe (None when it
    is not a terminal, or cannot be opened: pyserial then says why)."""
    try:
        fd = os.open(port, os.O_RDWR | os.O_NOCTTY | os.O_NONBLOCK)
    except OSError:
        return None
    try:
        if not os.isatty(fd):
            return None
        session = _session_on(os.fstat(fd).st_rdev)
        if session is not None:
            raise ProbeError(f"port {port} is the terminal of a running session ({session}), not a probe's "
                             "serial port: nothing was written to it")
        try:
            import termios

            return termios.tcgetattr(fd)
        except Exception:
            return None
    finally:
        os.close(fd)


def _session_on(rdev: int) -> str | None:
    """'NAME (pid N)' of a process whose controlling terminal is the device
    `rdev` (Linux /proc: field tty_nr of /proc/PID/stat), else None."""
    if not os.path.isdir("/proc"):
        return None
    for d in os.listdir("/proc"):
        if not d.isdigit():
            continue
        try:
            with open(f"/proc/{d}/stat", encoding="utf-8", errors="replace") as f:
                text = f.read()
        except OSError:
            continue
        name, _, rest = text.rpartition(")")
        fields = rest.split()
        try:
            if int(fields[4]) == rdev and rdev != 0:
                return f"{name.partition('(')[2]} (pid {d})"
        except (IndexError, ValueError):
            continue
    return None


def port_holders(port: str) -> list[tuple[int, str]]:
    """(pid, name) of the other processes that hold `port` open (Linux
    /proc; an empty list elsewhere).  The process holding a pseudo-terminal's
    other side (an emulator) is not counted."""
    try:
        st = os.stat(port)
    except (OSError, ValueError):
        return []
    if not os.path.isdir("/proc"):
        return []
    import stat as _stat

    if not _stat.S_ISCHR(st.st_mode):
        return []
    me, found = os.getpid(), []
    pts_index = None
    real = os.path.realpath(port)
    if real.startswith("/dev/pts/") and real[9:].isdigit():
        pts_index = int(real[9:])
    for d in os.listdir("/proc"):
        if not d.isdigit() or int(d) == me:
            continue
        fdir = f"/proc/{d}/fd"
        holds, owns_master = False, False
        try:
            for fd in os.listdir(fdir):
                try:
                    t = os.readlink(f"{fdir}/{fd}")
                    if t == "/dev/ptmx" or t.startswith("/dev/pts/ptmx"):
                        if pts_index is not None and _ptmx_index(d, fd) in (pts_index, None):
                            owns_master = True
                        continue
                    if t.startswith("/dev/") and os.stat(f"{fdir}/{fd}").st_rdev == st.st_rdev:
                        holds = True
                except OSError:
                    continue
        except OSError:
            continue
        if holds and not owns_master:
            try:
                with open(f"/proc/{d}/comm", encoding="utf-8", errors="replace") as f:
                    name = f.read().strip()
            except OSError:
                name = "?"
            found.append((int(d), name))
    return found


def _ptmx_index(pid: str, fd: str):
    try:
        with open(f"/proc/{pid}/fdinfo/{fd}", encoding="ascii", errors="replace") as f:
            for line in f:
                if line.startswith("tty-index:"):
                    return int(line.split()[1])
    except (OSError, ValueError, IndexError):
        pass
    return None


def _holders_text(port: str) -> str:
    try:
        h = port_holders(port)
    except Exception:  # pragma: no cover - /proc changing under the walk
        return ""
    if not h:
        return ""
    who = ", ".join(f"{n} (pid {p})" for p, n in h[:3])
    return f"; the port is also open in {who}, which may be taking the answers"
