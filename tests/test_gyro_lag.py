"""A gyroscope in the sensor description ([gyroscope], docs/dataset.md):
imported as wx_dps, wy_dps, wz_dps (deg/s, body frame), and read by the
row-alignment check, which locates each triad's row against the gyroscope's
rate (a vector in a still field turns against the body's rate) and names the
shift between the triads where the dip invariant cannot: BROAD 05's second
half (1 431 rows, turned by hand) with its magnetometer a row out of step."""
from pathlib import Path

import numpy as np
import pytest

from inclino import checks
from inclino.cli import main
from inclino.errors import DataError
from inclino.formats import dataset, importlog, sensor

BROAD = Path(__file__).parent / "data" / "real" / "broad"
WITH_ACC = (BROAD / "with_acc.toml").read_text(encoding="utf-8")


def _stretch(tmp_path):
    """BROAD 05 from its data row 1 431 on (the header kept)."""
    lines = (BROAD / "05.csv").read_text(encoding="utf-8").splitlines(keepends=True)
    p = tmp_path / "05_second_half.csv"
    p.write_text(lines[0] + "".join(lines[1431:]), encoding="utf-8")
    return p


def _description(tmp_path, gyro=True, lag=0, unit="rad/s"):
    """with_acc.toml, with or without its [gyroscope] (its unit as given),
    its magnetometer declared `lag` rows out of step (lag = 1 on a log in
    step pairs each accelerometer row with the next row's magnetometer)."""
    text = WITH_ACC.replace('unit = "rad/s"', f'unit = "{unit}"')
    if not gyro:
        start = text.index("[gyroscope]")
        text = text[:start] + text[text.index("[header]"):]
    if lag:
        text = text.replace('axes = "x = mx, y = my, z = mz"', f'axes = "x = mx, y = my, z = mz"\nlag = {lag}')
    p = tmp_path / f"d_{int(gyro)}_{lag}_{unit.replace('/', '')}.toml"
    p.write_text(text, encoding="utf-8")
    return sensor.load(str(p))


def _rows(rep, level=None):
    return [f for f in rep.findings if f.check == "row-alignment" and (level is None or f.level == level)]


def test_gyroscope_imported_in_deg_per_s(tmp_path):
    ds, _ = importlog.import_log(str(BROAD / "05.csv"), sensor.load(str(BROAD / "with_acc.toml")))
    first = (BROAD / "05.csv").read_text(encoding="utf-8").splitlines()[1].split(",")
    assert ds.has_gyro
    assert ds.gyro[0] == pytest.approx(np.degrees([float(first[5]), float(first[6]), float(first[7])]), rel=1e-12)
    assert ds.meta["gyro_unit"] == "rad/s" and ds.meta["gyro_axes"] == "x = gx, y = gy, z = gz"
    out = tmp_path / "run.csv"
    assert main(["import", str(BROAD / "05.csv"), "--sensor", str(BROAD / "with_acc.toml"), "-o", str(out)]) == 0
    back = dataset.read_raw(str(out))
    assert np.allclose(back.gyro, ds.gyro) and back.meta["gyro_unit"] == "rad/s"


@pytest.mark.parametrize("unit", ["rad/s", "deg/s"])  # deg/s: declared wrong, the fit's coefficient takes it
def test_shift_named_only_with_the_gyroscope(tmp_path, unit):
    log = str(_stretch(tmp_path))
    ds, _ = importlog.import_log(log, _description(tmp_path, gyro=True, lag=1, unit=unit))
    rep = checks.run(ds)
    named = [f for f in _rows(rep) if f.level in ("warning", "error")]
    assert rep.lag_rows == -1 and len(named) == 1
    assert named[0].figures["route"] == "gyroscope"
    assert named[0].figures["gyro_lag_acc_rows"] == 0 and named[0].figures["gyro_lag_mag_rows"] == -1
    assert "re-import with [magnetometer] lag = 0" in named[0].message
    # the same rows without the gyroscope: the dip's routes do not name the row
    ds, _ = importlog.import_log(log, _description(tmp_path, gyro=False, lag=1))
    rep = checks.run(ds)
    assert not rep.lag_rows and not [f for f in _rows(rep) if f.level in ("warning", "error")]


