"""A turntable run read several rows at each pose: the rows of one pose share
its turntable readout error, so the diagnosis works on each pose's mean
(analysis.pose_means) and names nothing on a run the 12-parameter model
fits exactly, while an effect hidden in such a run is still named; calibrate,
which fits such a run's own noise, says so of residuals above the nominal.

The runs are made here from the documented conventions alone
(docs/conventions.md: C = pose_matrix(inc, azi, tf) turns the world's NED
vectors into the body frame, the accelerometer reads the down vector, the
field is F (cos dip, 0, sin dip)), not with the project's emulator."""
import numpy as np
import pytest

from inclino.diagnose.analysis import diagnose, pose_means
from inclino.engines import reference as ref
from inclino.formats.dataset import RawDataset

F_NT, DIP_DEG = 48_000.0, 60.0


def _clustered_run(seed, n_poses=30, rows=(5, 10), pose_sd_deg=0.03, azi_offset_deg=0.0):
    """n_poses random poses, each read rows[0]..rows[1] times; each pose's true
    orientation off its indicated one by one readout error (pose_sd_deg per
    axis) shared by its rows; the poses' azimuth read azi_offset_deg off the
    true (a turntable azimuth offset).  Sensor: scale and cross-axis errors of
    1 %, offsets, white noise 0.3 mg and 25 nT."""
    rng = np.random.default_rng(seed)
    inc = rng.uniform(10.0, 170.0, n_poses)
    azi = rng.uniform(0.0, 360.0, n_poses)
    tf = rng.uniform(0.0, 360.0, n_poses)
    size = rng.integers(rows[0], rows[1] + 1, n_poses)
    err = rng.normal(0.0, pose_sd_deg, (n_poses, 3))
    C = ref.pose_matrix(inc + err[:, 0], azi + err[:, 1] + azi_offset_deg, tf + err[:, 2])
    dip = np.radians(DIP_DEG)
    g = C[:, :, 2]
    b = C @ (F_NT * np.array([np.cos(dip), 0.0, np.sin(dip)]))
    Aa, Am = np.eye(3) + rng.normal(0, 0.01, (3, 3)), np.eye(3) + rng.normal(0, 0.01, (3, 3))
    rep = np.repeat(np.arange(n_poses), size)
    n = len(rep)
    acc = g[rep] @ Aa.T + rng.normal(0, 0.02, 3) + rng.normal(0, 3e-4, (n, 3))
    mag = b[rep] @ Am.T + rng.normal(0, 500.0, 3) + rng.normal(0, 25.0, (n, 3))
    cols = {"t_s": np.arange(n) * 1.0 + 20.0 * rep, "inc_deg": inc[rep], "azi_deg": azi[rep], "tf_deg": tf[rep],
            "ax_g": acc[:, 0], "ay_g": acc[:, 1], "az_g": acc[:, 2],
            "mx_nT": mag[:, 0], "my_nT": mag[:, 1], "mz_nT": mag[:, 2]}
    return RawDataset(cols, {"field_nT": F_NT, "dip_deg": DIP_DEG, "declination_deg": 0.0})


def test_pose_means_one_row_per_pose_with_the_mean_of_its_rows():
    ds = _clustered_run(1)
    m, note = pose_means(ds)
    k = len(np.unique(ds.columns["inc_deg"]))
    assert len(m) == k and f"{len(ds)} readings at {k} turntable poses" in note
    first = ds.columns["inc_deg"] == ds.columns["inc_deg"][0]
    assert m.columns["ax_g"][0] == pytest.approx(ds.columns["ax_g"][first].mean(), abs=1e-15)
    assert m.columns["azi_deg"][0] == ds.columns["azi_deg"][0]
    one = RawDataset({c: v[np.r_[0, np.flatnonzero(np.diff(ds.columns["inc_deg"])) + 1]]
                      for c, v in ds.columns.items()}, dict(ds.meta))
    assert pose_means(one) == (one, None)


@pytest.mark.parametrize("seed", [5, 1])
def test_rows_sharing_their_pose_error_name_nothing(seed):
    """Row by row these runs (seed 5 of the tester's draws, and 1) named a
    turntable azimuth offset or a rig field and structure no effect explains."""
    r = diagnose(_clustered_run(seed))
    assert not r.effects and not r.unexplained, r.conclusion()
    assert any("turntable poses" in s for s in r.baseline["selection"]["notes"])


def test_an_azimuth_offset_in_a_run_read_several_rows_a_pose_is_named():
    r = diagnose(_clustered_run(7, azi_offset_deg=0.15))
    named = {e.name: e for e in r.effects}
    assert "turntable-azimuth-offset" in named, r.conclusion()
    e = named["turntable-azimuth-offset"]
    # the poses read 0.15 deg off the true azimuth: the estimate within 4 of its own standard errors
    assert abs(abs(e.estimate) - 0.15) < 4 * e.stderr, (e.estimate, e.stderr)


def test_a_pose_held_while_the_temperature_ramps_keeps_its_temperatures_apart():
    ds = _clustered_run(3, rows=(20, 20))
    n = len(ds)
    ds.columns["temp_c"] = np.linspace(-5.0, 55.0, n)  # 0.1 degC a row, 1.9 degC over a pose's 20 rows
    m, note = pose_means(ds)
    # each pose split where its rows leave MEANS_TEMP_C (0.5 degC) of the first: 4 groups a pose
    assert len(m) == 4 * 30
    assert np.all(np.abs(np.diff(m.columns["temp_c"])) < 1.0)


@pytest.mark.parametrize("seed", [11, 12])
def test_a_room_temperature_that_jitters_does_not_split_a_pose(seed):
    """temp_c = 25 + N(0, 0.3 degC) on every row (a room read by a noisy
    sensor): split at 0.5 degC from a pose's first row, 120 poses of 3 rows
    read as 174 and the shared readout error as structure no effect
    explains (3 of 4 generated runs).  A ramp's steps are no noise: it
    still splits (above)."""
    ds = _clustered_run(seed, n_poses=120, rows=(3, 3))
    rng = np.random.default_rng(seed + 100)
    ds.columns["temp_c"] = 25.0 + rng.normal(0.0, 0.3, len(ds))
    m, note = pose_means(ds)
    assert len(m) == 120 and "at 120 turntable poses (3 rows each)" in note
    r = diagnose(ds)
    assert not r.effects and not r.unexplained, r.conclusion()


def test_calibrate_on_such_a_run_does_not_say_its_covariance_is_scaled_by_s2(tmp_path, capsys):
    """calibrate fits the run's own noise (REML over the poses' clusters) and
    uses it for the covariance: its note on residuals above the nominal
    noise (this sensor's 0.3 mg, 25 nT against 0.15 mg, 5 nT) says so, not
    that s^2 scales the covariance."""
    import json

    from inclino.cli import main
    from inclino.formats.dataset import write_raw

    p = tmp_path / "run.csv"
    write_raw(str(p), _clustered_run(2))
    assert main(["calibrate", str(p), "-o", str(tmp_path / "cal.json"), "--json"]) == 0
    notes = json.loads(capsys.readouterr().out)["report"]["notes"]
    assert not any("scaled by s^2" in n for n in notes), notes
    assert any("what the nominal noise expects" in n and "the run's own noise" in n for n in notes), notes
