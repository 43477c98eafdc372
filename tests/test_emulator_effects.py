"""Each sensor-error effect alone: it changes what it should, by the right
sign and amount, and nothing else."""
import numpy as np
import pytest

from inclino.engines import reference as ref
from inclino.model import effects as fx
from inclino.model.scenario import generate_raw, load_scenario, scenario_from_dict
from inclino.model.world import Trajectory

V = np.array([[0.1, -0.5, 0.8], [1.0, 0.0, 0.0], [-0.3, 0.4, -0.2]])


def test_bias():
    y = fx.Bias([1.0, -2.0, 3.0]).apply(V)
    np.testing.assert_array_equal(y - V, np.tile([1.0, -2.0, 3.0], (3, 1)))


def test_scale():
    y = fx.Scale([2.0, 0.5, -1.0]).apply(V)
    np.testing.assert_array_equal(y, V * [2.0, 0.5, -1.0])


def test_misalignment_small_rotation_sign():
    # a frame rotation by +1 mrad about z: a field along body x appears on
    # sensor y as -1 mrad (reference.rz sign), as a real rotation would
    M = fx.Misalignment.from_small_angles(0.0, 0.0, 1e-3)
    y = M.apply(np.array([1.0, 0.0, 0.0]))
    np.testing.assert_allclose(y, ref.rz(np.degrees(1e-3)) @ [1.0, 0.0, 0.0], atol=1e-6)
    assert y[1] == pytest.approx(-1e-3)


def test_misalignment_nonorthogonality():
    M = fx.Misalignment.from_small_angles(0, 0, 0, nonorth=(2e-3, 0, 0))
    # sensor y leans towards x: an x field leaks +2e-3 into y, nothing else
    np.testing.assert_allclose(M.apply([1.0, 0.0, 0.0]), [1.0, 2e-3, 0.0])
    np.testing.assert_allclose(M.apply([0.0, 1.0, 0.0]), [0.0, 1.0, 0.0])


def test_hard_and_soft_iron():
    np.testing.assert_array_equal(fx.HardIron([5.0, 0, -5.0]).apply(V) - V, np.tile([5.0, 0, -5.0], (3, 1)))
    S = np.array([[1.01, 0.002, 0], [0.002, 0.99, 0], [0, 0, 1.0]])
    np.testing.assert_allclose(fx.SoftIron(S).apply(V), (S @ V.T).T)


def test_tempcos_zero_at_reference_and_linear():
    bt = fx.BiasTempco([1.0, 0.0, -2.0], t_ref_c=25.0)
    np.testing.assert_array_equal(bt.apply(V, 25.0), V)
    np.testing.assert_allclose(bt.apply(V, 35.0) - V, np.tile([10.0, 0.0, -20.0], (3, 1)))
    st = fx.ScaleTempco([100.0, 0.0, 0.0])
    np.testing.assert_allclose(st.apply(V, 35.0)[:, 0], V[:, 0] * 1.001)
    np.testing.assert_array_equal(st.apply(V, 35.0)[:, 1:], V[:, 1:])
    # per-sample temperatures
    y = bt.apply(V, np.array([25.0, 26.0, 27.0]))
    np.testing.assert_allclose(y[:, 0] - V[:, 0], [0.0, 1.0, 2.0])


def test_nonlinearity_sign_and_size():
    y = fx.ScaleNonlinearity([1e-9, 0, 0]).apply(np.array([[100000.0, 5.0, 5.0], [-100000.0, 5.0, 5.0]]))
    np.testing.assert_allclose(y[:, 0], [100010.0, -99990.0])  # +k2 x^2 both signs


def test_white_noise_statistics_and_seed():
    n = fx.WhiteNoise([1.0, 2.0, 0.0])
    y = n.apply(np.zeros((20000, 3)), np.random.default_rng(1))
    np.testing.assert_allclose(y.std(axis=0), [1.0, 2.0, 0.0], rtol=0.03, atol=1e-12)
    assert abs(y[:, 0].mean()) < 0.03
    y2 = n.apply(np.zeros((20000, 3)), np.random.default_rng(1))
    np.testing.assert_array_equal(y, y2)
    # averaging 4x the reference count halves sigma
    y4 = fx.WhiteNoise([1.0, 1.0, 1.0], n_ref=16).apply(np.zeros((20000, 3)), np.random.default_rng(2), n_avg=64)
    np.testing.assert_allclose(y4.std(axis=0), 0.5, rtol=0.03)


