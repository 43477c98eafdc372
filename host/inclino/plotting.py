"""The one figure set-up of every plot (calibration figures, acceptance
maps, diagnosis residuals, the papers' checks, well paths): matplotlib on
the Agg backend (PNG, no display needed), the output folder made with one
clear error, and each figure written through safeio's output rules (never
over an input or a device) at one resolution, then closed."""
from __future__ import annotations

import os

from inclino.errors import DataError

DPI = 110


def pyplot():
    """matplotlib.pyplot on the Agg backend (imported on first use: the CLI starts without it)."""
    import matplotlib

    matplotlib.use("Agg", force=True)
    import matplotlib.pyplot as plt

    return plt


def make_dir(path: str, what: str = "") -> None:
    """Create the output folder (and its parents); failing is bad input (exit 2)."""
    try:
        os.makedirs(path, exist_ok=True)
    except OSError as e:
        raise DataError(f"cannot create {what + ' ' if what else ''}{path}: {e.strerror}")


def save(fig, path: str) -> str:
    """Write `fig` as PNG to `path` by safeio's rules and close it."""
    from inclino.formats import safeio

    try:
        safeio.save_figure(fig, path, dpi=DPI)
    finally:
        pyplot().close(fig)
    return path
