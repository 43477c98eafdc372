"""What the checks cannot see on an accelerometer-only log, and a triad held
between its updates: each said in a note, not passed in silence."""
import numpy as np
from scipy.spatial.transform import Rotation

from inclino import checks
from inclino.formats.dataset import RawDataset


def _acc(sign=1.0, n=400, seed=1):
    rng = np.random.default_rng(seed)
    g = sign * Rotation.random(n, random_state=seed).as_matrix()[:, :, 2] + rng.normal(0, 1e-3, (n, 3))
    return {"ax_g": g[:, 0], "ay_g": g[:, 1], "az_g": g[:, 2]}


def _sign_notes(rep):
    return [f for f in rep.findings if f.check == "dip-sign"]


def test_an_accelerometer_only_log_says_its_gravity_sign_was_not_checked():
    for sign in (1.0, -1.0):  # the readings cannot tell the two apart: the same note either way
        rep = checks.run(RawDataset(_acc(sign), {}))
        notes = _sign_notes(rep)
        assert len(notes) == 1 and notes[0].level == "note"
        assert "gravity sign was not checked" in notes[0].message and "180 deg less" in notes[0].message


def test_with_poses_or_a_magnetometer_the_note_is_not_this_one():
    cols = _acc()
    n = len(cols["ax_g"])
    cols.update({"mx_nT": np.full(n, 2e4), "my_nT": np.full(n, 1e4), "mz_nT": np.full(n, 4e4)})
    rep = checks.run(RawDataset(cols, {}))
    assert not any("without poses or a magnetometer" in f.message for f in _sign_notes(rep))


def test_a_held_magnetometer_is_named_not_called_noisy():
    rng = np.random.default_rng(2)
    n = 1200
    C = Rotation.from_rotvec(np.cumsum(rng.normal(0, 0.05, (n, 3)), axis=0)).as_matrix()
    g = C[:, 2, :] + rng.normal(0, 1e-3, (n, 3))
    b = C @ np.array([2e4, 0.0, 4.5e4])
    b = b[(np.arange(n) // 4) * 4]  # a new magnetometer reading every 4 rows
    cols = {"ax_g": g[:, 0], "ay_g": g[:, 1], "az_g": g[:, 2], "mx_nT": b[:, 0], "my_nT": b[:, 1], "mz_nT": b[:, 2]}
    rep = checks.run(RawDataset(cols, {}))
    motion = [f.message for f in rep.findings if f.check == "motion"]
    assert motion and "magnetometer repeats the row before on 75 % of rows" in motion[0]
    assert "magnetometer 0 nT" not in motion[0]
