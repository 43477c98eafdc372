"""The posed diagnosis' F-test under heavy-tailed noise (diagnose.tails),
and the emulated turntable error at a vertical pose (model.world.pose_in_range).

A candidate whose signature rests on a few rows, under Student-t noise
(3 degrees of freedom), is named far more often than the test's alpha by
the F-test alone; with the kurtosis gate and the sandwich test it is named
at about alpha (switched off, the check fails).  On Gaussian noise the gate
seldom fires and the F-test stands as it was."""
import numpy as np

from inclino.diagnose import plans, tails
from inclino.diagnose.core import Design, make_folds
from inclino.engines import reference as ref
from inclino.model.world import pose_in_range

N = 150
ALPHA = 1e-3
DRAWS = 3000


def _design(rng, dist, beta=0.0, n=N):
    """Two channels: an intercept per channel as the model's base; the
    candidate x rests on two rows of channel 0 (a reading at the far end of
    the range), a trace elsewhere; unit-variance noise, Gaussian or
    Student-t (3 dof)."""
    if dist == "t":
        e = rng.standard_t(3, (n, 2)) / np.sqrt(3.0)
    else:
        e = rng.normal(size=(n, 2))
    x = np.zeros((n, 2))
    x[:, 0] = 0.02 * rng.normal(size=n)
    x[rng.choice(n, 2, replace=False), 0] = 1.0
    y = beta * x + e
    X = np.zeros((n, 2, 3))
    X[:, 0, 0] = 1.0
    X[:, 1, 1] = 1.0
    X[:, :, 2] = x
    des = Design(y, X, np.broadcast_to(np.eye(2), (n, 2, 2)).copy(), make_folds(n, 5), 5)
    des.tails = True
    return des


def _plain_p(des):
    des.tails = False
    try:
        return des.ftest([0, 1], [2])[0]
    finally:
        des.tails = True


def test_heavy_tails_on_a_few_rows_are_not_named_beyond_alpha():
    rng = np.random.default_rng(20261127)
    plain = robust = gated = 0
    for _ in range(DRAWS):
        des = _design(rng, "t")
        plain += _plain_p(des) < ALPHA
        robust += des.ftest([0, 1], [2])[0] < ALPHA
        gated += des.tail_gate([0, 1])["gated"]
    # the F-test alone: ~10 x alpha (one t3 error beyond 5.7 sigma at one of two rows); a calibrated
    # test names ALPHA * DRAWS = 3 on average, 9 or more with p < 0.004
    assert plain >= 5 * ALPHA * DRAWS, plain
    assert robust < 3 * ALPHA * DRAWS, (robust, plain)
    assert gated > 0.5 * DRAWS  # 150 rows of t3 noise mostly show their tails


def test_gaussian_noise_keeps_the_f_test():
    rng = np.random.default_rng(7)
    gated = same = 0
    draws = 300
    for _ in range(draws):
        des = _design(rng, "gauss")
        p = des.ftest([0, 1], [2])[0]
        g = des.tail_gate([0, 1])["gated"]
        gated += g
        same += (not g) and p == _plain_p(des)
    # the gate's false rate is GATE_P over the channels: 300 draws gate at most 3 times except with p ~ 1e-3
    assert gated <= 3
    assert same == draws - gated


def test_sandwich_finds_an_effect_spread_over_many_rows():
    """Power where the signature does not rest on a few rows: a z = 6
    effect spread over every row is found by the sandwich test too."""
    rng = np.random.default_rng(11)
    n = 400
    hits = 0
    for _ in range(50):
        e = rng.standard_t(3, (n, 1)) / np.sqrt(3.0)
        x = rng.normal(size=(n, 1))
        x /= np.linalg.norm(x)
        X = np.stack([np.ones((n, 1)), x], -1)
        des = Design(6.0 * x + e, X, np.ones((n, 1, 1)), make_folds(n, 5), 5)
        r = tails.sandwich(des, [0], [1])
        assert r["nu"] > n / 4  # Gaussian x: (sum x^2)^2 / sum x^4 ~ n / 3
        hits += r["p"] < ALPHA
    assert hits >= 45


def test_turntable_error_at_a_vertical_pose_is_a_tilt_in_any_direction():
    """The emulated probe at indicated inclination 0 sits at the indicated
    pose plus a readout error that tilts it either way (an inclination past
    0 is written as -inc with azimuth and toolface turned by 180 deg): the
    accelerometer's mean reading over many vertical readings is the
    error-free one, within its standard error.  Clipped at 0, the error was
    a mean tilt of 0.4 sigma toward the indicated azimuth (14 standard
    errors here)."""
    n = 400
    plan = {"kind": "static", "inc": np.zeros(n), "azi": np.zeros(n), "tf": np.zeros(n),
            "t_s": np.arange(n) * 60.0, "temp_c": np.full(n, 25.0)}
    d0 = plans.generate(plans.PROBE, plan, seed=3, sigma_pose_deg=0.0, noise=False)
    d1 = plans.generate(plans.PROBE, plan, seed=3, sigma_pose_deg=plans.TURNTABLE_SIGMA_DEG, noise=False)
    diff = d1.acc - d0.acc
    se = diff.std(0, ddof=1) / np.sqrt(n)
    assert np.all(np.abs(diff.mean(0)) < 4 * se[:] + 1e-12), (diff.mean(0), se)
    # and the same orientation as the unwrapped pose, inside the turntable's range
    rng = np.random.default_rng(5)
    inc = np.concatenate([rng.normal(0, 0.1, 50), 180 + rng.normal(0, 0.1, 50)])
    azi, tf = rng.uniform(0, 360, 100), rng.uniform(0, 360, 100)
    i2, a2, t2 = pose_in_range(inc, azi, tf)
    assert np.all((i2 >= 0) & (i2 <= 180))
    assert np.allclose(ref.pose_matrix(i2, a2, t2), ref.pose_matrix(inc, azi, tf), atol=1e-12)
