"""Output files that never destroy data, and bounded parsing of input files.

Every command that writes a file writes it through `output_file` /
`write_output` (docs/cli.md, "Output files"):

* `-` is standard output.
* An output that is one of the command's inputs is refused (exit 2) before
  anything is written: the same file by device and inode, so also through a
  hard link or a symbolic link.
* A path that names a directory is refused.
* An existing regular file, or a new path, is written atomically: a
  temporary file in the same directory, flushed to disk, then renamed over
  the target.  An existing target keeps its permission bits; a new file gets
  the bits an ordinary `open()` gives (0666 less the umask): CAL.json is
  readable like any other output.  A failure (disk full, no permission)
  removes the temporary file and leaves the target as it was.
* A symbolic link is written through: the file it points to gets the new
  content (by the same atomic rename, in that file's directory) and the link
  stays a link.
* An existing file that is not a regular file (a character device such as
  /dev/null or /dev/full, a FIFO, a terminal) is written into in place, never
  renamed over, so a device node is never replaced by a regular file; an
  error while writing or closing it (/dev/full: no space left) is one error
  line, exit 2.

Input files: `read_text` reads at most a stated number of bytes as UTF-8 (a
leading byte-order mark is dropped), `parse_json` refuses nesting deeper
than MAX_JSON_DEPTH, non-finite numbers (NaN, Infinity, 1e999) and integers
of more than MAX_INT_DIGITS digits -- each as one line (the error class the
caller gives), never a RecursionError, OverflowError or UnicodeDecodeError.

A command's files (`command_files`): the command line declares every file a
command reads and writes (inclino.cli.paths); `command_files(inputs,
outputs)` refuses, before any work, an output that is one of the inputs or
names the same file as another output, and, while the command runs, every
file written through this module is checked against those inputs and
against every file the command already wrote (a figure written into an
output folder through a planted symbolic link, two figures of one name).
"""
from __future__ import annotations

import contextlib
import io
import json
import math
import os
import stat
import sys
import tempfile

from inclino.errors import DataError

MAX_JSON_BYTES = 16 * 2**20  # a CAL.json with its fit report is a few tens of kB
MAX_JSON_DEPTH = 32  # CAL.json nests 4 deep; the fit report a few more
MAX_INT_DIGITS = 30  # the largest integer in CAL.json is a 32-bit coefficient (10 digits)


# ---------------------------------------------------------------- the command's files
class _Scope:
    """The files of the running command: its inputs, and what it wrote."""

    def __init__(self, inputs):
        self.inputs = [p for p in inputs if p and p != "-"]
        self.written: dict = {}  # identity or real path -> the path as given


_SCOPES: list = []


def _scope():
    return _SCOPES[-1] if _SCOPES else None


def _key(path: str):
    """What names a file: (device, inode) when it exists, else its real path."""
    return _ident(path) or os.path.realpath(path)


def check_outputs(inputs, outputs) -> None:
    """The rule between a command's files, before any work: each output
    (path, kind 'file' or 'dir', option name) is neither an input nor the
    file of another output; at most one output is standard output."""
    inputs = [p for p in inputs if p and p != "-"]
    seen: dict = {}
    stdout = []
    for path, kind, name in outputs:
        if path == "-":
            stdout.append(name)
            if len(stdout) > 1:
                raise DataError(f"{stdout[0]} and {name} both write to standard output")
            continue
        if kind == "dir":
            if not path:
                raise DataError(f"{name}: an empty folder path")
            for p in inputs:
                if _ident(p) is not None and _ident(p) == _ident(path):
                    raise DataError(f"refusing to write into {path}: it is the input {p}")
            if os.path.exists(path) and not os.path.isdir(path):
                raise DataError(f"refusing to write into {path} ({name}): it is not a folder")
        else:
            check_output(path, inputs)
            try:
                if not stat.S_ISREG(os.stat(path).st_mode):
                    continue  # a device (/dev/null) may take several outputs
            except (OSError, ValueError):
                pass
        k = _key(path)
        if k in seen:
            other, oname = seen[k]
            raise DataError(f"{oname} {other} and {name} {path} name the same "
                            f"{'folder' if kind == 'dir' else 'file'}: one output would replace the other")
        seen[k] = (path, name)


