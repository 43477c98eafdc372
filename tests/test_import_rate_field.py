"""Two facts a sensor description can state about a log: the sample rate of a
log with no time column (`[log] rate_hz`), and magnetometer readings
normalised to the site's total field (`unit = "field"`): docs/dataset.md,
"The sensor description"."""
from pathlib import Path

import numpy as np
import pytest

from inclino import holds
from inclino.cli import main
from inclino.errors import DataError
from inclino.formats import dataset, importlog, sensor

REAL = Path(__file__).parent / "data" / "real"
ACC = '[accelerometer]\ncolumns = ["ax", "ay", "az"]\nunit = "g"\n'


def _files(tmp_path, lines, desc):
    log, toml = tmp_path / "log.csv", tmp_path / "s.toml"
    log.write_text("\n".join(lines) + "\n")
    toml.write_text(desc)
    return log, toml


def _cli(tmp_path, lines, desc, capsys):
    log, toml = _files(tmp_path, lines, desc)
    out = tmp_path / "run.csv"
    rc = main(["import", str(log), "--sensor", str(toml), "-o", str(out)])
    return rc, capsys.readouterr().err, out


# ---- [log] rate_hz -------------------------------------------------------------------------------------------


def test_rate_hz_times_each_row_by_its_index_and_a_dropped_row_leaves_a_gap(tmp_path):
    """Six rows read at 50 Hz under a units line; the third has a missing
    value and is dropped: the rows kept are read 0, 1, 3, 4, 5 periods after
    the first (the units line is no sample)."""
    rows = ["0,0,1", "0.001,0,1", "0,NaN,1", "0,0.002,1", "0.001,0.001,1", "0,0,1"]
    log, toml = _files(tmp_path, ["ax,ay,az", "g,g,g"] + rows, "[log]\nrate_hz = 50\n" + ACC)
    ds, rep = importlog.import_log(str(log), sensor.load(str(toml)))
    np.testing.assert_array_equal(ds.columns["t_s"], np.array([0, 1, 3, 4, 5]) / 50.0)
    assert rep.dropped == {"a second header line (units or descriptions)": 1,
                           "a missing value in accelerometer y ('ay') (line 5)": 1}
    assert ds.meta["rate_hz"] == 50.0
    out = tmp_path / "run.csv"
    dataset.write_raw(str(out), ds)
    back = dataset.read_raw(str(out))
    assert back.meta["rate_hz"] == 50.0  # a number in the canonical header
    np.testing.assert_array_equal(back.columns["t_s"], ds.columns["t_s"])


def test_rate_hz_counts_rows_dropped_for_keep_or_a_lag(tmp_path):
    """Rows kept by [log].keep and rows cut by a triad's lag keep their own
    row's time."""
    rows = [f"{i % 2},0,0,1,30,0,40" for i in range(6)]  # part 0, 1, 0, 1, ...
    desc = '[log]\nrate_hz = "2 kHz"\nkeep = { part = ["1"] }\n' + ACC
    log, toml = _files(tmp_path, ["part,ax,ay,az,mx,my,mz"] + rows, desc)
    ds, _ = importlog.import_log(str(log), sensor.load(str(toml)))
    np.testing.assert_array_equal(ds.columns["t_s"], np.array([1, 3, 5]) / 2000.0)
    lag = ('[log]\nrate_hz = 10\n' + ACC + '[magnetometer]\ncolumns = ["mx", "my", "mz"]\nunit = "uT"\nlag = -2\n')
    log, toml = _files(tmp_path, ["part,ax,ay,az,mx,my,mz"] + rows, lag)
    ds, rep = importlog.import_log(str(log), sensor.load(str(toml)))
    assert rep.dropped == {"a triad's lag (rows without a partner)": 2}
    np.testing.assert_array_equal(ds.columns["t_s"], np.array([2, 3, 4, 5]) / 10.0)


def test_without_rate_hz_a_log_without_time_gets_no_time(tmp_path):
    log, toml = _files(tmp_path, ["ax,ay,az", "0,0,1", "0,0,1"], ACC)
    ds, _ = importlog.import_log(str(log), sensor.load(str(toml)))
    assert "t_s" not in ds.columns and "rate_hz" not in ds.meta


@pytest.mark.parametrize("rate", ["0", "-100", "inf", "nan", "-inf", '"fast"', "true", '""', "[100]"])
def test_a_rate_that_is_not_positive_and_finite_is_refused(tmp_path, capsys, rate):
    rc, err, out = _cli(tmp_path, ["ax,ay,az", "0,0,1"], f"[log]\nrate_hz = {rate}\n" + ACC, capsys)
    assert rc == 2 and "rate_hz: the sample rate in Hz, a finite number > 0" in err and err.count("\n") == 1
    assert not out.exists()


def test_a_rate_with_a_time_column_is_refused(tmp_path, capsys):
    rc, err, out = _cli(tmp_path, ["t,ax,ay,az", "0,0,0,1"], '[log]\ntime = "t"\nrate_hz = 100\n' + ACC, capsys)
    assert rc == 2 and "rate_hz and time" in err and err.count("\n") == 1 and not out.exists()


def test_mpu6050_log_timed_by_its_declared_rate_matches_its_settings():
    """The MPU-6050 log's settings say Fs,100 (sensor.toml: rate_hz = 100)
    an initialization time of 36.5 s (Tedaldi's T_init: the sensor is held
    still at least that long before the first turn) and a waiting time of
    3 s (a hold): timed by the rate, the first hold found in the readings
    lasts from 36.5 s to 36.5 s + 3 s (37.6 s), a second view of the rate
    from the data (at 90 or 110 Hz it would last 41.8 s or 34.2 s)."""
    d = REAL / "mpu6050_tedaldi"
    ds, rep = importlog.import_log(str(d / "example_data_calibration.csv"), sensor.load(str(d / "sensor.toml")))
    t = ds.columns["t_s"]
    assert rep.rows_read == 10245 and t[-1] == pytest.approx(102.44)
    assert ds.meta["rate_hz"] == 100.0
    h = holds.find(ds)
    first = t[h.labels == h.labels[0]]
    assert h.labels[0] >= 0 and 36.5 <= first[-1] - first[0] < 36.5 + 3


