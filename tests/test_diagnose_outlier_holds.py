"""Which holds the pose-free baseline sets aside must not follow a small
effect in the readings.

The logs are drawn here with scipy's rotations: an accelerometer (scale and
cross-axis errors, offsets, 2 mg white noise) held at 40 random
orientations for 60 rows each, turned between them in 15 rows, a
temperature that goes once up and down over the run; one of the stops is 16
rows long and still settling (a swing of 6 mg decaying over 6 rows, as a
hand or a motor that has just stopped).  Its mean is a few mg off, and its
own rows say so: their scatter leaves that mean as uncertain as its residual.
Judged against the holds' common spread alone it sat at the chi-square
point, and whether it was set aside followed the median residual, which a
temperature bias a quarter of a milligram across the run moves."""
import numpy as np
import pytest
from scipy.spatial.transform import Rotation as Rot, Slerp

from inclino import holds
from inclino.diagnose import posefree
from inclino.formats.dataset import RawDataset

SEEDS = range(12)
SIZES = (0.0, 0.25e-4, 0.5e-4, 1e-4)  # g/degC on x: up to +-0.5 mg over the run's +-5 degC


def _log(seed, settle_mg=6.0, quiet_offset_mg=0.0):
    """(acc, t, temp, (first, end) of the short stop)."""
    rng = np.random.default_rng(seed)
    n_holds, hold_rows, move_rows = 40, 60, 15
    keys = Rot.random(n_holds, random_state=rng)
    R, stop = [], None
    for k in range(n_holds):
        rows = 16 if k == n_holds // 2 else hold_rows
        if rows == 16:
            stop = (len(R), len(R) + 16)
        R += [keys[k]] * rows
        if k + 1 < n_holds:
            x = 0.5 - 0.5 * np.cos(np.pi * np.linspace(0, 1, move_rows + 2)[1:-1])
            R += list(Slerp([0, 1], Rot.concatenate([keys[k], keys[k + 1]]))(x))
    R = Rot.concatenate(R)
    n = len(R)
    M = np.eye(3) + np.diag(rng.normal(0, 0.02, 3)) + rng.normal(0, 0.01, (3, 3)) * (1 - np.eye(3))
    acc = R.inv().apply([0.0, 0.0, 1.0]) @ M.T + rng.normal(0, 0.03, 3) + rng.normal(0, 2e-3, (n, 3))
    a, b = stop
    u = rng.normal(size=3)
    u /= np.linalg.norm(u)
    acc[a:b] += 1e-3 * settle_mg * np.exp(-np.arange(b - a) / 6.0)[:, None] * u
    g = acc[a:b].mean(0)
    acc[a:b] += 1e-3 * quiet_offset_mg * g / np.linalg.norm(g)  # along gravity: all of it on |g|
    t = np.arange(n) / 100.0
    temp = 25.0 + 5.0 * np.sin(2 * np.pi * t / t[-1])
    return acc, t, temp, stop


def _with_bias(acc, t, temp, c):
    a = acc.copy()
    a[:, 0] += c * (temp - temp.mean())
    return RawDataset(columns={"t_s": t, "temp_c": temp, **{f"a{q}_g": a[:, k] for k, q in enumerate("xyz")}},
                      meta={})


@pytest.fixture
def set_aside(monkeypatch):
    """A function: the first row of each hold the baseline of
    diagnose_posefree(ds) sets aside (the rows of the last design built)."""
    seen = []

    class Spy(posefree.Design):
        def __init__(self, *a, rows=None, **k):
            super().__init__(*a, rows=rows, **k)
            seen.append(np.asarray(rows))
    monkeypatch.setattr(posefree, "Design", Spy)

    def run(ds):
        seen.clear()
        posefree.diagnose_posefree(ds)
        h = holds.find(ds)
        kept = seen[-1]
        assert len(kept) == h.count  # the holds are the poses
        return tuple(int(np.flatnonzero(h.labels == j)[0]) for j in np.flatnonzero(~kept))
    return run


def test_settling_stop_decision_does_not_follow_a_small_effect(set_aside):
    """For each drawn log the holds set aside are the same at every size of
    the temperature bias.  Before each pose was judged against its own noise
    too, 2 of these 12 logs flipped (seed 2: the stop out at 0-0.5e-4 and in
    at 1e-4; seed 8: out, out, in, out)."""
    flips = {}
    for seed in SEEDS:
        acc, t, temp, stop = _log(seed)
        out = [set_aside(_with_bias(acc, t, temp, c)) for c in SIZES]
        if len(set(out)) > 1:
            flips[seed] = out
    assert not flips


def test_a_stop_off_beyond_its_own_noise_is_still_set_aside(set_aside):
    """The rule still sets aside what its own rows do not explain: the same
    settling stop read 20 mg high on |g| (a knock, a stop against the rig)
    is set aside at every size (its own noise is about 0.7 mg)."""
    for seed in (2, 8):
        acc, t, temp, (a, b) = _log(seed, quiet_offset_mg=20.0)
        for c in SIZES:
            out = set_aside(_with_bias(acc, t, temp, c))
            assert any(abs(r - a) <= 2 for r in out), (seed, c, out)