@contextlib.contextmanager
def command_files(inputs, outputs=()):
    """Run a command with its declared files (see the module's docstring)."""
    check_outputs(inputs, outputs)
    _SCOPES.append(_Scope(inputs))
    try:
        yield
    finally:
        _SCOPES.pop()


# ---------------------------------------------------------------- outputs
def _ident(path: str):
    try:
        st = os.stat(path)
    except (OSError, ValueError):
        return None
    return (st.st_dev, st.st_ino)


def check_output(path: str, inputs=()) -> None:
    """Raise DataError if writing `path` would overwrite one of `inputs` or
    a directory.  Call it before the work, so a refusal costs nothing."""
    if path == "-":
        return
    if not path:
        raise DataError("an empty output path")
    out = _ident(path)
    if out is not None:
        for p in inputs:
            if p and p != "-" and _ident(p) == out:
                raise DataError(f"refusing to write {path}: it is the input file {p}")
    if os.path.isdir(path):
        raise DataError(f"refusing to write {path}: it is a directory")


def _regular_or_new(path: str) -> bool:
    try:
        return stat.S_ISREG(os.stat(path).st_mode)
    except (OSError, ValueError):
        return True


def _new_file_mode() -> int:
    mask = os.umask(0)
    os.umask(mask)
    return 0o666 & ~mask


@contextlib.contextmanager
def output_file(path: str, inputs=(), *, binary: bool = False, newline: str | None = ""):
    """Open `path` for writing by the rules above; yields a file object.  The
    content is committed when the with-block ends without an exception."""
    scope = _scope()
    inputs = list(inputs) + (scope.inputs if scope is not None else [])
    check_output(path, inputs)
    if scope is not None and path != "-":
        k = _key(path)
        if k in scope.written and scope.written[k] != path and _regular_or_new(path):
            raise DataError(f"refusing to write {path}: this command already wrote that file "
                            f"({scope.written[k]})")
    if path == "-":
        f = sys.stdout.buffer if binary else sys.stdout
        try:
            yield f
            f.flush()
        except BrokenPipeError:
            raise
        except OSError as e:
            raise DataError(f"cannot write to standard output: {e.strerror}") from None
        return
    real = os.path.realpath(path)  # a symlink is written through
    try:
        st = os.stat(real)
    except FileNotFoundError:
        st = None
    except OSError as e:
        raise DataError(f"cannot write {path}: {e.strerror}") from None
    mode = "wb" if binary else "w"
    kw = {} if binary else {"encoding": "utf-8", "newline": newline}
    if st is not None and not stat.S_ISREG(st.st_mode):
        # a device, FIFO or terminal: written into, never replaced
        try:
            f = open(real, mode, **kw)
        except OSError as e:
            raise DataError(f"cannot write {path}: {e.strerror}") from None
        try:
            with f:
                yield f
        except OSError as e:
            raise DataError(f"cannot write {path}: {e.strerror}") from None
        return
    d = os.path.dirname(real) or "."
    try:
        fd, tmp = tempfile.mkstemp(prefix="." + os.path.basename(real) + ".", suffix=".tmp", dir=d)
    except OSError as e:
        raise DataError(f"cannot write {path}: {e.strerror}") from None
    ok = False
    try:
        try:
            os.fchmod(fd, stat.S_IMODE(st.st_mode) if st is not None else _new_file_mode())
            with os.fdopen(fd, mode, **kw) as f:
                yield f
                f.flush()
                os.fsync(f.fileno())
            now = _ident(path)  # the same check again just before the rename
            if now is not None and now in {_ident(p) for p in inputs if p and p != "-"}:
                raise DataError(f"refusing to write {path}: it is the input file")
            os.replace(tmp, real)
            ok = True
            if scope is not None:
                scope.written[_key(real)] = path
        except OSError as e:
            raise DataError(f"cannot write {path}: {e.strerror}") from None
    finally:
        if not ok:
            with contextlib.suppress(OSError):
                os.unlink(tmp)


