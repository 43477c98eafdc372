"""Each calibration method recovers a known truth from emulated data
(inclino_emu scenarios; the truth is the scenario's own coefficients)."""
import copy

import numpy as np
import pytest

from inclino.engines import reference as ref
from inclino.benchmarks import calibration as bench
from inclino.calib import common, fit, guo2009, joint, li2021, ren2014, runs
from inclino.errors import CalibrationError, DataError
from inclino.model.scenario import generate_raw, load_scenario, scenario_from_dict


def truth_of(s):
    return bench.truth_calibration(s)


def grid_errors(cal, s):
    grid, ev = bench.grid_truth(s)
    return bench._errors(cal, grid, ev)


def test_li2021_fit_returns_table2_from_the_li2021_probe():
    """The li2021 scenario is built from Li's Table 2; the twelve-position
    closed form on its (noise-free, quantised) readings must give Table 2
    back: K and e to 1e-4, B to a count."""
    s = load_scenario("li2021")
    ds = generate_raw(s, *runs.li2021_twelve())
    cal, info = li2021.fit(ds)
    got = info["paper_parameters"]
    for kind, lsb in (("acc", ref.ACC_LSB_G), ("mag", ref.MAG_LSB_NT)):
        t2 = li2021.TABLE2[kind]
        np.testing.assert_allclose(got[kind]["K"], t2["K"], atol=1e-4)
        np.testing.assert_allclose(got[kind]["e"], t2["e"], atol=1e-4)
        np.testing.assert_allclose(np.array(got[kind]["B"]) / lsb, t2["B"], atol=1.0)
    t = truth_of(s)
    np.testing.assert_allclose(cal.mag_m, t.mag_m, atol=1e-4)
    np.testing.assert_allclose(cal.acc_m, t.acc_m, atol=1e-4)


def test_li2021_needs_all_twelve_positions():
    s = load_scenario("li2021")
    I, A, T = runs.li2021_twelve()
    ds = generate_raw(s, I[:11], A[:11], T[:11])
    with pytest.raises(DataError, match="missing position"):
        li2021.fit(ds)


def test_guo2009_recovers_the_li2021_probe():
    s = load_scenario("li2021")
    cal, info = guo2009.fit(generate_raw(s, *runs.guo2009()))
    t = truth_of(s)
    np.testing.assert_allclose(cal.acc_m, t.acc_m, atol=2e-4)
    np.testing.assert_allclose(cal.mag_m, t.mag_m, atol=2e-4)
    np.testing.assert_allclose(cal.acc_b, t.acc_b, atol=2e-4)  # g
    np.testing.assert_allclose(cal.mag_b, t.mag_b, atol=5.0)  # nT
    assert abs(info["paper_parameters"]["d1_deg"] - 30.0) < 0.01
    da, di = grid_errors(cal, s)
    assert np.abs(da).max() < 0.1 and np.abs(di).max() < 0.01


def _ren_probe():
    """A probe inside Ren's model: the fluxgate's misalignment is a pure
    rotation (non-tilted ellipsoid), plus scale, offset and hard iron; the
    accelerometer has a general affine error."""
    R = ref.rz(2.0) @ ref.ry(-1.5) @ ref.rz(0.7)
    return scenario_from_dict({
        "name": "ren-model", "seed": 5,
        "world": {"field_nT": 50000.0, "dip_deg": 60.0},
        "acc": {"bias": {"value": [0.01, -0.02, 0.015]}, "scale": {"value": [1.02, 0.99, 1.01]},
                "misalignment": {"angles_rad": [0.01, -0.02, 0.015], "nonorth_rad": [0.003, -0.002, 0.004]}},
        "mag": {"bias": {"value": [300.0, -200.0, 150.0]}, "scale": {"value": [0.97, 1.03, 1.01]},
                "misalignment": {"matrix": R.tolist()}, "hard_iron": {"value": [100.0, 50.0, -80.0]}},
    })


