"""A device on a pseudo-terminal that answers the probe's frames the way a
test tells it to: with a valid CRC and a payload of any length, or with
text like a modem, or not at all.  For the link's hostile cases (a probe
of another protocol, a noisy line that happens to make a valid frame, a
device that is not a probe)."""
from __future__ import annotations

import os
import pty
import select
import termios
import threading

from inclino.link import protocol


class FakeDevice:
    """`answer(frame) -> bytes | None`: what to send back for each request
    frame (None: nothing).  `path` is the port to open."""

    def __init__(self, answer):
        self.answer = answer
        self.master, self.slave = pty.openpty()  # the slave keeps its default (cooked) settings
        self.path = os.ttyname(self.slave)
        self.requests = []
        self._stop = threading.Event()
        self._thread = threading.Thread(target=self._run, daemon=True)
        self._thread.start()

    def _run(self):
        parser = protocol.FrameParser()
        while not self._stop.is_set():
            r, _, _ = select.select([self.master], [], [], 0.05)
            if not r:
                parser.idle()
                continue
            try:
                data = os.read(self.master, 4096)
            except OSError:
                return
            for ev in parser.feed(data):
                if ev.kind != "frame":
                    continue
                self.requests.append(ev.frame)
                out = self.answer(ev.frame)
                if out:
                    try:
                        os.write(self.master, out)
                    except OSError:
                        return

    def close(self):
        self._stop.set()
        self._thread.join(timeout=2)
        for fd in (self.master, self.slave):
            try:
                os.close(fd)
            except OSError:
                pass

    def __enter__(self):
        return self

    def __exit__(self, *exc):
        self.close()


def answer_with(payload: bytes):
    """Answer every request with a valid frame carrying `payload`."""
    def f(frame):
        return protocol.encode_frame(frame.seq, frame.cmd | 0x80, payload)
    return f


def termios_state(path):
    fd = os.open(path, os.O_RDWR | os.O_NOCTTY | os.O_NONBLOCK)
    try:
        return termios.tcgetattr(fd)
    finally:
        os.close(fd)
