"""Model discrepancy: find what the simulation (the per-triad 12-parameter
model) gets wrong in a raw turntable dataset, name the library effect that
explains it, estimate it and measure the gain.

    from inclino.diagnose import diagnose
    result = diagnose(dataset)          # -> Diagnosis; result.to_json()

The submodules (SciPy, the emulator's effect library) load on first use so
that the `inclino` command, which registers `diagnose`, starts quickly.
"""
from __future__ import annotations

from .names import EFFECT_NAMES  # one place: names.py (no SciPy loaded)

__all__ = ["diagnose", "Diagnosis", "EFFECT_NAMES"]


def __getattr__(name):
    if name == "diagnose":
        from .analysis import diagnose

        return diagnose
    if name == "Diagnosis":
        from .result import Diagnosis

        return Diagnosis
    raise AttributeError(name)
