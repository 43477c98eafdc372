"""`inclino attitude --cal`: the corrected readings' |g|, |b| and dip against
the header's gravity_g, field_nT and dip_deg (inclino.checks.corrected).  A
calibration of another sensor, or a stale one, is one warning line on
stderr naming the figures; the rows are computed and the exit stays 0."""
import numpy as np

from inclino import checks, cli
from inclino.engines import reference
from inclino.formats import dataset
from inclino.formats.calfile import Calibration

FIELD, DIP = 51368.0, 66.1


def _sensor(tmp_path, meta, n=300, seed=5):
    """A sensor with scale errors and a hard-iron offset of tens of uT (as a
    phone's or a breakout board's), and its exact calibration."""
    rng = np.random.default_rng(seed)
    inc, azi, tf = rng.uniform(5, 175, n), rng.uniform(0, 360, n), rng.uniform(0, 360, n)
    g, b = reference.body_vectors(inc, azi, tf, FIELD, DIP)
    am = np.array([[1.03, 0.01, 0.0], [0.0, 0.97, 0.02], [0.0, 0.0, 1.01]])
    ab = np.array([0.02, -0.03, 0.01])
    mm = np.array([[1.05, 0.02, 0.0], [0.0, 0.95, 0.01], [0.01, 0.0, 1.02]])
    mb = np.array([22000.0, -15000.0, 30000.0])
    acc = g @ np.linalg.inv(am).T + ab
    mag = b @ np.linalg.inv(mm).T + mb
    cols = {"ax_g": acc[:, 0], "ay_g": acc[:, 1], "az_g": acc[:, 2],
            "mx_nT": mag[:, 0], "my_nT": mag[:, 1], "mz_nT": mag[:, 2]}
    p = tmp_path / "run.csv"
    dataset.write_raw(str(p), dataset.RawDataset(cols, {"source": "test", **meta}))
    own = Calibration(acc_m=am.tolist(), acc_b=ab.tolist(), mag_m=mm.tolist(), mag_b=mb.tolist(), method="test")
    # another sensor's: its own offsets (a few uT) and scale, nothing of this one's
    other = Calibration(acc_m=np.eye(3).tolist(), acc_b=[0.01, 0.0, -0.02], mag_m=(1.1 * np.eye(3)).tolist(),
                        mag_b=[3000.0, -2000.0, 1000.0], method="test")
    paths = {}
    for name, cal in (("own", own), ("other", other)):
        paths[name] = tmp_path / f"{name}.json"
        paths[name].write_text(cal.to_json())
    return p, paths


def _after(err):
    return [ln for ln in err.splitlines() if "after " in ln and "corrected readings" in ln]


def test_another_sensors_calibration_is_named(tmp_path, capsys):
    p, cal = _sensor(tmp_path, {"field_nT": FIELD, "dip_deg": DIP})
    assert cli.main(["attitude", str(p), "--cal", str(cal["own"]), "-o", str(tmp_path / "a.csv")]) == 0
    assert _after(capsys.readouterr().err) == []
    assert cli.main(["attitude", str(p), "--cal", str(cal["other"]), "-o", str(tmp_path / "b.csv")]) == 0
    err = capsys.readouterr().err
    lines = _after(err)
    assert len(lines) == 1 and lines[0].startswith("inclino: warning: after ") and "Traceback" not in err
    assert "against the header's field_nT 51368" in lines[0] and "wrong header values (field_nT" in lines[0]
    assert "a calibration of another sensor or a stale one" in lines[0]
    assert (tmp_path / "b.csv").exists()


def test_without_header_values_g_and_the_geomagnetic_range(tmp_path, capsys):
    p, cal = _sensor(tmp_path, {})
    assert cli.main(["attitude", str(p), "--cal", str(cal["other"]), "-o", str(tmp_path / "b.csv")]) == 0
    lines = _after(capsys.readouterr().err)
    # |b| through the other sensor's calibration keeps most of this one's 40 uT offset: 70 000 nT, beyond the
    # geomagnetic range; with no header dip the dip (56 deg against the truth's 66) is not compared
    assert len(lines) == 1 and "outside the geomagnetic range" in lines[0] and "dip" not in lines[0]
    # a calibration that leaves |g| 30 % off is named without any header value
    bad = Calibration(acc_m=(1.3 * np.eye(3)).tolist(), mag_m=np.eye(3).tolist(), method="test")
    cp = tmp_path / "bad.json"
    cp.write_text(bad.to_json())
    assert cli.main(["attitude", str(p), "--cal", str(cp), "-o", str(tmp_path / "c.csv")]) == 0
    lines = _after(capsys.readouterr().err)
    assert len(lines) == 1 and "against 1 g (+29 %)" in lines[0] and "the header's" not in lines[0]


