"""World, scenarios and dataset generation (inclino_emu)."""
import numpy as np
import pytest

from inclino.engines import reference as ref
from inclino.formats.dataset import read_raw, write_raw
from inclino.model import effects as fx
from inclino.model.scenario import builtin_scenarios, generate_raw, load_scenario, scenario_from_dict
from inclino.model.world import EarthField, EncoderErrors, Trajectory, Turntable, World

RNG = np.random.default_rng(7)
INC = RNG.uniform(0, 180, 40)
AZI = RNG.uniform(0, 360, 40)
TF = RNG.uniform(0, 360, 40)


def test_builtin_scenarios_present():
    assert {"ideal", "typical", "li2021"} <= set(builtin_scenarios())


def test_world_truth_matches_reference():
    w = World(earth=EarthField(48000.0, 52.0, 3.5), gravity_g=0.9993)
    g, b = w.truth(INC, AZI, TF)
    g0, b0 = ref.body_vectors(INC, AZI, TF, 48000.0, 52.0, 3.5, 0.9993)
    np.testing.assert_allclose(g, g0, atol=1e-15)
    np.testing.assert_allclose(b, b0, atol=1e-9)


def test_level_pose_by_hand():
    # I=A=T=0: body axes N, E, D; gravity +1 g on z; field (F cos dip, 0, F sin dip)
    g, b = World(earth=EarthField(50000.0, 60.0, 0.0)).truth(0.0, 0.0, 0.0)
    np.testing.assert_allclose(g, [0, 0, 1], atol=1e-15)
    np.testing.assert_allclose(b, [25000.0, 0.0, 50000.0 * np.sqrt(3) / 2], atol=1e-9)
    # azimuth 90 (probe x towards east): the north component appears on -y
    _, b = World(earth=EarthField(50000.0, 60.0, 0.0)).truth(0.0, 90.0, 0.0)
    np.testing.assert_allclose(b, [0.0, -25000.0, 50000.0 * np.sqrt(3) / 2], atol=1e-9)


def test_ideal_scenario_reproduces_reference_exactly():
    s = load_scenario("ideal")
    ds = generate_raw(s, INC, AZI, TF)
    g0, b0 = ref.body_vectors(INC, AZI, TF, 50000.0, 60.0, 0.0)
    np.testing.assert_array_equal(ds.acc, ref.quantise_acc(g0) * ref.ACC_LSB_G)
    np.testing.assert_array_equal(ds.mag, ref.quantise_mag(b0) * ref.MAG_LSB_NT)
    assert ds.meta["field_nT"] == 50000.0 and ds.meta["dip_deg"] == 60.0
    np.testing.assert_array_equal(ds.columns["inc_deg"], INC)


def test_dataset_roundtrip_through_write_raw(tmp_path):
    ds = generate_raw(load_scenario("typical"), INC[:5], AZI[:5], TF[:5], temp_c=[20, 25, 30, 35, 40])
    p = tmp_path / "raw.csv"
    write_raw(str(p), ds)
    back = read_raw(str(p))
    np.testing.assert_array_equal(back.acc, ds.acc)
    np.testing.assert_array_equal(back.mag, ds.mag)
    np.testing.assert_array_equal(back.columns["temp_c"], [20, 25, 30, 35, 40])
    assert back.meta["source"].startswith("inclino_emu scenario=typical")


def test_seeded_reproducibility():
    s = load_scenario("typical")
    a = generate_raw(s, INC, AZI, TF)
    b = generate_raw(load_scenario("typical"), INC, AZI, TF)
    c = generate_raw(s, INC, AZI, TF, seed=99)
    np.testing.assert_array_equal(a.mag, b.mag)
    np.testing.assert_array_equal(a.acc, b.acc)
    assert not np.array_equal(a.mag, c.mag)


def test_encoder_errors_move_the_true_pose():
    enc = EncoderErrors([0.5, -1.0, 2.0], [1e-3, 0.0, -2e-3])
    w = World(turntable=Turntable(enc))
    g, b = w.truth(30.0, 100.0, 200.0)
    g0, b0 = ref.body_vectors(0.5 + 1.001 * 30.0, -1.0 + 100.0, 2.0 + 0.998 * 200.0)
    np.testing.assert_allclose(g, g0, atol=1e-14)
    np.testing.assert_allclose(b, b0, atol=1e-9)


def test_turntable_limits():
    with pytest.raises(ValueError):
        Turntable().check(181.0, 0.0, 0.0)
    with pytest.raises(ValueError):
        Turntable().check(10.0, 361.0, 0.0)


def test_field_drift_changes_total_and_dip():
    w = World(earth=EarthField(50000.0, 60.0, 0.0), drift=fx.FieldDrift(2.0, 0.001, 0.0))
    _, b = w.truth(INC[:3], AZI[:3], TF[:3], t=100.0)
    np.testing.assert_allclose(np.linalg.norm(b, axis=-1), 50200.0, rtol=1e-12)
    g, _ = w.truth(INC[:3], AZI[:3], TF[:3], t=100.0)
    att = ref.attitude(g, b)
    np.testing.assert_allclose(att["dip"], 60.1, atol=1e-9)


def test_igrf_field_chengdu():
    e = EarthField.from_igrf(30.66, 104.06, "2021-01-01", 0.5)
    # IGRF-14 at Chengdu: about 51 000 nT, dip 48 deg, declination -2.3 deg
    assert 50500 < e.field_nT < 51500
    assert 47.0 < e.dip_deg < 49.5
    assert -3.5 < e.declination_deg < -1.0


def test_scenario_igrf_with_dip_override():
    s = scenario_from_dict({"world": {"lat_deg": 30.66, "lon_deg": 104.06, "date": "2021-01-01",
                                      "dip_deg": 45.1}})
    assert s.world.earth.dip_deg == 45.1
    assert 50500 < s.world.earth.field_nT < 51500


def test_li2021_scenario_field():
    s = load_scenario("li2021")
    assert s.world.earth.dip_deg == 45.1
    assert s.world.earth.declination_deg == 0.0


def test_trajectory_continuous_rotation():
    tr = Trajectory([0.0, 10.0], [45.0, 45.0], [30.0, 30.0], [0.0, 3600.0])
    inc, azi, tf = tr(np.array([0.0, 0.25, 10.0, 20.0]))
    np.testing.assert_allclose(tf, [0.0, 90.0, 3600.0, 3600.0])
    ds = generate_raw(load_scenario("ideal"), trajectory=tr, t_s=np.array([0.0, 0.25, 5.1]))
    np.testing.assert_allclose(ds.columns["tf_deg"], [0.0, 90.0, 36.0], atol=1e-9)
