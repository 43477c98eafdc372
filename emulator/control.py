"""The emulator's control channel: JSON lines over TCP, loopback only.

One request per line, one answer per line:

    -> {"cmd": "move", "inc": 30, "azi": 120, "tf": 45}
    <- {"ok": true}
    -> {"cmd": "nonsense"}
    <- {"ok": false, "error": "unknown command 'nonsense'"}

The commands (their handlers come from emulator/runner.py) are listed in
docs/emulator.md.  The server is polled from the emulator's own loop
(`poll()`), so handlers run in the same thread as the firmware and need no
locking.  It binds 127.0.0.1 only.
"""
from __future__ import annotations

import json
import selectors
import socket
from typing import Callable

MAX_LINE = 65536


class ControlServer:
    def __init__(self, handlers: dict[str, Callable[[dict], dict | None]], port: int = 0):
        self.handlers = handlers
        self._sel = selectors.DefaultSelector()
        self._srv = socket.socket(socket.AF_INET, socket.SOCK_STREAM)
        self._srv.setsockopt(socket.SOL_SOCKET, socket.SO_REUSEADDR, 1)
        try:
            self._srv.bind(("127.0.0.1", port))
        except OSError as e:
            self._srv.close()
            raise OSError(f"cannot listen on 127.0.0.1:{port}: {e.strerror}") from None
        self._srv.listen(4)
        self._srv.setblocking(False)
        self._sel.register(self._srv, selectors.EVENT_READ, None)
        self.port = self._srv.getsockname()[1]
        self._bufs: dict[socket.socket, bytearray] = {}

    def poll(self, timeout: float = 0.0) -> None:
        for key, _ in self._sel.select(timeout):
            if key.fileobj is self._srv:
                try:
                    conn, _ = self._srv.accept()
                except BlockingIOError:
                    continue
                conn.setblocking(False)
                self._bufs[conn] = bytearray()
                self._sel.register(conn, selectors.EVENT_READ, None)
                continue
            conn = key.fileobj
            try:
                data = conn.recv(4096)
            except (BlockingIOError, InterruptedError):
                continue
            except OSError:
                data = b""
            if not data:
                self._drop(conn)
                continue
            buf = self._bufs[conn]
            buf += data
            if len(buf) > MAX_LINE and b"\n" not in buf:
                self._send(conn, {"ok": False, "error": "line too long"})
                self._drop(conn)
                continue
            while b"\n" in buf:
                line, _, rest = bytes(buf).partition(b"\n")
                buf[:] = rest
                self._send(conn, self.handle_line(line))

    def handle_line(self, line: bytes) -> dict:
        try:
            req = json.loads(line.decode("utf-8"))
        except (UnicodeDecodeError, json.JSONDecodeError) as e:
            return {"ok": False, "error": f"not JSON: {e}"}
        if not isinstance(req, dict) or not isinstance(req.get("cmd"), str):
            return {"ok": False, "error": "a request is an object with a string 'cmd'"}
        h = self.handlers.get(req["cmd"])
        if h is None:
            return {"ok": False, "error": f"unknown command {req['cmd']!r}"}
        try:
            ans = h(req) or {}
        except (KeyError, TypeError, ValueError) as e:
            return {"ok": False, "error": f"bad arguments for {req['cmd']}: {e}"}
        return {"ok": True, **ans}

    def _send(self, conn, obj) -> None:
        try:
            conn.setblocking(True)
            conn.sendall((json.dumps(obj) + "\n").encode())
            conn.setblocking(False)
        except OSError:
            self._drop(conn)

    def _drop(self, conn) -> None:
        try:
            self._sel.unregister(conn)
        except (KeyError, ValueError):
            pass
        self._bufs.pop(conn, None)
        conn.close()

    def close(self) -> None:
        for conn in list(self._bufs):
            self._drop(conn)
        try:
            self._sel.unregister(self._srv)
        except (KeyError, ValueError):
            pass
        self._srv.close()


class ControlClient:
    """Client for tests and `inclino acquire --bench HOST:PORT`."""

    def __init__(self, host: str = "127.0.0.1", port: int = 0, timeout: float = 10.0):
        self._sock = socket.create_connection((host, port), timeout=timeout)
        self._buf = b""

    def call(self, cmd: str, **kw) -> dict:
        self._sock.sendall((json.dumps({"cmd": cmd, **kw}) + "\n").encode())
        while b"\n" not in self._buf:
            data = self._sock.recv(65536)
            if not data:
                raise ConnectionError("control channel closed")
            self._buf += data
        line, _, self._buf = self._buf.partition(b"\n")
        return json.loads(line)

    def close(self) -> None:
        self._sock.close()
