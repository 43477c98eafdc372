"""Diagnose at the magnitudes real data have: strong effects (no 'singular'
refusal, the right name, the estimate within 2 stderr or 10 %), spiked
rows (listed, neither inflating the noise nor masking an effect), and the
shared best-subset selection's closed forms against direct refits.

The regression datasets are the ones that used to fail (exit 2 'singular
fit' on strong effects; a masked effect behind two spiked rows); the strong
hidden-effect tests draw sensor, axis, sign and size at test time."""
import copy
import json

import numpy as np
import pytest
from conftest import test_seed

from inclino.cli import main
from inclino.formats.dataset import write_raw
from inclino.benchmarks import diagnose as bench
from inclino.diagnose import core, plans, robust, selection
from inclino.diagnose.analysis import diagnose

RNG_SEED = SEED0 = test_seed() % 1_000_000_000  # INCLINO_TEST_SEED replays a run (conftest)


def _key(e):
    return (e.name, e.sensor, e.axis)


def _close(est, se, truth):
    return abs(est - truth) <= 2.0 * se or abs(est - truth) <= 0.1 * abs(truth)


def _close_drawn(est, se, truth):
    """For effects drawn afresh at every run: 4 standard errors or 20 %,
    the hidden-effect tests' 4 SE.  The stated errors hold (error/SE over
    40 strong draws each: standard deviation 0.84 for the turntable
    azimuth offset, 1.02 for the inclination offset, 1.00 for a field
    drift), so a tolerance of k SE fails by chance at the normal tail: at
    3 SE 0.27 % per draw, about one suite run in 40 with ten effects per
    run (seed 601604: an azimuth offset 3.1 SE and 20.1 % off, on the
    code before and after the turntable gain change); at 4 SE one in
    1600.  At the issue's 2 SE or 10 % about 2 % of random strong draws
    miss (5 of 210 in two sweeps, 9-15 % off at 2-3.6 SE); the bench's
    strong section reports the rate at that tolerance."""
    return abs(est - truth) <= 4.0 * se or abs(est - truth) <= 0.2 * abs(truth)


def test_strong_turntable_and_drift_effects_regression(tmp_path, capsys):
    """Turntable azimuth offset 0.7 deg and inclination offset 0.3 deg, field
    drift 680 nT over the run, on the oven plan: once 'poses cannot separate
    the baseline's 12 parameters (singular fit)', exit 2, from both diagnose
    and calibrate.  Now every effect is named and estimated, and calibrate
    gives a fit with a verdict."""
    p = copy.deepcopy(plans.PROBE)
    p["world"]["encoder"] = {"offset_deg": [0.3, 0.7, 0.0]}
    plan = plans.oven_plan(seed=21)
    rate = 680.0 / float(np.ptp(plan["t_s"]))
    p["world"]["field_drift"] = {"rate_nT_per_s": rate}
    ds = plans.generate(p, plan, 21)
    r = diagnose(ds)
    got = {_key(e): e for e in r.effects}
    for key, truth in ((("turntable-azimuth-offset", "turntable", "azi"), 0.7),
                       (("turntable-inclination-offset", "turntable", "inc"), 0.3),
                       (("field-drift", "field", "total"), rate)):
        assert key in got, (key, list(got))
        assert _close(got[key].estimate, got[key].stderr, truth), (key, got[key].estimate, got[key].stderr)
    path = str(tmp_path / "strong.csv")
    write_raw(path, ds)
    rc = main(["calibrate", path, "--method", "joint", "-o", str(tmp_path / "cal.json")])
    out, err = capsys.readouterr()
    rep = json.loads((tmp_path / "cal.json").read_text())["report"]
    assert rc == (0 if rep["passed"] else 1) and "verdict:" in out and "singular" not in err, (rc, out, err)
    # the fit is written with a failed verdict: joint has no turntable offset, so the 0.3 deg
    # inclination offset stays in its inclination residual (0.28 deg RMS against the 0.1 limit)
    assert rc == 1 and any(r.startswith("inclination residual RMS") for r in rep["reasons"]), rep["reasons"]


def test_strong_sample_skew_regression():
    """A fluxgate read 30 ms after the accelerometer on the rotation run that
    turns both ways at 45 and 90 deg/s (a 2.7 deg pose error at 90 deg/s)."""
    r = diagnose(plans.generate(plans.hide(plans.PROBE, "sample-skew", "mag", "xyz", 0.03), plans.rotation_plan(), 22))
    (e,) = [e for e in r.effects if e.name == "sample-skew"]
    assert _close(e.estimate, e.stderr, 0.03), (e.estimate, e.stderr)


