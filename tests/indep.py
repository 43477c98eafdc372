"""What the tests' own generators share, written from docs/conventions.md
alone (not inclino.model): the body frame's reading of a world vector at a
pose, so that data made with it check inclino rather than agree with it."""
from __future__ import annotations

import numpy as np


def body(I, A, T, v):
    """(n, 3): the world vector v (north, east, down) read in the body frame
    at inclination I, azimuth A and toolface T (degrees, arrays of n): the
    transpose of Rz(A) Ry(I) Rz(T), written out."""
    I, A, T = np.radians(I), np.radians(A), np.radians(T)
    cI, sI, cA, sA, cT, sT = np.cos(I), np.sin(I), np.cos(A), np.sin(A), np.cos(T), np.sin(T)
    C = np.array([[cT * cI * cA - sT * sA, cT * cI * sA + sT * cA, -cT * sI],
                  [-sT * cI * cA - cT * sA, -sT * cI * sA + cT * cA, sT * sI],
                  [sI * cA, sI * sA, cI]])
    return np.einsum("ijn,j->ni", C, v)