def test_in_step_not_named_and_checked(tmp_path):
    log = str(_stretch(tmp_path))
    ds, _ = importlog.import_log(log, _description(tmp_path, gyro=True))
    rep = checks.run(ds)
    assert not rep.lag_rows and not _rows(rep)  # in step, and the pairing checked: no note that it is not
    ds, _ = importlog.import_log(log, _description(tmp_path, gyro=False))
    rep = checks.run(ds)
    assert not rep.lag_rows and any("not checked to a row" in f.message for f in _rows(rep, "note"))


def test_gyroscope_axes_default_to_the_accelerometers():
    d = sensor.from_toml('[accelerometer]\ncolumns = ["a1", "a2", "a3"]\naxes = "x = -ay, y = ax, z = az"\n'
                         '[gyroscope]\ncolumns = ["g1", "g2", "g3"]\nunit = "deg/s"\n')
    assert d.gyro.axes == d.acc.axes and d.gyro.scale == 1.0
    d = sensor.from_toml('[accelerometer]\ncolumns = ["a1", "a2", "a3"]\n'
                         '[gyroscope]\ncolumns = ["g1", "g2", "g3"]\nunit = "counts"\nlsb = "1/131 deg/s"\n'
                         'axes = "x = gy, y = -gx, z = gz"\n')
    assert d.gyro.axes == [[1, 1], [-1, 0], [1, 2]] and d.gyro.scale == pytest.approx(1 / 131)


@pytest.mark.parametrize("table, says", [
    ('columns = ["g1", "g2", "g3"]', "[gyroscope].unit: the angular rate's unit"),
    ('columns = ["g1", "g2", "g3"]\nunit = "furlongs"', "unknown unit 'furlongs'"),
    ('columns = ["g1", "g2", "g3"]\nunit = "counts"', "needs lsb"),
    ('columns = ["g1", "g2", "g3"]\nunit = "deg/s"\naxes = "x = -gx, y = gy, z = gz"', "is a reflection"),
    ('columns = ["g1", "g2"]\nunit = "deg/s"', "three column names"),
    ('columns = ["g1", "g2", "g3"]\nunit = "deg/s"\nlag = 1', "unknown key(s) lag"),
])
def test_bad_gyroscope_table_one_line_exit_2(tmp_path, capsys, table, says):
    p = tmp_path / "s.toml"
    p.write_text('[accelerometer]\ncolumns = ["a1", "a2", "a3"]\n[gyroscope]\n' + table + "\n", encoding="utf-8")
    with pytest.raises(DataError, match=None) as e:
        sensor.load(str(p))
    assert says in str(e.value)
    log = tmp_path / "log.csv"
    log.write_text("a1,a2,a3,g1,g2,g3\n0,0,1,0,0,0\n", encoding="utf-8")
    assert main(["import", str(log), "--sensor", str(p), "-o", str(tmp_path / "o.csv")]) == 2
    err = capsys.readouterr().err.strip().splitlines()
    assert len(err) == 1 and says in err[0] and "Traceback" not in err[0]


def test_dataset_gyroscope_is_three_columns(tmp_path):
    p = tmp_path / "r.csv"
    p.write_text("ax_g,ay_g,az_g,wx_dps,wy_dps\n0,0,1,0,0\n", encoding="utf-8")
    with pytest.raises(DataError, match="missing column.s. wz_dps"):
        dataset.read_raw(str(p))


def test_gyroscope_read_from_the_log_beside_a_triad_in_its_own_file(tmp_path):
    lines = (BROAD / "02.csv").read_text(encoding="utf-8").splitlines()
    names = lines[0].split(",")
    mag = [names.index(c) for c in ("mag_x", "mag_y", "mag_z")]
    keep = [j for j in range(len(names)) if j not in mag]
    (tmp_path / "log.csv").write_text("\n".join(",".join(r.split(",")[j] for j in keep) for r in lines) + "\n")
    (tmp_path / "mag.csv").write_text("\n".join(",".join(r.split(",")[j] for j in mag) for r in lines) + "\n")
    text = WITH_ACC.replace("[magnetometer]\n", '[magnetometer]\nfile = "mag.csv"\ntime = false\n')
    (tmp_path / "s.toml").write_text(text, encoding="utf-8")
    ds, _ = importlog.import_log(str(tmp_path / "log.csv"), sensor.load(str(tmp_path / "s.toml")))
    whole, _ = importlog.import_log(str(BROAD / "02.csv"), sensor.load(str(BROAD / "with_acc.toml")))
    assert np.array_equal(ds.gyro, whole.gyro) and np.array_equal(ds.mag, whole.mag)
