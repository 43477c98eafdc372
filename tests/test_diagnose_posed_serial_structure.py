"""The posed structure test on a continuous run whose sensor filters its
noise (AR(1) errors from row to row, as a sensor's internal low-pass filter
read at 10-100 Hz makes): the run holds nothing beyond the 12-parameter
model, so the diagnosis names nothing and reports no structure; a
toolface that lags behind the table's motion (no library effect) is still
reported as structure.

Before, the posed structure test's Ljung-Box test read the sensor's own
correlated noise as structure no library effect explains on every such
run (16 of 16 at rho 0.5, 10 Hz; and at rho 0.95, 100 Hz).  The runs are
made here from docs/conventions.md alone (tests/indep.py), not with the
project's emulator."""
import numpy as np
import pytest

from indep import DIP_DEG, F_NT, ar1, body
from inclino.diagnose.analysis import diagnose
from inclino.formats.dataset import RawDataset

def _continuous_run(seed, rho=0.5, rate=45.0, hz=10.0, lag_s=0.0):
    """The toolface turned once each way at three inclinations and the azimuth
    at two, at rate deg/s, read at hz; a probe with scale, misalignment and
    offset errors; a 0.01 deg readout error per reading; AR(1) sensor noise
    (rho, 0.15 mg, 5 nT); the table's true pose lag_s behind the recorded one."""
    rng = np.random.default_rng(seed)
    segs = [("tf", 45, 30), ("tf", 90, 200), ("tf", 135, 30), ("azi", 60, 0), ("azi", 120, 0)]
    t0, parts = 0.0, []
    for what, inc, azi in segs:
        t0 += 3.0
        dur = 360.0 / rate
        for sgn in (1, -1):
            k = np.arange(1, int(dur * hz))
            ang = k / hz * rate if sgn > 0 else 360.0 - k / hz * rate
            turn = np.zeros((len(k), 3))
            turn[:, 2 if what == "tf" else 1] = sgn * rate
            A = np.full(len(k), float(azi)) if what == "tf" else azi + ang
            T = ang if what == "tf" else np.zeros(len(k))
            parts.append((t0 + k / hz, np.full(len(k), float(inc)), A, T, turn))
            t0 += dur
    t, I, A, T, turn = (np.concatenate(c) for c in zip(*parts))
    n = len(t)
    true = np.column_stack([I, A, T]) - turn * lag_s + rng.normal(0.0, 0.01, (n, 3))
    dip = np.radians(DIP_DEG)
    g = body(*true.T, np.array([0.0, 0.0, 1.0]))
    b = body(*true.T, F_NT * np.array([np.cos(dip), 0.0, np.sin(dip)]))

    def affine(scale, mis_deg):
        return np.eye(3) + np.diag(rng.normal(0, scale, 3)) + np.radians(rng.normal(0, mis_deg, (3, 3))) * (1 - np.eye(3))

    acc = g @ affine(0.005, 0.3).T + rng.normal(0, 0.01, 3) + ar1(rng, n, rho, 1.5e-4)
    mag = b @ affine(0.01, 0.5).T + rng.normal(0, 300.0, 3) + ar1(rng, n, rho, 5.0)
    cols = {"t_s": t, "inc_deg": I, "azi_deg": np.mod(A, 360.0), "tf_deg": np.mod(T, 360.0),
            "ax_g": acc[:, 0], "ay_g": acc[:, 1], "az_g": acc[:, 2],
            "mx_nT": mag[:, 0], "my_nT": mag[:, 1], "mz_nT": mag[:, 2]}
    return RawDataset(cols, {"field_nT": F_NT, "dip_deg": DIP_DEG, "declination_deg": 0.0})


@pytest.mark.parametrize("seed", [0, 1])
def test_a_sensor_that_filters_its_noise_is_no_structure(seed):
    r = diagnose(_continuous_run(seed))
    assert not r.effects, r.conclusion()
    assert not r.unexplained, r.structure["significant"]
    st = r.baseline["residual_study"]
    assert any(s["serially_correlated"] for s in st.values())


def test_a_toolface_lagging_the_motion_is_still_structure():
    # 10 ms behind at 45 deg/s: 0.45 deg each way of every turn, which no library effect models
    r = diagnose(_continuous_run(2, lag_s=0.01))
    assert r.unexplained, r.conclusion()