def write_output(path: str, data, inputs=()) -> None:
    """Write a whole str or bytes to `path` by the rules above."""
    binary = isinstance(data, (bytes, bytearray))
    with output_file(path, inputs, binary=binary, newline=None if not binary else "") as f:
        f.write(data)


def save_figure(fig, path: str, **kw) -> None:
    """A matplotlib figure as PNG through the same rules."""
    buf = io.BytesIO()
    fig.savefig(buf, format="png", **kw)
    write_output(path, buf.getvalue())


def open_log(path: str, mode: str = "a", inputs=()):
    """A log file written as a run goes, row by row ("w": a new one, "a":
    continued; a survey run's CSV, acquire's RUN.csv.part): by the same
    rules as every output (never one of the inputs, a directory, or a file
    this command already wrote under another name); the caller flushes each
    row, and what it wrote stays on any exit."""
    scope = _scope()
    inputs = list(inputs) + (scope.inputs if scope is not None else [])
    check_output(path, inputs)
    if scope is not None:
        k = _key(path)
        if k in scope.written and scope.written[k] != path:
            raise DataError(f"refusing to write {path}: this command already wrote that file "
                            f"({scope.written[k]})")
    try:
        f = open(path, "a" if mode == "a" else "w", encoding="utf-8", newline="")
    except OSError as e:
        raise DataError(f"cannot write {path}: {e.strerror}") from None
    if scope is not None:
        scope.written[_key(path)] = path
    return f


# ---------------------------------------------------------------- inputs
def read_text(path: str, what: str = "file", max_bytes: int = MAX_JSON_BYTES, error=DataError) -> str:
    """The whole text of a small input file (UTF-8, BOM dropped), at most
    max_bytes; a file that cannot be opened or read is a DataError (exit 2,
    bad input, whatever the file is: a missing CAL.json was exit 3 where
    a missing --prior was 2), every defect of its content one `error` line
    naming the file."""
    try:
        with open(path, "rb") as f:
            raw = f.read(max_bytes + 1)
    except OSError as e:
        raise DataError(f"cannot read {what} {path}: {e.strerror}") from None
    if len(raw) > max_bytes:
        raise error(f"{what} {path} is larger than {max_bytes // 2**20} MiB")
    if b"\x00" in raw:
        raise error(f"{what} {path} is not a text file (binary data)")
    try:
        return raw.decode("utf-8-sig")
    except UnicodeDecodeError as e:
        line, col = line_of(raw, e.start + (3 if raw.startswith(b"\xef\xbb\xbf") else 0))
        raise error(f"{what} {path}:{line}: not UTF-8 text (byte 0x{raw[line_start(raw, line) + col - 1]:02X} at "
                    f"column {col})") from None


def line_of(raw: bytes, offset: int) -> tuple[int, int]:
    """(line, column), both from 1, of a byte offset in raw text (lines end
    in LF, CRLF or a lone CR, as Python's text files read them)."""
    head = raw[:offset]
    line = head.count(b"\n") + head.count(b"\r") - head.count(b"\r\n") + 1
    start = max(head.rfind(b"\n"), head.rfind(b"\r")) + 1
    return line, offset - start + 1


def line_start(raw: bytes, line: int) -> int:
    """The byte offset of a line (from 1) in raw text."""
    off, n = 0, 1
    while n < line:
        i, j = raw.find(b"\n", off), raw.find(b"\r", off)
        ends = [x for x in (i, j) if x >= 0]
        if not ends:
            break
        k = min(ends)
        off = k + (2 if raw[k:k + 2] == b"\r\n" else 1)
        n += 1
    return off


