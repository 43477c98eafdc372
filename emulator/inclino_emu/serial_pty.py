"""The probe's SCI as a real pseudo-terminal, with byte timing and link faults.

A `PtyLink` owns a pseudo-terminal pair.  Host tools open the slave path
(`link.path`, optionally a stable symlink) with pyserial, picocom or minicom
as they would a USB-serial adapter.  The emulator moves bytes between the pty
master and a *device* — any object with `sci_write(data: bytes)` (bytes into
the probe's receiver) and `sci_read() -> bytes` (bytes the probe sent) — and
applies the link faults on the way (`LinkFaults`).

Byte timing: at `baud` baud (8N1) one byte takes 10/baud seconds; `pump(dt)`
moves at most the bytes that fit in dt in each direction, so a 115 200 baud
link carries 11 520 bytes/s.  With `throttle=False` bytes pass as fast as the
device makes them.
"""
from __future__ import annotations

import errno
import os
import random
import termios
import tty
from dataclasses import dataclass, field


@dataclass
class LinkFaults:
    """Faults injected on the serial line, in both directions.

    bit_error_rate: probability that each bit is flipped (applied per byte:
      each of its 8 bits independently); drop_rate / dup_rate: probability
      that a byte is lost / sent twice; disconnected: nothing passes."""

    bit_error_rate: float = 0.0
    drop_rate: float = 0.0
    dup_rate: float = 0.0
    disconnected: bool = False
    seed: int = 0
    counts: dict = field(default_factory=lambda: {"bit_errors": 0, "dropped": 0, "duplicated": 0})

    def __post_init__(self):
        self._rng = random.Random(self.seed)

    def apply(self, data: bytes) -> bytes:
        if self.disconnected:
            return b""
        if not (self.bit_error_rate or self.drop_rate or self.dup_rate):
            return data
        out = bytearray()
        r = self._rng
        for b in data:
            if self.drop_rate and r.random() < self.drop_rate:
                self.counts["dropped"] += 1
                continue
            if self.bit_error_rate:
                for bit in range(8):
                    if r.random() < self.bit_error_rate:
                        b ^= 1 << bit
                        self.counts["bit_errors"] += 1
            out.append(b)
            if self.dup_rate and r.random() < self.dup_rate:
                out.append(b)
                self.counts["duplicated"] += 1
        return bytes(out)


class PtyLink:
    def __init__(self, baud: int = 115200, link_path: str | None = None, throttle: bool = True):
        self.baud = baud
        self.throttle = throttle
        self.faults = LinkFaults()
        self.master, self._slave = os.openpty()
        tty.setraw(self._slave)
        attrs = termios.tcgetattr(self._slave)
        speed = getattr(termios, f"B{baud}", None)
        if speed is not None:
            attrs[4] = attrs[5] = speed
            termios.tcsetattr(self._slave, termios.TCSANOW, attrs)
        os.set_blocking(self.master, False)
        self.path = os.ttyname(self._slave)
        self.link_path = link_path
        if link_path:
            try:
                if os.path.islink(link_path):
                    os.unlink(link_path)
                os.symlink(self.path, link_path)
            except OSError as e:
                self.close()
                raise OSError(f"cannot create the link {link_path}: {e.strerror}") from None
        self._tx_credit = 0.0  # bytes the host->probe direction may still move
        self._rx_credit = 0.0
        self._to_host = bytearray()
        self.bytes_to_host = 0
        self.bytes_to_probe = 0

    @property
    def byte_time(self) -> float:
        return 10.0 / self.baud

    def pump(self, device, dt: float) -> None:
        """Move bytes for dt seconds of link time between the pty and the
        device (host -> probe, then probe -> host)."""
        budget = dt / self.byte_time if self.throttle else float("inf")
        # host -> probe
        self._tx_credit = min(self._tx_credit + budget, 4096.0)
        n = int(self._tx_credit) if self.throttle else 65536
        if n > 0:
            try:
                data = os.read(self.master, n)
            except BlockingIOError:
                data = b""
            except OSError as e:
                if e.errno != errno.EIO:
                    raise
                data = b""
            if data:
                self._tx_credit -= len(data)
                self.bytes_to_probe += len(data)
                data = self.faults.apply(data)
                if data:
                    device.sci_write(data)
        # probe -> host
        self._to_host += device.sci_read()
        self._rx_credit = min(self._rx_credit + budget, 4096.0)
        n = min(len(self._to_host), int(self._rx_credit) if self.throttle else len(self._to_host))
        if n > 0:
            chunk = bytes(self._to_host[:n])
            del self._to_host[:n]
            self._rx_credit -= n
            out = self.faults.apply(chunk)
            try:
                if out:
                    os.write(self.master, out)
                self.bytes_to_host += n
            except BlockingIOError:
                pass  # the host is not reading: the pty buffer is full, bytes are lost as on a real line

    def close(self) -> None:
        for fd in (self.master, self._slave):
            try:
                os.close(fd)
            except OSError:
                pass
        if self.link_path and os.path.islink(self.link_path):
            try:
                os.unlink(self.link_path)
            except OSError:
                pass
