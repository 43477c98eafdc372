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

import numpy as np

from inclino.errors import DataError

MAX_JSON_BYTES = 16 * 2**20  # a CAL.json with its fit report is a few tens of kB
MAX_JSON_DEPTH = 32  # CAL.json nests 4 deep; the fit report a few more
MAX_INT_DIGITS = 30  # the largest integer in CAL.json is a 32-bit coefficient (10 digits)


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


def _new_file_mode() -> int:
    mask = os.umask(0)
    os.umask(mask)
    return 0o666 & ~mask


@contextlib.contextmanager
def output_file(path: str, inputs=(), *, binary: bool = False, newline: str | None = ""):
    """Open `path` for writing by the rules above; yields a file object.  The
    content is committed when the with-block ends without an exception."""
    check_output(path, inputs)
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


# ---------------------------------------------------------------- inputs
def read_text(path: str, what: str = "file", max_bytes: int = MAX_JSON_BYTES, error=DataError) -> str:
    """The whole text of a small input file (UTF-8, BOM dropped), at most
    max_bytes; every defect is one `error` line naming the file."""
    try:
        with open(path, "rb") as f:
            raw = f.read(max_bytes + 1)
    except OSError as e:
        raise error(f"cannot read {what} {path}: {e.strerror}") from None
    if len(raw) > max_bytes:
        raise error(f"{what} {path} is larger than {max_bytes // 2**20} MiB")
    if b"\x00" in raw:
        raise error(f"{what} {path} is not a text file (binary data)")
    try:
        return raw.decode("utf-8-sig")
    except UnicodeDecodeError as e:
        raise error(f"{what} {path} is not UTF-8 text (byte {e.start})") from None


def json_depth(text: str) -> int:
    """Deepest nesting of [ and { outside strings, in linear time (no
    regular expression that could backtrack on hostile text)."""
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