def utf8_error(path: str, chunk: int = 1 << 20):
    """(line, column, byte) of the first byte of a file that is not UTF-8
    (None when it all decodes): read in binary, for the error line of a
    reader that decodes as it streams."""
    import codecs

    dec = codecs.getincrementaldecoder("utf-8")()
    lines, col, last_cr = 1, 0, False
    with open(path, "rb") as f:
        while True:
            buf = f.read(chunk)
            try:
                dec.decode(buf, final=not buf)
            except UnicodeDecodeError as e:
                # the error's offset is within what the decoder held: the pending bytes and this buffer
                pend = len(e.object) - len(buf)
                bad = e.start - pend
                head = buf[:max(bad, 0)]
                n = head.count(b"\n") + head.count(b"\r") - head.count(b"\r\n")
                if last_cr and head.startswith(b"\n"):
                    n -= 1
                cut = max(head.rfind(b"\n"), head.rfind(b"\r"))
                c = (bad - cut) if cut >= 0 else col + bad + 1
                return lines + n, c, e.object[e.start]
            if not buf:
                return None
            n = buf.count(b"\n") + buf.count(b"\r") - buf.count(b"\r\n")
            if last_cr and buf.startswith(b"\n"):
                n -= 1
            cut = max(buf.rfind(b"\n"), buf.rfind(b"\r"))
            col = (len(buf) - cut - 1) if cut >= 0 else col + len(buf)
            lines += n
            last_cr = buf.endswith(b"\r")


def json_depth(text: str) -> int:
    """Deepest nesting of [ and { outside strings, in linear time (no
    regular expression that could backtrack on hostile text)."""
    import numpy as np

    a = np.frombuffer(text.encode("utf-8", "surrogatepass"), dtype=np.uint8)
    if a.size == 0:
        return 0
    idx = np.arange(a.size)
    # backslashes right before each byte: a quote after an odd number is escaped
    last_other = np.maximum.accumulate(np.where(a != 0x5C, idx, -1))
    before = np.concatenate(([0], idx[:-1] - last_other[:-1]))
    quote = (a == 0x22) & (before % 2 == 0)
    inside = (np.cumsum(quote) % 2 == 1) & ~quote
    opens = ((a == 0x5B) | (a == 0x7B)) & ~inside
    closes = ((a == 0x5D) | (a == 0x7D)) & ~inside
    return int(np.cumsum(opens.astype(np.int64) - closes).max(initial=0))


def parse_json(text: str, what: str = "JSON", error=DataError, max_depth: int = MAX_JSON_DEPTH):
    """json.loads with bounds: nesting, finite numbers, integer length."""
    depth = json_depth(text)
    if depth > max_depth:
        raise error(f"{what} nests deeper than {max_depth} levels")

    def _float(s):
        v = float(s)
        if not math.isfinite(v):
            raise ValueError(f"the number {s[:20]} is out of range")
        return v

    def _int(s):
        if len(s.lstrip("-")) > MAX_INT_DIGITS:
            raise ValueError(f"an integer of {len(s.lstrip('-'))} digits")
        return int(s)

    def _const(s):
        raise ValueError(f"{s} is not a number JSON allows")

    try:
        return json.loads(text, parse_float=_float, parse_int=_int, parse_constant=_const)
    except json.JSONDecodeError as e:
        raise error(f"{what} is not valid JSON ({e.msg} at line {e.lineno})") from None
    except (ValueError, RecursionError, OverflowError) as e:
        raise error(f"{what} is not valid JSON ({e})") from None


def load_json(path: str, what: str = "file", error=DataError, max_bytes: int = MAX_JSON_BYTES):
    return parse_json(read_text(path, what, max_bytes, error), f"{what} {path}", error)