def test_corrected_thresholds():
    meta = {"field_nT": 50000.0, "dip_deg": 60.0}
    one = np.ones(10)
    assert checks.corrected(meta, one, 50000 * one, 60 * one) is None
    assert checks.corrected(meta, 1.12 * one, 1.2 * 50000 * one, 69 * one) is None   # within the tolerances
    assert "|g| 1.2 g" in checks.corrected(meta, 1.2 * one, 50000 * one, 60 * one).message  # beyond a MEMS scale error
    f = checks.corrected(meta, one, 1.3 * 50000 * one, 60 * one)
    assert f.level == "warning" and "field_nT" in f.message and "dip" not in f.message
    f = checks.corrected(meta, one, 50000 * one, 45 * one)
    assert "dip +45.0" in f.message and "wrong header values (dip_deg)" in f.message
    assert "geomagnetic range" in checks.corrected({}, one, 80000 * one, 10 * one).message
    assert checks.corrected({}, one, 50000 * one, 10 * one) is None                    # no header dip


def test_rows_beyond_the_probes_range_are_counted_on_stderr(tmp_path, capsys):
    """A VMU931's readings 4.4 fields off the origin (177 800 nT) carry
    ATT_F_MAG_OVERRANGE on every row, with every engine: the flags column
    said so and stderr nothing.  The rows are counted and the engine's part
    said; within the range nothing is said."""
    run, cals = _sensor(tmp_path, {"field_nT": FIELD, "dip_deg": DIP})
    ds = dataset.read_raw(str(run))
    far = dataset.RawDataset({**ds.columns, "mx_nT": ds.columns["mx_nT"] + 120_000.0}, dict(ds.meta))
    dataset.write_raw(str(tmp_path / "far.csv"), far)
    shifted = Calibration.from_json(cals["own"].read_text())
    shifted.mag_b = (np.asarray(shifted.mag_b) + [120_000.0, 0.0, 0.0]).tolist()
    (tmp_path / "far.json").write_text(shifted.to_json())
    for engine, tail in (("reference", "computed in float all the same"), ("firmware", "--engine reference")):
        assert cli.main(["attitude", str(tmp_path / "far.csv"), "--cal", str(tmp_path / "far.json"),
                         "--engine", engine, "-o", str(tmp_path / "att.csv")]) == 0
        err = capsys.readouterr().err
        rows = np.genfromtxt(tmp_path / "att.csv", delimiter=",", names=True)
        n = int(np.count_nonzero(rows["flags"].astype(int) & 0x0004))
        assert n > 0 and f"{n} of {len(ds)} rows with a field reading beyond" in err and tail in err, err
    assert cli.main(["attitude", str(run), "--cal", str(cals["own"]), "-o", str(tmp_path / "att.csv")]) == 0
    assert "beyond the probe" not in capsys.readouterr().err


def test_with_a_calibration_the_raw_readings_size_is_not_warned_of(tmp_path, capsys):
    """An LSM303's raw |b| 28 % below the header's field: attitude --cal
    repeated the raw check's warning although the calibration corrects it
    (corrected |b| at the field).  With --cal what the calibration leaves is
    checked; without one the raw warning stands."""
    run, cals = _sensor(tmp_path, {"field_nT": FIELD, "dip_deg": DIP})
    ds = dataset.read_raw(str(run))
    small = dataset.RawDataset({**ds.columns, **{c: 0.72 * ds.columns[c] for c in ("mx_nT", "my_nT", "mz_nT")}},
                               dict(ds.meta))
    dataset.write_raw(str(tmp_path / "small.csv"), small)
    cal = Calibration.from_json(cals["own"].read_text())
    cal.mag_m = (np.asarray(cal.mag_m) / 0.72).tolist()
    cal.mag_b = (0.72 * np.asarray(cal.mag_b)).tolist()
    (tmp_path / "small.json").write_text(cal.to_json())
    assert cli.main(["attitude", str(tmp_path / "small.csv"), "-o", str(tmp_path / "a.csv")]) == 0
    assert "% from the header's field_nT" in capsys.readouterr().err
    assert cli.main(["attitude", str(tmp_path / "small.csv"), "--cal", str(tmp_path / "small.json"),
                     "-o", str(tmp_path / "a.csv")]) == 0
    assert "warning" not in capsys.readouterr().err