# ---- [magnetometer] unit = "field" ----------------------------------------------------------------------------


def _sphere(n=300, seed=3, dip=60.0):
    """Readings of a still field (dip below horizontal) and gravity seen
    from n random orientations: (acc in g, mag as unit vectors)."""
    rng = np.random.default_rng(seed)
    q = rng.normal(size=(n, 4))
    q /= np.linalg.norm(q, axis=1, keepdims=True)
    w, x, y, z = q.T
    R = np.stack([np.stack([1 - 2 * (y * y + z * z), 2 * (x * y - w * z), 2 * (x * z + w * y)], -1),
                  np.stack([2 * (x * y + w * z), 1 - 2 * (x * x + z * z), 2 * (y * z - w * x)], -1),
                  np.stack([2 * (x * z - w * y), 2 * (y * z + w * x), 1 - 2 * (x * x + y * y)], -1)], 1)
    d = np.radians(dip)
    acc = R @ np.array([0.0, 0.0, 1.0])
    mag = R @ np.array([np.cos(d), 0.0, np.sin(d)])
    return acc, mag


def _field_log(meta=()):
    acc, mag = _sphere()
    lines = [f"# {m}" for m in meta] + ["ax,ay,az,mx,my,mz"]
    lines += [",".join(f"{v:.9f}" for v in (*a, *m)) for a, m in zip(acc, mag)]
    return lines, acc, mag


MAG_FIELD = '[magnetometer]\ncolumns = ["mx", "my", "mz"]\nunit = "field"\n'


def test_field_unit_is_scaled_by_the_descriptions_field(tmp_path):
    lines, acc, mag = _field_log()
    desc = ACC + MAG_FIELD + "[header]\nfield_nT = 49500\ndip_deg = 60\n"
    log, toml = _files(tmp_path, lines, desc)
    ds, _ = importlog.import_log(str(log), sensor.load(str(toml)))
    m = np.column_stack([ds.columns[c] for c in dataset.MAG_COLS])
    np.testing.assert_allclose(m, np.round(mag, 9) * 49500.0, rtol=1e-12)
    assert ds.meta["mag_unit"] == "field x 49500 nT"
    assert "mag_lsb_nT" not in ds.meta  # the resolution is not known
    rc = main(["import", str(log), "--sensor", str(toml), "-o", str(tmp_path / "run.csv")])
    assert rc == 0  # the checks accept it: |b| is the header's field


def test_field_unit_takes_the_logs_own_field_line(tmp_path):
    lines, acc, mag = _field_log(meta=("field_nT=48000",))
    log, toml = _files(tmp_path, lines, ACC + MAG_FIELD)
    ds, _ = importlog.import_log(str(log), sensor.load(str(toml)))
    assert np.median(np.linalg.norm(np.column_stack([ds.columns[c] for c in dataset.MAG_COLS]), axis=1)) == \
        pytest.approx(48000.0)
    assert ds.meta["mag_unit"] == "field x 48000 nT" and ds.meta["field_nT"] == 48000.0


def test_field_unit_without_a_field_is_refused(tmp_path, capsys):
    lines, _, _ = _field_log()
    rc, err, out = _cli(tmp_path, lines, ACC + MAG_FIELD, capsys)
    assert rc == 2 and "unit = \"field\"" in err and "field_nT" in err and err.count("\n") == 1
    assert not out.exists()


def test_field_unit_quantities(tmp_path):
    """lsb, noise, range: a plain number is in field units (needs the
    description's field), a quantity with a unit is itself."""
    with_field = sensor.from_toml(ACC + MAG_FIELD + 'lsb = 0.001\nnoise = "0.3 uT"\nrange = 4\n'
                                  "[header]\nfield_nT = 50000\n")
    assert with_field.mag.lsb == pytest.approx(50.0) and with_field.mag.noise == pytest.approx(300.0)
    assert with_field.mag.range == pytest.approx(200000.0)
    no_field = sensor.from_toml(ACC + MAG_FIELD + 'noise = "0.3 uT"\n')
    assert no_field.mag.noise == pytest.approx(300.0) and no_field.mag.lsb is None
    with pytest.raises(DataError, match="in field units needs the site's field"):
        sensor.from_toml(ACC + MAG_FIELD + "lsb = 0.001\n")


def test_field_is_a_magnetometer_unit_only():
    with pytest.raises(DataError, match="unknown unit 'field'"):
        sensor.from_toml('[accelerometer]\ncolumns = ["ax", "ay", "az"]\nunit = "field"\n')


def test_a_line_of_control_bytes_after_the_names_is_named_as_such(tmp_path):
    """A serial capture whose logger sent NULs before its first row: the line
    after the names has no number in it, as a units line has, but it is
    noise on the link, and the import says so (it had been counted as "a
    second header line (units or descriptions)")."""
    rows = ["0,0,1", "0.001,0,1", "0,0.002,1"]
    log, toml = _files(tmp_path, ["ax,ay,az", "\x00\x00,\x00,\x00"] + rows, "[log]\nrate_hz = 50\n" + ACC)
    ds, rep = importlog.import_log(str(log), sensor.load(str(toml)))
    assert len(ds) == 3 and rep.dropped == {"a line of control bytes (a serial link's noise)": 1}, rep.dropped