def test_saturation_and_quantisation():
    y = fx.Saturation.symmetric(1.7).apply(np.array([[2.0, -3.0, 0.5]]))
    np.testing.assert_array_equal(y, [[1.7, -1.7, 0.5]])
    q = fx.Quantisation(1 / 16384, -32768, 32767)
    np.testing.assert_array_equal(q.counts([[1.0, -1.0, 2.5]]), [[16384, -16384, 32767]])
    np.testing.assert_array_equal(q.counts([[0.5 / 16384, 1.5 / 16384, -0.6 / 16384]]), [[0, 2, -1]])


def test_sampling_skew_equals_toolface_advance():
    # 360 deg/s toolface rotation, fluxgate 2 ms late -> it sees toolface +0.72 deg
    d = {"world": {"field_nT": 50000.0, "dip_deg": 60.0}, "timing": {"mag_skew_s": 0.002}}
    s = scenario_from_dict(d)
    tr = Trajectory([0.0, 10.0], [40.0, 40.0], [30.0, 30.0], [0.0, 3600.0])
    t = np.array([1.0, 2.345])
    ds = generate_raw(s, trajectory=tr, t_s=t)
    _, b_expected = ref.body_vectors(40.0, 30.0, 360.0 * t + 0.72, 50000.0, 60.0)
    g_expected, _ = ref.body_vectors(40.0, 30.0, 360.0 * t, 50000.0, 60.0)
    np.testing.assert_array_equal(ds.mag, ref.quantise_mag(b_expected))
    np.testing.assert_array_equal(ds.acc, ref.quantise_acc(g_expected) * ref.ACC_LSB_G)
    # and without skew the mag differs
    s0 = scenario_from_dict({"world": d["world"]})
    assert not np.array_equal(generate_raw(s0, trajectory=tr, t_s=t).mag, ds.mag)


@pytest.mark.parametrize("effect,table,changed", [
    ("bias", {"value": [0.01, 0.0, 0.0]}, "acc"),
    ("scale", {"value": [1.0, 1.0, 1.01]}, "acc"),
    ("misalignment", {"angles_rad": [0.0, 0.01, 0.0]}, "acc"),
    ("hard_iron", {"value": [500.0, 0.0, 0.0]}, "mag"),
    ("soft_iron", {"matrix": [[1.02, 0, 0], [0, 1, 0], [0, 0, 1]]}, "mag"),
    ("noise", {"sigma": [10.0, 10.0, 10.0]}, "mag"),
])
def test_each_effect_alone_touches_only_its_triad(effect, table, changed):
    inc, azi, tf = [10.0, 60.0, 120.0], [0.0, 100.0, 250.0], [30.0, 200.0, 300.0]
    base = generate_raw(load_scenario("ideal"), inc, azi, tf)
    d = {"world": {"field_nT": 50000.0, "dip_deg": 60.0}, changed: {effect: table}}
    ds = generate_raw(scenario_from_dict(d), inc, azi, tf)
    other = "mag" if changed == "acc" else "acc"
    assert not np.array_equal(getattr(ds, changed), getattr(base, changed))
    np.testing.assert_array_equal(getattr(ds, other), getattr(base, other))


def test_triad_linear_and_only():
    m = load_scenario("typical").mag
    A, c = m.linear()
    x = np.array([20000.0, -10000.0, 40000.0])
    lin = fx.TriadModel(soft_iron=m.soft_iron, hard_iron=m.hard_iron, misalignment=m.misalignment,
                        scale=m.scale, bias=m.bias)
    np.testing.assert_allclose(lin.apply(x), A @ x + c, rtol=1e-12)
    only = m.only("hard_iron")
    np.testing.assert_allclose(only.apply(x), x + m.hard_iron.h)


# ---- Li 2021 -------------------------------------------------------------
@pytest.mark.parametrize("kind,abc_tol,d_tol", [("mag", 6e-5, 1.0), ("acc", 1e-4, 1.0)])
def test_li2021_mapping_reproduces_table3(kind, abc_tol, d_tol):
    """Table 3 (inverse coefficients, printed in the paper) follows from
    Table 2 under our mapping: independent check of the e-block reading."""
    t2, t3 = fx.LI2021_TABLE2[kind], fx.LI2021_TABLE3[kind]
    A = fx.li2021_matrix(t2["K"], t2["e"])
    inv = np.linalg.inv(A)
    np.testing.assert_allclose(inv, t3["ABC"], atol=abc_tol)
    D = -inv @ np.asarray(t2["B"])
    np.testing.assert_allclose(D, t3["D"], atol=d_tol)


