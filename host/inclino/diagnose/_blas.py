"""One BLAS thread while a diagnosis runs.

The diagnosis works on many small matrices (tens of columns); OpenBLAS's
worker threads only contend for them, and on a loaded machine a multi-
threaded BLAS made one dataset ten times slower (1.4 s against 0.11 s).
`one_blas_thread()` sets the loaded OpenBLAS libraries (numpy's and
SciPy's) to one thread and restores their counts afterwards; threadpoolctl
is used when it is installed; anything else is left alone (no-op)."""
from __future__ import annotations

import contextlib
import ctypes

_SYMBOLS = (("scipy_openblas_get_num_threads64_", "scipy_openblas_set_num_threads64_"),
            ("scipy_openblas_get_num_threads", "scipy_openblas_set_num_threads"),
            ("openblas_get_num_threads", "openblas_set_num_threads"))


def _openblas_handles():
    paths = set()
    try:
        with open("/proc/self/maps", encoding="utf-8", errors="replace") as f:
            for line in f:
                parts = line.split()
                if len(parts) >= 6 and "openblas" in parts[-1].lower() and ".so" in parts[-1]:
                    paths.add(parts[-1])
    except OSError:
        return []
    out = []
    for p in sorted(paths):
        try:
            lib = ctypes.CDLL(p)
        except OSError:
            continue
        for g, s in _SYMBOLS:
            if hasattr(lib, g) and hasattr(lib, s):
                out.append((getattr(lib, g), getattr(lib, s)))
                break
    return out


@contextlib.contextmanager
def one_blas_thread():
    # SciPy's OpenBLAS loaded first: only the libraries loaded when the limit is entered are limited (with
    # SciPy's loaded later, its calls in a long run's temperature fit still ran two threads: 277 against
    # 181 CPU s at 250 000 rows)
    import scipy.linalg  # noqa: F401

    try:
        from threadpoolctl import threadpool_limits
    except ImportError:
        threadpool_limits = None
    if threadpool_limits is not None:
        with threadpool_limits(1, "blas"):
            yield
        return
    saved = []
    for get, put in _openblas_handles():
        try:
            n = int(get())
            put(1)
            saved.append((put, n))
        except Exception:  # a library without the call: leave it alone
            continue
    try:
        yield
    finally:
        for put, n in saved:
            put(n)
