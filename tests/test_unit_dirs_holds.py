"""The checks' first look at a step-and-hold log whose rows between the
holds carry a hand's acceleration: the ellipsoid through every row can be
wrong (an MPU-9250 accelerometer 0.65 g off: offsets read (0.70, -0.09,
-0.28) g where its holds give (-0.01, -0.42, -0.50)), and the dip then
spread 24 deg whatever the axis map; the holds' ellipsoid stands in where
the every-row fit misfits the holds' own rows 3x more."""
import numpy as np
from scipy.spatial.transform import Rotation, Slerp

from inclino import checks


def _log(seed=4, offset=(-0.01, -0.42, -0.5), hand=0.3):
    """(raw accelerometer rows, true directions, rows at rest): 30 holds of 40 rows, 60 rows moving between
    them with `hand` g of acceleration."""
    rng = np.random.default_rng(seed)
    R = Rotation.random(30, random_state=seed)
    g, still, prev = [], [], R[0]
    for k in range(30):
        sl = Slerp([0, 1], Rotation.concatenate([prev, R[k]]))(np.linspace(0, 1, 62)[1:-1])
        g.append(sl.as_matrix()[:, 2, :])  # body <- world is the transpose: its third column is row 2 here
        still.append(np.zeros(60, bool))
        g.append(np.repeat(R[k].as_matrix()[2][None, :], 40, axis=0))
        still.append(np.ones(40, bool))
        prev = R[k]
    g, still = np.concatenate(g), np.concatenate(still)
    noise = np.where(still[:, None], 1e-3, hand) * rng.normal(size=g.shape)
    return g + noise + np.array(offset), g, still


def _worst_deg(u, g, still):
    return float(np.degrees(np.arccos(np.clip(np.median((u[still] * g[still]).sum(1)), -1, 1))))


def test_the_holds_ellipsoid_stands_in_for_a_wrong_fit_of_every_row():
    raw, g, still = _log()
    u_all, ok_all = checks._unit_dirs(raw, 1.0)
    u_held, ok_held = checks._unit_dirs(raw, 1.0, lambda: still)
    assert ok_held and _worst_deg(u_held, g, still) < 1.0
    assert _worst_deg(u_all, g, still) > 5.0


def test_a_good_fit_of_every_row_is_kept():
    raw, g, still = _log(offset=(0.01, -0.02, 0.015), hand=0.02)
    u0, _ = checks._unit_dirs(raw, 1.0)
    u1, _ = checks._unit_dirs(raw, 1.0, lambda: still)
    assert np.array_equal(u0, u1)