def test_ren2014_recovers_a_probe_inside_its_model():
    s = _ren_probe()
    cal, _ = ren2014.fit(generate_raw(s, *runs.ren2014()))
    t = truth_of(s)
    np.testing.assert_allclose(cal.acc_m, t.acc_m, atol=1e-4)
    np.testing.assert_allclose(cal.acc_b, t.acc_b, atol=1e-4)
    np.testing.assert_allclose(cal.mag_m, t.mag_m, atol=2e-3)
    np.testing.assert_allclose(cal.mag_b, t.mag_b, atol=5.0)
    da, di = grid_errors(cal, s)
    assert np.sqrt(np.mean(da ** 2)) < 0.1 and np.abs(di).max() < 0.01


def test_ren2014_needs_the_three_circles():
    s = _ren_probe()
    I, A, T = runs.ren2014()
    keep = ~((I == 0) & (A == 0) & (T > 0))  # drop the z-down circle but its first point
    with pytest.raises(DataError, match="circle rotation with body z"):
        ren2014.fit(generate_raw(s, I[keep], A[keep], T[keep]))


@pytest.fixture(scope="module")
def linear_probe_run():
    """The bench's typical probe without scale nonlinearity, one seeded run
    with turntable readout error."""
    s = bench.bench_probe(linear=True)
    return s, bench.emulated_run(s, bench.calibration_poses(), seed=11)


def test_joint_recovers_truth_within_its_covariance(linear_probe_run):
    s, ds = linear_probe_run
    cal, info = joint.fit(ds, sigma_acc=1.5e-4, sigma_mag=1.0, sigma_pose_deg=0.05)
    err = common.cal_vector(cal) - common.cal_vector(truth_of(s))
    sig = np.sqrt(np.diag(info["covariance"]))
    z = err / sig
    assert np.abs(z).max() < 4.5, np.abs(z).max()
    assert 0.3 < np.sqrt(np.mean(z ** 2)) < 2.0  # the covariance is neither far too small nor too large
    assert 0.5 < info["s2"] < 2.0
    assert abs(info["dip_deg"] - 60.0) < 0.05
    da, di = grid_errors(cal, s)
    assert np.sqrt(np.mean(da ** 2)) < 0.06 and np.sqrt(np.mean(di ** 2)) < 0.01


def test_joint_rejects_outliers(linear_probe_run):
    s, ds = linear_probe_run
    bad = copy.deepcopy(ds)
    rows = [5, 40, 77]
    bad.columns["mx_nT"][rows] += 3000.0
    bad.columns["az_g"][rows[0]] -= 0.05
    cal, info = joint.fit(bad, sigma_acc=1.5e-4, sigma_mag=1.0, sigma_pose_deg=0.05)
    assert set(rows) <= set(info["outliers"]) and len(info["outliers"]) <= 6
    clean, _ = joint.fit(ds, sigma_acc=1.5e-4, sigma_mag=1.0, sigma_pose_deg=0.05)
    np.testing.assert_allclose(common.cal_vector(cal)[12:21], common.cal_vector(clean)[12:21], atol=2e-4)
    # a plain least squares is pulled off by the same outliers
    g, f = common.true_vectors(bad, 60.0, 50000.0)
    Mm, _ = ren2014.accelerometer(bad.mag, f)
    assert np.abs(Mm - np.asarray(truth_of(s).mag_m)).max() > 5 * np.abs(
        np.asarray(cal.mag_m) - np.asarray(truth_of(s).mag_m)).max()


