"""Pose lists of the calibration procedures (indicated turntable poses,
degrees, our convention) and the papers' check grids."""
from __future__ import annotations

import numpy as np

from .li2021 import POSITIONS


def _arr(poses):
    a = np.asarray(poses, float).reshape(-1, 3)
    return a[:, 0], a[:, 1], a[:, 2]


def li2021_twelve(repeat: int = 1):
    """Li 2021 Table 1, each position `repeat` times."""
    return _arr([POSITIONS[p] for p in range(1, 13) for _ in range(repeat)])


def ren2014(circle_step_deg: float = 30.0):
    """Ren 2014: the ten accelerometer positions (X_b, Y_b, Z_b down and up;
    gravity at (0, +-0.707, -0.707)... in Ren's words -- here the four 45 deg
    tilts about x and y) and the three circle rotations, body x, y, z
    pointing down, turned about the vertical every circle_step_deg."""
    p = [(90, 0, 180), (90, 0, 0), (90, 0, 90), (90, 0, 270), (0, 0, 0), (180, 0, 0),
         (45, 0, 90), (45, 0, 270), (45, 0, 0), (45, 0, 180)]
    steps = np.arange(0.0, 360.0, circle_step_deg)
    p += [(90, a, 180) for a in steps]  # x down
    p += [(90, a, 90) for a in steps]  # y down
    p += [(0, 0, t) for t in steps]  # z down (I = 0: toolface turns the probe about the vertical)
    return _arr(p)


def guo2009(d1: float = 30.0, azimuth: float = 2.0, step_deg: float = 30.0):
    """Guo 2009: toolface every step_deg at d1 and d1 + 90, one azimuth."""
    r = np.arange(0.0, 360.0, step_deg)
    return _arr([(d, azimuth, t) for d in (d1, d1 + 90.0) for t in r])


def multi_position(n: int = 60, seed: int = 0):
    """Quasi-uniform orientations over the sphere (Fibonacci sphere of the
    tool axis, toolface golden-angle steps): the joint method's own run."""
    k = np.arange(n) + 0.5
    inc = np.degrees(np.arccos(1 - 2 * k / n))
    azi = np.mod(k * 137.50776405, 360.0)
    tf = np.mod(k * 222.49223595 + 17.0, 360.0)
    return inc, azi, tf


def union(*runs):
    return tuple(np.concatenate([r[k] for r in runs]) for k in range(3))


def li2021_grid(toolfaces=(0.0,)):
    """Li 2021 Table 4/5 check grid: inclinations 2, 5, 10, 20, ..., 90 deg,
    azimuths 0-300 deg every 60 deg, at each toolface given."""
    inc = [2.0, 5.0, 10.0, 20.0, 30.0, 40.0, 50.0, 60.0, 70.0, 80.0, 90.0]
    azi = np.arange(0.0, 360.0, 60.0)
    I, A, T = np.meshgrid(inc, azi, np.asarray(toolfaces, float), indexing="ij")
    return I.ravel(), A.ravel(), T.ravel()