def test_li2021_transposed_reading_would_fail():
    t2, t3 = fx.LI2021_TABLE2["mag"], fx.LI2021_TABLE3["mag"]
    At = fx.li2021_matrix(t2["K"], t2["e"])
    K = np.asarray(t2["K"])
    wrong = K[:, None] * (At / K[:, None]).T  # e block read the other way
    assert np.abs(np.linalg.inv(wrong) - np.asarray(t3["ABC"])).max() > 0.02


def test_li2021_equation3_by_hand():
    t2 = fx.LI2021_TABLE2["mag"]
    m = fx.from_li2021(t2["K"], t2["B"], t2["e"], lsb=1.0)
    M = np.array([1000.0, 2000.0, 3000.0])
    (exy, exz), (eyx, eyz), (ezx, ezy) = t2["e"]
    K, B = t2["K"], t2["B"]
    H = [K[0] * (M[0] + eyx * M[1] + ezx * M[2]) + B[0],
         K[1] * (exy * M[0] + M[1] + ezy * M[2]) + B[1],
         K[2] * (exz * M[0] + eyz * M[1] + M[2]) + B[2]]
    np.testing.assert_allclose(m.apply(M), H, rtol=1e-13)


def test_li2021_scenario_level_reading_by_hand():
    """li2021.toml through the loader: at I = A = T = 0 the true gravity is
    (0, 0, 1) g, so eq. (4) gives a = (k_x f_zx, k_y f_zy, k_z) + g_bias,
    with Table 2's bias in counts of 1/16384 g."""
    s = load_scenario("li2021")
    ds = generate_raw(s, [0.0], [0.0], [0.0])
    k = [0.9998, 0.9977, 0.9977]
    f_zx, f_zy = 0.0019, 0.0585
    bias = np.array([-17.5863, -46.3725, -6.8975]) / 16384
    expected = np.array([k[0] * f_zx, k[1] * f_zy, k[2]]) + bias
    np.testing.assert_allclose(ds.acc[0], np.round(expected * 16384) / 16384, atol=0)


def test_rig_field_of_a_part_on_the_inclination_arm():
    """A magnetised part riding on the inclination arm is a constant field in
    the arm's frame Ry(I) Rz(A) W; in the frame the inclination axis turns
    in (the azimuth platform, Rz(A) W) that is Ry(I)^T b_arm, the first
    harmonic of I: cos I (b_x, 0, b_z) + sin I (b_z, 0, -b_x) + (0, b_y, 0)
    at h = 0.  The body then reads Rz(T) b_arm at every pose, and the
    emulated world adds it to the Earth field; the accelerometer is not
    touched."""
    rng = np.random.default_rng(5)
    b = rng.normal(0, 300, 3)
    rf = fx.RigField("inc", [[0.0, b[1], 0.0], [b[0], 0.0, b[2]]], [[0.0, 0.0, 0.0], [b[2], 0.0, -b[0]]])
    I, A, T = rng.uniform(0, 180, 50), rng.uniform(0, 360, 50), rng.uniform(0, 360, 50)
    want = (ref.rz(T) @ b[:, None])[..., 0]
    assert np.allclose(rf.apply(I, A, T), want, atol=1e-9)
    s = scenario_from_dict({"world": {"rig_field": {"axis": "inc", "cos_nT": rf.cos_nT.tolist(),
                                                    "sin_nT": rf.sin_nT.tolist()}}})
    g0, b0 = scenario_from_dict({}).world.truth(I, A, T)
    g1, b1 = s.world.truth(I, A, T)
    assert np.array_equal(g0, g1) and np.allclose(b1 - b0, want, atol=1e-9)


def test_rig_field_of_the_azimuth_axis_is_in_the_world_frame():
    """On the azimuth axis a field given in the world frame at harmonic 1:
    cos A (1, 0, 0) + sin A (0, 1, 0) points along the platform's x axis
    (north turned by A), so the body reads C(I, A, T) (cos A, sin A, 0)."""
    rf = fx.RigField("azi", [[0, 0, 0], [100.0, 0, 0]], [[0, 0, 0], [0, 100.0, 0]])
    I, A, T = np.array([30.0, 90.0]), np.array([40.0, 200.0]), np.array([10.0, 300.0])
    a = np.radians(A)
    want = (ref.pose_matrix(I, A, T) @ np.stack([100 * np.cos(a), 100 * np.sin(a), 0 * a], -1)[..., None])[..., 0]
    assert np.allclose(rf.apply(I, A, T), want)
    with pytest.raises(ValueError):
        fx.RigField("pitch")
