"""The papers' methods' reported uncertainty (calib/paper_bootstrap.py)
against the truth of simulated probes: the coefficients' errors in units of
their reported sigma, and the predicted azimuth accuracy against what the
calibration achieves on the noise-free Li grid.

The runs are the project's typical probe (linear, so that its truth is a
calibration) on the papers' own procedures, read through the emulator's
sensor models, with a turntable readout error drawn once per pose and shared
by every row read there, or with sensor noise four times the nominal the
bootstrap assumes.  Before the readings were turned by the pose error, the
bootstrap perturbed each row's pose columns and assumed the nominal noise:
z RMS 4.0-9.9 here, the prediction exceeded 1.9-4.2 times (pooled)."""
import numpy as np
import pytest

from inclino.benchmarks import calibration_runs as bench
from inclino.calib import common, fit, runs
from inclino.engines import reference as ref
from inclino.model import effects as fx
from inclino.model.scenario import generate_raw, load_scenario
from inclino.model.world import pose_in_range

SEEDS = range(10)


def _run(s, poses, seed, rows, sigma_pose):
    """Each indicated pose read `rows` times at one true pose: the indicated
    one turned by a readout error drawn once per pose (the rows share it)."""
    I, A, T = (np.asarray(p, float) for p in poses)
    rng = np.random.default_rng([seed, 11])
    true = pose_in_range(*(p + rng.normal(0.0, sigma_pose, len(p)) for p in (I, A, T)))
    rep = lambda v: np.repeat(np.asarray(v, float), rows)  # noqa: E731
    ds = generate_raw(s, *(rep(v) for v in true), seed=seed)
    ds.columns["inc_deg"], ds.columns["azi_deg"], ds.columns["tf_deg"] = rep(I), rep(A), rep(T)
    return ds


def _grid_azimuth_rms(s, cal):
    """The azimuth RMS the calibration achieves on the noise-free Li grid."""
    grid, ev = bench.grid_truth(s)
    a = ref.attitude(ref.correct(ev.acc, cal.acc_m, cal.acc_b), ref.correct(ev.mag, cal.mag_m, cal.mag_b))
    return float(np.sqrt(np.mean(ref.angle_diff(a["azi"], grid[1]) ** 2)))


@pytest.mark.parametrize("method, rows, sigma_pose, noise_x", [
    ("li2021", 1, 0.05, 1.0),   # z RMS 1.23, achieved / predicted 0.72 (before: 6.3, 1.9)
    ("li2021", 3, 0.05, 1.0),   # 1.22, 0.85 (before: 9.9, 4.0: the rows share the pose error)
    ("guo2009", 3, 0.05, 1.0),  # 1.23, 0.92 (before: 8.3, 2.5)
    ("li2021", 3, 0.0, 4.0),    # noise 4x the nominal, no pose error: 0.99, 1.02 (before: 4.0, 4.2)
])
def test_paper_sigmas_hold(method, rows, sigma_pose, noise_x):
    """Over ten runs the coefficients' errors against the truth have an RMS
    near 1 in units of the reported sigma (over 30 runs 1.07-1.12: the
    nominal 5 nT noise the bootstrap keeps as a floor takes a part of the
    residuals that this probe's 1 nT fluxgate leaves to the pose error), the
    predicted azimuth accuracy holds on the Li grid (achieved / predicted,
    pooled; over 30 runs 0.87-1.20), and no model misfit is claimed (both
    methods' model is the firmware's affine one)."""
    s = bench.bench_probe(linear=True)
    if noise_x != 1.0:
        s.acc.noise = fx.WhiteNoise(s.acc.noise.sigma * noise_x, s.acc.noise.n_ref)
        s.mag.noise = fx.WhiteNoise(np.full(3, common.SIGMA_MAG * noise_x))
    truth = common.cal_vector(bench.truth_calibration(s))
    poses = runs.li2021_twelve() if method == "li2021" else runs.guo2009()
    z, achieved, predicted = [], [], []
    for seed in SEEDS:
        cal, rep = fit(_run(s, poses, seed, rows, sigma_pose), method)
        u = rep.uncertainty
        assert "model_misfit" not in u, u["source"]
        sig = np.array([u["sigma"][k] for k in common.PARAM_NAMES])
        z.append((common.cal_vector(cal) - truth) / sig)
        achieved.append(_grid_azimuth_rms(s, cal))
        predicted.append(u["predicted_azi_rms_deg"])
    zr = float(np.sqrt(np.mean(np.square(z))))
    ratio = float(np.sqrt(np.mean(np.square(achieved)) / np.mean(np.square(predicted))))
    assert 0.6 < zr < 1.6, zr
    assert 0.4 < ratio < 1.4, (ratio, achieved, predicted)


def test_ren2014_outside_its_model_predicts_what_it_achieves():
    """Li 2021's probe (fluxgate cross-axis coupling 0.03-0.06, which Ren's
    non-tilted ellipsoid cannot hold) through Ren's procedure: the method
    leaves a few tenths of a degree of azimuth on the Li grid, far above what
    its noise explains.  The report names the magnetometer's misfit, predicts
    within 30 % of what is achieved (0.686-0.691 deg achieved, predicted to
    0.2 %: the misfit's own bias over the grid) and fails the verdict on it;
    before, it predicted 0.047 deg."""
    s = load_scenario("li2021")
    s.acc.noise = fx.WhiteNoise(np.full(3, common.SIGMA_ACC))  # the scenario's are none: the nominal
    s.mag.noise = fx.WhiteNoise(np.full(3, common.SIGMA_MAG))
    for seed in range(3):
        ds = generate_raw(s, *runs.ren2014(), seed=seed)
        cal, rep = fit(ds, "ren2014")
        u = rep.uncertainty
        assert u["model_misfit"]["triads"] == ["mag"], u["source"]
        achieved = _grid_azimuth_rms(s, cal)
        assert achieved > 0.1
        assert 0.7 < achieved / u["predicted_azi_rms_deg"] < 1.3, (achieved, u["predicted_azi_rms_deg"])
        assert "model misfit" in u["source"] and "mean square error" in u["source"]
        assert any("model misfits the magnetometer" in r for r in rep.reasons), rep.reasons