def test_joint_without_poses_recovers_truth_up_to_the_unobservable_rotation():
    s = bench.bench_probe(linear=True)
    ds = generate_raw(s, *runs.multi_position(200), seed=3)
    for c in ("inc_deg", "azi_deg", "tf_deg"):
        del ds.columns[c]
    cal, info = joint.fit(ds, sigma_acc=1.5e-4, sigma_mag=1.0)
    assert info["mode"] == "invariants"
    t = truth_of(s)
    # cal = R truth for one common rotation R of both triads
    R = np.asarray(cal.acc_m) @ np.linalg.inv(t.acc_m)
    np.testing.assert_allclose(R @ R.T, np.eye(3), atol=5e-4)
    np.testing.assert_allclose(np.asarray(cal.mag_m), R @ np.asarray(t.mag_m), atol=5e-4)
    np.testing.assert_allclose(cal.acc_b, t.acc_b, atol=1e-4)
    np.testing.assert_allclose(cal.mag_b, t.mag_b, atol=5.0)
    assert abs(info["dip_deg"] - 60.0) < 0.05
    # with a prior body frame (the truth's), the attitude itself is recovered
    cal2, _ = joint.fit(ds, sigma_acc=1.5e-4, sigma_mag=1.0, prior=t)
    da, di = grid_errors(cal2, s)
    assert np.sqrt(np.mean(da ** 2)) < 0.1 and np.abs(di).max() < 0.02


def test_joint_singular_poses_are_refused():
    s = load_scenario("ideal")
    ds = generate_raw(s, [30.0] * 20, [40.0] * 20, [50.0] * 20)
    with pytest.raises(CalibrationError):
        fit(ds, "joint")


def test_fit_report_fields_and_json_round_trip(linear_probe_run):
    s, ds = linear_probe_run
    cal, rep = fit(ds, "li2021", bootstrap=10)
    assert rep.method == "li2021" and rep.rows == len(ds) and rep.rows_used >= 12
    assert set(common.PARAM_NAMES) == set(rep.uncertainty["sigma"])
    assert rep.quantisation["coef_azi_max_deg"] < 1e-3
    assert rep.passed, rep.reasons
    back = type(rep).from_json(rep.to_json())
    assert back == type(rep).from_json(back.to_json())
    assert cal.report["method"] == "li2021" and cal.data["rows"] == len(ds)


def test_verdict_names_the_reason():
    """Ren's non-tilted ellipsoid cannot represent the Li 2021 probe's
    0.03-0.06 cross-axis coupling: the fit is written but its verdict
    fails, naming the residuals that are too large."""
    s = load_scenario("li2021")
    cal, rep = fit(generate_raw(s, *runs.ren2014()), "ren2014", bootstrap=5)
    assert not rep.passed
    assert any("azimuth residual" in r for r in rep.reasons), rep.reasons
    assert "FAIL" in rep.summary() and "azimuth residual" in rep.summary()


def test_too_few_orientations_without_poses_is_a_data_error():
    s = bench.bench_probe(linear=True)
    t = np.arange(0, 360, 4.0)
    ds = generate_raw(s, np.full(len(t), 60.0), np.full(len(t), 10.0), t, seed=2)
    for c in ("inc_deg", "azi_deg", "tf_deg"):
        del ds.columns[c]
    with pytest.raises(DataError, match="too few orientations"):
        fit(ds, "joint")


def test_a_reflection_of_a_triad_alone_is_said_against_the_poses():
    """An accelerometer-only run with poses, fitted a reflection: the line
    names the poses, not a magnetometer the run does not have."""
    import numpy as np
    import pytest

    from inclino.calib import _refuse_reflection
    from inclino.errors import MirroredAxesError
    from inclino.formats.calfile import Calibration
    from inclino.formats.dataset import RawDataset

    n = 12
    cols = {"ax_g": np.ones(n), "ay_g": np.zeros(n), "az_g": np.zeros(n), "inc_deg": np.full(n, 90.0),
            "tf_deg": np.zeros(n)}
    cal = Calibration(acc_m=np.diag([1.0, 1.0, -1.0]).tolist())
    with pytest.raises(MirroredAxesError, match="mirrored against the poses"):
        _refuse_reflection(RawDataset(cols, {}), cal, use_poses=True)