def test_spiked_rows_regression(tmp_path, capsys):
    """Two rows spiked by 5 mg on one accelerometer channel (1 % of the
    run) and a temperature bias at z = 10 on the same channel: the effect is
    named, the two rows are listed with their channel in the JSON and the
    text, and the channel's noise is not inflated."""
    plan = plans.oven_plan(seed=23)
    cand = core.Candidate("temperature-bias", "acc", "x", "g/degC")
    value = 10.0 / plans.signature_z(plans.PROBE, plan, cand)
    ds = plans.generate(plans.hide(plans.PROBE, "temperature-bias", "acc", "x", value), plan, 23)
    rows = [57, 201]
    col = np.asarray(ds.columns["ax_g"], float).copy()
    col[rows] += 5e-3
    ds.columns["ax_g"] = col
    path = str(tmp_path / "spiked.csv")
    write_raw(path, ds)
    assert main(["diagnose", path, "--json"]) == 0
    d = json.loads(capsys.readouterr().out)
    named = [(e["name"], e["sensor"], e["axis"]) for e in d["effects"]]
    assert ("temperature-bias", "acc", "x") in named
    e = next(e for e in d["effects"] if e["name"] == "temperature-bias")
    assert abs(e["estimate"] - value) <= 3 * e["stderr"]
    listed = {o["row"]: o for o in d["baseline"]["outliers"]["rows"]}
    assert set(rows) <= set(listed)
    for r in rows:
        assert listed[r]["channel"] == "acc_x" and listed[r]["sigma"] > 4.0
    assert d["baseline"]["selection"]["final_noise"]["acc_g"][0] < 1.5 * plans.ACC_SIGMA_G
    assert main(["diagnose", path]) == 0
    text = capsys.readouterr().out
    assert "outlier rows set aside" in text and "row 57: acc_x" in text and "row 201: acc_x" in text


@pytest.mark.parametrize("effect", core.EFFECT_NAMES)
def test_strong_hidden_effect_named_and_estimated(effect):
    """One effect at a random sensor, axis, sign and size between z = 10 and
    the strong magnitude of the issue (turntable 2 deg, drift 2000 nT over
    the run, 50 ug/degC, 5 nT/degC, 2000 ppm/degC, 1 % nonlinearity, 50 ms
    skew, a rig field of 500 nT RMS beyond what the baseline absorbs),
    log-uniform, drawn at test time; every other run with 1 % spiked rows."""
    _strong_case(effect, SEED0 + core.EFFECT_NAMES.index(effect))


def test_strong_declination_drift_regression():
    """The draw of the test above that missed a declination drift at z = 98
    on the oven plan with spiked rows (seed 807750035): the diagnosis took
    the drift's gain on the sensor part, which removes it as readout error."""
    _strong_case("field-drift", 807750035)


def _strong_case(effect, seed):
    rng = np.random.default_rng([seed, 3])
    kinds = bench.EFFECT_PLANS[effect]
    kind = kinds[int(rng.integers(len(kinds)))]
    plan = plans.oven_plan(seed=seed) if kind == "static" else plans.rotation_plan()
    cand = bench._pick(effect, rng)
    # a rig field: a random one, scaled so that its size is what the baseline cannot absorb (what is reported)
    pattern = plans.unit_rig_pattern(plans.PROBE, plan, cand.axis, rng) if effect == "rig-field" else None
    zu = plans.signature_z(plans.PROBE, plan, cand, pattern=pattern)
    big = bench.strong_value(cand, plan)
    lo = min(10.0 / zu, big)
    size = float(np.exp(rng.uniform(np.log(lo), np.log(big))))
    value = size * (1.0 if rng.random() < 0.5 or pattern is not None else -1.0)
    ds = plans.generate(plans.hide(plans.PROBE, cand.name, cand.sensor, cand.axis, value, pattern=pattern), plan, seed)
    if seed % 2:
        plans.add_outlier_rows(ds, np.random.default_rng([seed, 98]), 0.01)
    r = diagnose(ds)
    got = {_key(e): e for e in r.effects}
    key = (cand.name, cand.sensor, cand.axis)
    if effect == "rig-field" and key not in got:
        # two turntable axes' fields overlap 0.85-0.98 on these plans: near z = 10 the other axis' field is
        # kept in ~3 % of draws, and the report must then say the run cannot tell them apart
        assert any(c["named"] and c["with"] == cand.key for c in r.confounded), (seed, key, value, list(got))
        return
    assert key in got, (seed, key, value, list(got))
    assert _close_drawn(got[key].estimate, got[key].stderr, value), (seed, key, value, got[key].estimate,
                                                                      got[key].stderr)


# --------------------------------------------------------------------------
# the shared selection: closed forms against direct computation
def _problem(seed, n=40, p=6, groups=True):
    rng = np.random.default_rng(seed)
    X = rng.normal(size=(n, p))
    beta = np.zeros(p)
    beta[[1, 4]] = [1.5, -2.0]
    y = X @ beta + 0.5 * rng.normal(size=n)
    w = rng.uniform(0.5, 2.0, n)
    return selection.Problem(X, y, w, [f"t{j}" for j in range(p)], np.arange(n) % 5 if groups else None)


def test_loo_closed_form_equals_refits():
    pb = _problem(1)
    S = [1, 3, 4]
    loo = selection.loo_cv(pb, S)
    for i in range(len(pb.y)):
        m = np.ones(len(pb.y), bool)
        m[i] = False
        beta, _, _ = selection.fit(pb.subset(m), S)
        assert loo[i] == pytest.approx(pb.y[i] - pb.X[i, S] @ beta, abs=1e-9)


