"""The emulator's control channel: JSON lines over TCP, loopback only.

One request per line, one answer per line:

    -> {"cmd": "move", "inc": 30, "azi": 120, "tf": 45}
    <- {"ok": true}
    -> {"cmd": "nonsense"}
    <- {"ok": false, "error": "unknown command 'nonsense'"}

The commands (their handlers come from emulator/inclino_emu/runner.py) are listed in
docs/emulator.md.  The server is polled from the emulator's own loop
(`poll()`), so handlers run in the same thread as the firmware and need no
locking.  It binds 127.0.0.1 only.

Whatever a client does, the emulator keeps serving the probe (docs/emulator.md,
"Rules of the channel"):

* parsing is bounded: a line is at most MAX_LINE bytes, nested at most
  MAX_DEPTH deep (checked before the JSON parser sees it), numbers are at
  most MAX_NUMBER characters, NaN / Infinity are not JSON here;
* every argument has one rule (`number`, `integer`, `boolean`, `choice`,
  `known`), checked before the handler changes anything;
* sockets never block: answers go into a per-client queue of at most
  MAX_PENDING bytes, sent as the client reads them; a client whose queue is
  full (it does not read) is dropped, never waited on;
* each poll handles at most LINES_PER_POLL requests per client and accepts
  at most ACCEPT_PER_POLL connections; at most MAX_CLIENTS are connected
  (one more is answered `too many clients` and closed);
* a client that sends nothing and has nothing to receive for `idle_timeout`
  seconds (IDLE_TIMEOUT_S by default) is closed, so that idle connections
  cannot fill the MAX_CLIENTS places;
* a request whose work takes long (`advance`) answers with a `Pending`: its
  work is done a bounded slice per poll, between which the emulator serves
  the serial side and the other clients; that client's next request waits
  for the answer.
"""
from __future__ import annotations

import json
import math
import selectors
import socket
import time
from typing import Callable

MAX_LINE = 65536          # bytes in one request line (newline excluded)
MAX_DEPTH = 16            # nesting of arrays / objects in a request
MAX_NUMBER = 40           # characters of one JSON number
MAX_PENDING = 65536       # bytes of answers queued for one client before it is dropped
MAX_CLIENTS = 64
LINES_PER_POLL = 32       # requests handled per client per poll
REQUESTS_PER_POLL = 256   # requests handled per poll over all clients (taken in turn)
ACCEPT_PER_POLL = 64
IDLE_TIMEOUT_S = 600.0    # a client silent this long (nothing sent, nothing to receive) is closed
RECV_SIZE = 16384
SOCK_SNDBUF = 16384       # kernel send buffer asked for each client's socket


class RequestError(ValueError):
    """A request line that is refused before any handler runs."""


class ArgError(ValueError):
    """An argument that breaks its rule (answered `bad arguments for CMD: ...`)."""


# ---- bounded parsing ----------------------------------------------------------------
def _depth_ok(text: str, limit: int = MAX_DEPTH) -> bool:
    """True if arrays/objects nest at most `limit` deep (strings skipped)."""
    depth, in_str, esc = 0, False, False
    for ch in text:
        if in_str:
            if esc:
                esc = False
            elif ch == "\\":
                esc = True
            elif ch == '"':
                in_str = False
        elif ch == '"':
            in_str = True
        elif ch in "[{":
            depth += 1
            if depth > limit:
                return False
        elif ch in "]}":
            depth -= 1
    return True


def _no_constant(name: str):
    raise RequestError(f"{name} is not a number here (finite numbers only)")


def _parse_int(s: str) -> int:
    if len(s) > MAX_NUMBER:
        raise RequestError(f"number too long ({len(s)} characters)")
    return int(s)


def _parse_float(s: str) -> float:
    if len(s) > MAX_NUMBER:
        raise RequestError(f"number too long ({len(s)} characters)")
    v = float(s)
    if not math.isfinite(v):
        raise RequestError(f"{s} is out of range for a number")
    return v


def parse_request(line: bytes) -> dict:
    """One request line -> the request object.  Raises RequestError with
    the answer's text; never anything else, whatever the bytes."""
    if len(line) > MAX_LINE:
        raise RequestError("line too long")
    try:
        text = line.decode("utf-8")
    except UnicodeDecodeError as e:
        raise RequestError(f"not JSON: not UTF-8 at byte {e.start}") from None
    if not _depth_ok(text):
        raise RequestError(f"not JSON: nested deeper than {MAX_DEPTH}")
    try:
        req = json.loads(text, parse_constant=_no_constant, parse_int=_parse_int,
                         parse_float=_parse_float)
    except RequestError:
        raise
    except json.JSONDecodeError as e:
        raise RequestError(f"not JSON: {e}") from None
    except (ValueError, RecursionError) as e:   # belt and braces: the checks above bound both
        raise RequestError(f"not JSON: {e}") from None
    if not isinstance(req, dict) or not isinstance(req.get("cmd"), str):
        raise RequestError("a request is an object with a string 'cmd'")
    return req


