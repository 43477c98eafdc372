"""An MPU-9150 turned by hand and held still between turns
(tests/data/real/mikoff_mpu9150, MIT): described from its repository's own
words (whitespace-separated, no header, no time column, 100 Hz, m/s^2), it
imports with no error or warning, calibrates and diagnoses; a user's slips
on it are named: g declared for m/s^2, the log declared static though it
moves between its holds, a header line declared that the log lacks."""
from pathlib import Path

from inclino import checks
from inclino.cli import main
from inclino.formats import dataset, importlog, sensor

MK = Path(__file__).parent / "data" / "real" / "mikoff_mpu9150"
LOG = MK / "imu0_rows5001-10900.log"


def _desc(old=None, new=None):
    text = (MK / "sensor.toml").read_text()
    if old is not None:
        assert text.count(old) == 1
        text = text.replace(old, new)
    return sensor.from_toml(text)


def test_the_mpu9150_log_imports_cleanly_and_calibrates(tmp_path, capsys):
    run = tmp_path / "run.csv"
    assert main(["import", str(LOG), "--sensor", str(MK / "sensor.toml"), "-o", str(run)]) == 0
    ds = dataset.read_raw(str(run))
    assert len(ds) == 5900 and ds.triads == "acc" and float(ds.meta["rate_hz"]) == 100.0
    rep = checks.run(ds)
    assert not [f for f in rep.findings if f.level in ("error", "warning")], rep.lines()
    assert any(f.check == "motion" and "step-and-hold" in f.message for f in rep.findings)
    capsys.readouterr()
    cal = tmp_path / "cal.json"
    # written, the verdict judged against the probe's limits (its |g| RMS is the part's own noise)
    assert main(["calibrate", str(run), "-o", str(cal)]) in (0, 1) and cal.is_file()
    out = capsys.readouterr().out
    assert "static holds found in the readings were fitted" in out, out
    assert main(["diagnose", str(run)]) in (0, 1)
    assert "Traceback" not in capsys.readouterr().err


def test_g_declared_for_m_s2_is_refused_naming_m_s2():
    ds, _ = importlog.import_log(str(LOG), _desc('unit = "m/s2"', 'unit = "g"'))
    (f,) = [f for f in checks.run(ds).findings if f.level == "error"]
    assert f.check == "units" and 'unit = "m/s2"' in f.message


def test_declared_static_the_rows_between_its_holds_are_named_as_moving():
    ds, _ = importlog.import_log(str(LOG), _desc(), static=True)
    (f,) = [f for f in checks.run(ds, declared_static=True).findings if f.level == "warning"]
    assert f.check == "motion" and "read while moving" in f.message
    assert f.figures["holds"] >= 30 and f.figures["moving_misfit_g"] > 3 * f.figures["held_misfit_g"]


def test_a_header_declared_on_the_headerless_log_is_said():
    ds, rep = importlog.import_log(str(LOG), _desc("header = false", "header = true"))
    assert len(ds) == 5899
    assert any("a data row" in n and "header = false" in n for n in rep.notes), rep.notes