def test_fast_nested_loo_equals_the_direct_nested_loo():
    """The leave-two-out formula against running the whole search n times."""
    pb = _problem(2, n=30, p=5)
    direct, chosen = selection.nested(pb, list(range(5)), 4, "one")
    fast, chosen_fast = selection.nested_loo_all(pb, list(range(5)), 4)(list(range(5)))
    np.testing.assert_allclose(fast, direct, atol=1e-9)
    assert chosen == chosen_fast


def test_best_subset_finds_the_true_terms_and_the_drop_test_asks_for_them():
    pb = _problem(3, n=60, p=6)
    s = selection.select(pb, max_terms=4)
    assert set(s.chosen) == {"t1", "t4"}
    assert all(t["asked_for_by_the_data"] for t in s.drop_tests)
    assert s.nested_group_rms is not None and s.nested_loo_rms < float(np.sqrt(np.mean(pb.y ** 2)))


# --------------------------------------------------------------------------
# clean data: the outlier rule's false alarms
def test_clean_data_give_no_outliers_at_the_stated_rate():
    """The outlier rule on Gaussian rows drawn from the noise model itself
    (sensor noise plus the turntable readout error through a pose Jacobian):
    robust.py states that a dataset has any row flagged with probability
    about OUTLIER_P (the Bonferroni bound: each row at OUTLIER_P / n).  Over
    N clean datasets the count of datasets with a flagged row is then
    Binomial(N, OUTLIER_P); the allowed count is its 1e-6 upper quantile.
    A rule without the division by n flags a row in 1 - (1 - 1e-3)^n of the
    datasets (a quarter at n = 288, the oven plan's rows)."""
    from scipy import stats

    from inclino.diagnose import noise as dnoise

    rng = np.random.default_rng(20260)
    n_sets, n = 400, 288
    J = rng.normal(size=(n, 6, 3)) * np.array([2e-3] * 3 + [800.0] * 3)[None, :, None]  # per degree
    nz = dnoise.Noise(np.array([1.5e-4] * 3 + [5.0] * 3), np.array([0.05, 0.05, 0.05]))
    L = np.linalg.cholesky(nz.row_cov(J))
    flagged_sets = flagged_rows = 0
    for _ in range(n_sets):
        R = (L @ rng.standard_normal((n, 6, 1)))[..., 0]
        out, z = robust.outlier_mask(R, nz, J)
        flagged_sets += bool(out.any())
        flagged_rows += int(out.sum())
    allowed = int(stats.binom.isf(1e-6, n_sets, robust.OUTLIER_P))
    assert flagged_sets <= allowed, (flagged_sets, flagged_rows, allowed)


def test_mad_start_is_the_standard_deviation_and_ignores_spikes():
    """robust.mad_sigma: 1.4826 x the median absolute deviation about each
    column's median is the standard deviation of Gaussian data (the factor
    is 1 / Phi^-1(3/4)), whatever the column's offset and scale, and 1 %
    of rows spiked by 1000 sigma move it by less than 2 %."""
    rng = np.random.default_rng(7)
    sd = np.array([1.5e-4, 2e-4, 1e-4, 5.0, 3.0, 8.0])
    R = rng.normal(size=(20000, 6)) * sd + np.array([0.3, -1.0, 1e-3, 48000.0, -200.0, 7.0])
    assert 1.4826 == pytest.approx(1 / __import__("scipy").stats.norm.ppf(0.75), rel=1e-4)
    np.testing.assert_allclose(robust.mad_sigma(R), sd, rtol=0.03)
    spiked = R.copy()
    spiked[rng.choice(len(R), 200, replace=False)] += 1000 * sd
    np.testing.assert_allclose(robust.mad_sigma(spiked), robust.mad_sigma(R), rtol=0.02)


def test_outlier_mask_keeps_only_the_worst_fifth():
    """More than MAX_OUTLIER_FRACTION of the rows beyond the threshold is
    heavy-tailed noise, not outliers: only the worst fifth (by whitened
    norm) are set aside, the rest kept."""
    from inclino.diagnose import noise as dnoise

    rng = np.random.default_rng(8)
    n = 200
    J = np.zeros((n, 6, 3))
    nz = dnoise.Noise(np.ones(6), np.full(3, 1e-6))
    R = rng.normal(size=(n, 6))
    big = rng.choice(n, 80, replace=False)  # 40 % far out, each by a different amount
    R[big] += np.linspace(20, 400, 80)[:, None]
    out, z = robust.outlier_mask(R, nz, J)
    k = int(robust.MAX_OUTLIER_FRACTION * n)
    assert out.sum() == k
    worst = big[np.argsort(np.linspace(20, 400, 80))[::-1][:k]]
    assert set(np.flatnonzero(out)) == set(worst)
    np.testing.assert_allclose(z, R, atol=1e-9)  # z: each channel in its own sigma (1 here)