# ---- one rule per argument --------------------------------------------------------
def known(r: dict, *names: str) -> None:
    """Refuse arguments the command does not take."""
    extra = sorted(k for k in r if k != "cmd" and k not in names)
    if extra:
        raise ArgError(f"unknown argument {extra[0]!r} (takes: {', '.join(names) or 'none'})")


def number(r: dict, key: str, lo: float, hi: float, unit: str = "") -> float:
    """A required finite number within [lo, hi]."""
    if key not in r:
        raise ArgError(f"{key!r} is missing")
    v = r[key]
    if isinstance(v, bool) or not isinstance(v, (int, float)):
        raise ArgError(f"{key} must be a number, not {type(v).__name__}")
    v = float(v)
    if not (math.isfinite(v) and lo <= v <= hi):
        raise ArgError(f"{key} must be a finite number within {lo:g} to {hi:g}{unit}")
    return v


def integer(r: dict, key: str, lo: int, hi: int) -> int:
    if key not in r:
        raise ArgError(f"{key!r} is missing")
    v = r[key]
    if isinstance(v, bool) or not isinstance(v, int):
        raise ArgError(f"{key} must be an integer")
    if not lo <= v <= hi:
        raise ArgError(f"{key} must be within {lo} to {hi}")
    return v


def boolean(r: dict, key: str) -> bool:
    v = r.get(key)
    if not isinstance(v, bool):
        raise ArgError(f"{key} must be true or false")
    return v


def choice(r: dict, key: str, options: tuple, default: str) -> str:
    v = r.get(key, default)
    if v not in options:
        raise ArgError(f"{key} must be one of {', '.join(options)}")
    return v


# ---- the server --------------------------------------------------------------------
class Pending:
    """The answer of a request whose work goes on over several polls:
    `step()` does a bounded slice of it and returns None, or the answer's
    fields when the work is done (an ArgError or ValueError: the error
    answer)."""

    def __init__(self, step: Callable[[], dict | None], cmd: str = ""):
        self.step, self.cmd = step, cmd


class _Client:
    __slots__ = ("sock", "inbuf", "outbuf", "closing", "pending", "active")

    def __init__(self, sock):
        self.sock = sock
        self.inbuf = bytearray()
        self.outbuf = bytearray()
        self.closing = False   # close once the queue is sent (after `line too long`)
        self.pending: Pending | None = None
        self.active = time.monotonic()


