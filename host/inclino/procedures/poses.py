"""A turntable pose (the table's indicated inclination, azimuth, toolface)
and the angle wrap every procedure uses: shared by acquisition, the
acceptance test and the turntables (inclino.procedures.turntable,
turntable_emulated)."""
from __future__ import annotations

import math
from dataclasses import dataclass


@dataclass
class Step:
    """One position of a procedure: the turntable's indicated pose."""
    inc: float
    azi: float
    tf: float
    label: str
    rotation: int = 0  # continuous: 1 or 2 (which toolface rotation), else 0


def wrap_deg(a: float) -> float:
    """An angle in deg brought into [0, 360) (-0.0 and 360 - tiny give 0.0)."""
    a = math.fmod(float(a), 360.0)
    a = a + 360.0 if a < 0 else a
    return 0.0 if a >= 360.0 else a + 0.0


_DIRS = (("north", (1, 0, 0)), ("south", (-1, 0, 0)), ("east", (0, 1, 0)), ("west", (0, -1, 0)),
         ("down", (0, 0, 1)), ("up", (0, 0, -1)))


def describe(inc: float, azi: float, tf: float) -> str:
    """Where each body axis points at this pose, e.g. "X down, Y west, Z
    north" (Li 2021 Table 1's words); axes off the six directions are given
    by their inclination from down."""
    from inclino.engines import reference as ref

    C = ref.pose_matrix(inc, azi, tf)
    parts = []
    for k, name in enumerate("XYZ"):
        v = C[k]
        best = max(_DIRS, key=lambda d: sum(a * b for a, b in zip(v, d[1])))
        if sum(a * b for a, b in zip(v, best[1])) > math.cos(math.radians(1.0)):
            parts.append(f"{name} {best[0]}")
        else:
            parts.append(f"{name} {math.degrees(math.acos(max(-1.0, min(1.0, v[2])))):.0f} deg from down")
    return ", ".join(parts)
