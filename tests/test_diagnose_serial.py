"""The F-test's correction for serially correlated rows (diagnose.serial):
on independent rows it changes nothing; on rows with AR(1) errors it
estimates the Bartlett inflation the errors' and the regressor's
autocorrelations give, and a candidate the data do not hold is named at
about the test's alpha, where the uncorrected test names it many times
over (so the check can fail: switched off, it does)."""
import numpy as np

from inclino.diagnose import serial
from inclino.diagnose.core import Design, make_folds

N = 2000


def _design(rng, phi, beta=0.0, n=N):
    """One channel: y = beta x + e, e AR(1) with coefficient phi and unit
    variance; the model's base an intercept, the candidate x a slow sweep
    (three cycles over the run, with a random phase)."""
    w = rng.normal(size=n)
    e = np.empty(n)
    e[0] = w[0]
    for i in range(1, n):
        e[i] = phi * e[i - 1] + np.sqrt(1 - phi ** 2) * w[i]
    t = np.arange(n) / n
    x = np.sin(2 * np.pi * 3 * t + rng.uniform(0, 2 * np.pi))
    y = (beta * x + e)[:, None]
    X = np.stack([np.ones(n), x], -1)[:, None, :]
    des = Design(y, X, np.ones((n, 1, 1)), make_folds(n, 5), 5)
    des.serial = True
    return des, x


def _bartlett_truth(x, phi, L):
    """1 + 2 sum_k phi^k rho_x(k) over L lags under the same taper, from the
    known error model (the estimate uses the residuals' sample ACF)."""
    xc = x - x.mean()
    g0 = xc @ xc
    k = np.arange(1, L + 1)
    rx = np.array([xc[:-j] @ xc[j:] for j in k]) / g0
    return 1.0 + 2.0 * np.sum((1 - k / (L + 1.0)) * phi ** k * rx)


def test_independent_rows_are_left_alone(rng):
    gated = 0
    for _ in range(20):
        des, _ = _design(rng, 0.0)
        r = serial.factor(des, [0], [1])
        gated += r["gated"]
        if not r["gated"]:
            assert r["f"] == 1.0
            assert des.ftest([0], [1]) == _uncorrected_ftest(des)
    # the gate's false rate is GATE_P per channel: 20 draws gate at most twice except with p ~ 1e-6
    assert gated <= 2


def _uncorrected_ftest(des):
    des.serial = False
    try:
        return des.ftest([0], [1])
    finally:
        des.serial = True


def test_ar1_rows_give_the_bartlett_factor(rng):
    phi = 0.7
    est, truth = [], []
    for _ in range(10):
        des, x = _design(rng, phi)
        r = serial.factor(des, [0], [1])
        assert r["gated"]
        est.append(r["f"])
        truth.append(_bartlett_truth(x, phi, serial.max_lag(N)))
    # (1 + phi) / (1 - phi) = 5.67 for a regressor this smooth; the estimate from the residuals' ACF within
    # 25 % of it on average
    assert 4.5 < np.mean(truth) < 5.7
    assert 0.75 < np.mean(est) / np.mean(truth) < 1.25


def test_a_long_correlation_is_not_cut_short_by_the_window(rng):
    """AR(1) errors with phi 0.95 (a sensor's low-pass filter at a high
    rate) against a slow sweep: the factor over every lag is about 37; the
    residuals' ACF within max_lag (45) lags under the Bartlett taper alone
    gave 23 on average (10 draws), so the F-test kept 60 % too much.  The
    AR(p) model of the residual carries the correlation past the window."""
    phi = 0.95
    est, truth = [], []
    for _ in range(10):
        des, x = _design(rng, phi)
        est.append(serial.factor(des, [0], [1])["f"])
        xc = x - x.mean()
        k = np.arange(1, N)
        rx = np.correlate(xc, xc, "full")[N:] / (xc @ xc)
        truth.append(1.0 + 2.0 * np.sum(phi ** k * rx))
    assert 30.0 < np.mean(truth) < 39.0
    assert 0.85 < np.mean(est) / np.mean(truth) < 1.2, (np.mean(est), np.mean(truth))


def test_a_null_candidate_is_named_at_about_alpha_only_when_corrected(rng):
    alpha = 0.01
    hits, hits_raw = 0, 0
    draws = 200
    for _ in range(draws):
        des, _ = _design(rng, 0.7)
        hits += des.ftest([0], [1])[0] < alpha
        hits_raw += _uncorrected_ftest(des)[0] < alpha
    # corrected: near alpha (the factor's own sampling noise, SD ~0.8 on 5.3, makes it liberal: 2.75 % over
    # 400 draws); uncorrected: the rows count as 2000 independent ones where they are worth ~350, and a
    # smooth null regressor passes 26 % of the time.  Bounds at ~4 SD of the binomial
    assert hits <= 0.08 * draws
    assert hits_raw >= 0.15 * draws


def test_a_kept_effects_standard_error_grows_by_the_root_of_its_factor(rng):
    des, _ = _design(rng, 0.7, beta=0.5)
    cov = des.coef_cov([0, 1])
    plain = np.sqrt(cov[1, 1])
    f = serial.scale_cov(des, [0, 1], cov, [[1]])[0]
    assert f > 2.0
    assert np.isclose(np.sqrt(cov[1, 1]), plain * np.sqrt(f))
    assert np.isclose(np.sqrt(cov[0, 0]), np.sqrt(des.coef_cov([0, 1])[0, 0]))