class ControlServer:
    def __init__(self, handlers: dict[str, Callable[[dict], dict | None]], port: int = 0,
                 idle_timeout: float = IDLE_TIMEOUT_S):
        if not isinstance(port, int) or not 0 <= port <= 65535:
            raise ValueError(f"control port {port} is not within 0-65535")
        self.idle_timeout = idle_timeout
        self.handlers = handlers
        self._sel = selectors.DefaultSelector()
        self._srv = socket.socket(socket.AF_INET, socket.SOCK_STREAM)
        self._srv.setsockopt(socket.SOL_SOCKET, socket.SO_REUSEADDR, 1)
        try:
            self._srv.bind(("127.0.0.1", port))
        except OSError as e:
            self._srv.close()
            raise OSError(f"cannot listen on 127.0.0.1:{port}: {e.strerror}") from None
        self._srv.listen(128)
        self._srv.setblocking(False)
        self._sel.register(self._srv, selectors.EVENT_READ, None)
        self.port = self._srv.getsockname()[1]
        self._clients: dict[socket.socket, _Client] = {}
        self._turn = 0
        self.stats = {"accepted": 0, "refused": 0, "dropped_slow": 0, "dropped_long": 0, "dropped_idle": 0,
                      "requests": 0}

    @property
    def clients(self) -> int:
        return len(self._clients)

    def fileobjs(self) -> list:
        """The sockets poll() watches (the listening one and each client's):
        for a caller that waits on them together with other descriptors."""
        return [k.fileobj for k in self._sel.get_map().values()]

    def poll(self, timeout: float = 0.0) -> None:
        """Accept, read, answer and send without ever blocking (beyond
        `timeout` in the select)."""
        for key, _ in self._sel.select(timeout):
            if key.fileobj is self._srv:
                self._accept()
                continue
            c = self._clients.get(key.fileobj)
            if c is None:
                continue
            if len(c.inbuf) <= MAX_LINE and not c.closing:
                try:
                    data = c.sock.recv(RECV_SIZE)
                except (BlockingIOError, InterruptedError):
                    data = None
                except OSError:
                    data = b""
                if data == b"":
                    self._drop(c)
                    continue
                if data:
                    c.inbuf += data
                    c.active = time.monotonic()
        now = time.monotonic()
        for c in list(self._clients.values()):
            if c.pending is not None:
                self._step_pending(c)
                c.active = now
            elif now - c.active > self.idle_timeout:
                self.stats["dropped_idle"] += 1
                self._drop(c)
        clients = list(self._clients.values())
        if clients:   # start with a different client each poll: a busy one cannot starve the others
            k = self._turn % len(clients)
            self._turn += 1
            clients = clients[k:] + clients[:k]
        budget = REQUESTS_PER_POLL
        for c in clients:
            if budget > 0 and not c.closing and c.inbuf and c.pending is None:
                budget -= self._handle_lines(c, min(LINES_PER_POLL, budget))
            if c.sock in self._clients:
                self._flush(c)

    def _accept(self) -> None:
        for _ in range(ACCEPT_PER_POLL):
            try:
                conn, _ = self._srv.accept()
            except (BlockingIOError, InterruptedError):
                return
            except OSError:
                return
            conn.setblocking(False)
            try:   # bound what the kernel holds for a client that does not read
                conn.setsockopt(socket.SOL_SOCKET, socket.SO_SNDBUF, SOCK_SNDBUF)
            except OSError:
                pass
            if len(self._clients) >= MAX_CLIENTS:
                self.stats["refused"] += 1
                try:
                    conn.send(b'{"ok": false, "error": "too many clients"}\n')
                except OSError:
                    pass
                conn.close()
                continue
            self.stats["accepted"] += 1
            c = self._clients[conn] = _Client(conn)
            self._sel.register(conn, selectors.EVENT_READ, None)

    def _handle_lines(self, c: _Client, n: int) -> int:
        """Answer at most n complete lines of c; returns how many."""
        done = 0
        while done < n:
            i = c.inbuf.find(b"\n", 0, MAX_LINE + 2)
            if i < 0 or i > MAX_LINE:
                if i > MAX_LINE or len(c.inbuf) > MAX_LINE:
                    self.stats["dropped_long"] += 1
                    self._queue(c, {"ok": False, "error": "line too long"})
                    c.closing = True
                    c.inbuf.clear()
                return done
            line = bytes(c.inbuf[:i])
            del c.inbuf[:i + 1]
            done += 1
            ans = self.handle_line(line, pending_ok=True)
            if isinstance(ans, Pending):  # answered when its work is done; the next request waits
                c.pending = ans
                break
            self._queue(c, ans)
            if c.sock not in self._clients:
                break
        return done

    def _step_pending(self, c: _Client) -> None:
        p = c.pending
        try:
            ans = p.step()
        except (KeyError, TypeError, ValueError, OverflowError) as e:
            c.pending = None
            self._queue(c, {"ok": False, "error": f"bad arguments for {p.cmd}: {e}"})
            return
        if ans is not None:
            c.pending = None
            self._queue(c, {"ok": True, **ans})

    def handle_line(self, line: bytes, pending_ok: bool = False):
        """The answer to one request line.  A request whose work goes on
        over several polls returns its Pending when pending_ok (the
        server's own loop), else runs it to the end here."""
        self.stats["requests"] += 1
        try:
            req = parse_request(line.rstrip(b"\r"))
        except RequestError as e:
            return {"ok": False, "error": str(e)}
        h = self.handlers.get(req["cmd"])
        if h is None:
            return {"ok": False, "error": f"unknown command {req['cmd'][:40]!r}"}
        try:
            ans = h(req) or {}
        except (KeyError, TypeError, ValueError, OverflowError) as e:
            return {"ok": False, "error": f"bad arguments for {req['cmd']}: {e}"}
        if isinstance(ans, Pending):
            ans.cmd = req["cmd"]
            if pending_ok:
                return ans
            try:
                while (done := ans.step()) is None:
                    pass
            except (KeyError, TypeError, ValueError, OverflowError) as e:
                return {"ok": False, "error": f"bad arguments for {req['cmd']}: {e}"}
            return {"ok": True, **done}
        return {"ok": True, **ans}

    def _queue(self, c: _Client, obj) -> None:
        c.outbuf += (json.dumps(obj, allow_nan=False) + "\n").encode()
        if len(c.outbuf) > MAX_PENDING:
            self.stats["dropped_slow"] += 1   # it does not read its answers: drop it, never wait
            self._drop(c)

    def _flush(self, c: _Client) -> None:
        while c.outbuf:
            try:
                n = c.sock.send(c.outbuf)
            except (BlockingIOError, InterruptedError):
                break
            except OSError:
                self._drop(c)
                return
            del c.outbuf[:n]
            if n:
                c.active = time.monotonic()
        if c.closing and not c.outbuf:
            self._drop(c)

    def _drop(self, c: _Client) -> None:
        if self._clients.pop(c.sock, None) is None:
            return
        try:
            self._sel.unregister(c.sock)
        except (KeyError, ValueError):
            pass
        c.sock.close()

    def close(self) -> None:
        for c in list(self._clients.values()):
            self._drop(c)
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
