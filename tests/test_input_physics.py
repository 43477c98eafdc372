"""The checks before any fit read what a log's own physics says of its time
column, its temperature column and its orientations (inclino.checks:
_time_unit, _temperature, _orientations; docs/dataset.md, "Checks before any
fit").  The logs are the real corpus (tests/data/real) with one thing
changed: the time column rewritten in another unit, a temperature column
that is constant, a counter or another column, the rows of one hold."""
import csv
import re
from pathlib import Path

import numpy as np
import pytest

from inclino import checks
from inclino.cli import main
from inclino.formats import dataset, importlog, sensor

REAL = Path(__file__).parent / "data" / "real"
BROAD = REAL / "broad" / "05.csv"
FUSION = REAL / "micropython_fusion"
MPU = REAL / "mpu6050_tedaldi"


def _one_error(err: str, needle: str) -> None:
    assert err.count("\n") == 1 and err.startswith("inclino: error: "), err
    assert "Traceback" not in err and needle in err, err


def _rewrite(src: Path, dst: Path, column: str, fn, extra=None, rows=None, skip=0) -> None:
    """The log at src with `column` rewritten by fn (and a column `extra` =
    (name, fn(row index, row)) added), its first `rows` data rows only; the
    column names on the first line after `skip` lines not a comment."""
    lines = list(csv.reader(src.open(newline="")))
    h = next(i for i, r in enumerate(lines) if i >= skip and r and not r[0].startswith("#"))
    j = lines[h].index(column) if column else None
    with dst.open("w", newline="") as f:
        w = csv.writer(f)
        for i, r in enumerate(lines[:h + 1 + (rows if rows else len(lines))]):
            if i == h and extra:
                r = r + [extra[0]]
            elif i > h:
                if j is not None:
                    r = r[:j] + [fn(r[j])] + r[j + 1:]
                if extra:
                    r = r + [extra[1](i - h - 1, r)]
            w.writerow(r)


def _desc(tmp_path, src: Path, old: str, new: str, name="d.toml") -> Path:
    text = src.read_text()
    assert old in text
    p = tmp_path / name
    p.write_text(text.replace(old, new, 1))
    return p


def _found(log, desc):
    ds, _ = importlog.import_log(str(log), sensor.load(str(desc)))
    return ds, checks.run(ds)


def _time(rep):
    return [f for f in rep.findings if f.check == "time"]


# ------------------------------------------------------------------ (a) the time unit
def test_time_in_ms_declared_as_s_is_named_with_the_fix(tmp_path, capsys):
    # BROAD's trial 05 turned by hand at 14.3 rows/s: its t_s written in ms, the description still says s
    log = tmp_path / "05_ms.csv"
    _rewrite(BROAD, log, "t_s", lambda v: repr(round(float(v) * 1000.0, 3)))
    desc = REAL / "broad" / "with_acc.toml"
    ds, rep = _found(log, desc)
    (f,) = _time(rep)
    assert f.level == "warning" and f.figures["looks_like"] == "ms"
    assert 0.05 < f.figures["turn_deg_s"] < 0.2 and 10 < f.figures["rows_per_s"] * 1000 < 20
    assert 'time_unit = "ms" (declared "s")' in f.message
    assert main(["import", str(log), "--sensor", str(desc), "-o", str(tmp_path / "run.csv")]) == 0
    out = capsys.readouterr().out
    assert 'warning: the time column\'s unit does not fit the rows' in out and 'time_unit = "ms"' in out
    # the fix named imports it clean
    fixed = _desc(tmp_path, desc, 'time_unit = "s"', 'time_unit = "ms"', "fixed.toml")
    assert not _time(_found(log, fixed)[1])


def test_time_in_s_declared_as_ms_is_named(tmp_path):
    desc = _desc(tmp_path, REAL / "broad" / "with_acc.toml", 'time_unit = "s"', 'time_unit = "ms"')
    (f,) = _time(_found(BROAD, desc)[1])
    assert f.level == "warning" and f.figures["looks_like"] == "s"
    assert f.figures["turn_deg_s"] > 5000 and 'time_unit = "s" (declared "ms")' in f.message


def test_time_in_us_declared_as_ms_is_named(tmp_path):
    desc = _desc(tmp_path, FUSION / "sensor.toml", 'time_unit = "us"', 'time_unit = "ms"')
    (f,) = _time(_found(FUSION / "mpudata.csv", desc)[1])
    assert f.level == "warning" and f.figures["looks_like"] == "us"


@pytest.mark.parametrize("declared", ["min", "h"])
def test_time_in_us_declared_in_minutes_or_hours_names_us(tmp_path, declared):
    """A named unit before a sample period: us declared as min read 6e7x slow,
    and 1e-6 min (1/16 666.7 s, first among the prefixes) made the rows and
    the turning a hand's as well as us did; followed, the rows were 60x off."""
    desc = _desc(tmp_path, FUSION / "sensor.toml", 'time_unit = "us"', f'time_unit = "{declared}"')
    (f,) = _time(_found(FUSION / "mpudata.csv", desc)[1])
    assert f.figures["looks_like"] == "us" and f'time_unit = "us" (declared "{declared}")' in f.message
    fixed = _desc(tmp_path, FUSION / "sensor.toml", 'time_unit = "us"', 'time_unit = "us"', "fixed.toml")
    assert not _time(_found(FUSION / "mpudata.csv", fixed)[1])


def test_a_turn_no_hand_makes_is_refused_with_the_rate_to_write(tmp_path, capsys):
    # the MPU-6050's step-and-hold session (100 Hz) declared at 100 kHz: its hand turns it at 4.7e5 deg/s
    desc = _desc(tmp_path, MPU / "sensor.toml", "rate_hz = 100", "rate_hz = 100000")
    assert main(["import", str(MPU / "example_data_calibration.csv"), "--sensor", str(desc),
                 "-o", str(tmp_path / "run.csv")]) == 2
    err = capsys.readouterr().err
    _one_error(err, "rate_hz = 100, 1000x less, is among them")
    lo, hi = (float(x) for x in re.search(r"at ([\d.e+]+) to ([\d.e+]+) Hz the sensor would turn", err).groups())
    assert lo <= 100 <= hi, err
    assert not (tmp_path / "run.csv").exists()
    desc = _desc(tmp_path, MPU / "sensor.toml", "rate_hz = 100", "rate_hz = 0.1", "slow.toml")
    (f,) = _time(_found(MPU / "example_data_calibration.csv", desc)[1])
    assert f.level == "warning" and f.figures["looks_like"] == "100 Hz"


def test_a_declared_static_log_is_not_read_as_turning(tmp_path):
    # one row a position, each read at rest: a turn of degrees a row says nothing of the time between rows
    log = tmp_path / "05_ms.csv"
    _rewrite(BROAD, log, "t_s", lambda v: repr(round(float(v) * 1000.0, 3)))
    desc = _desc(tmp_path, REAL / "broad" / "with_acc.toml", "[log]\n", "[log]\nstatic = true\n")
    assert not _time(_found(log, desc)[1])


# ------------------------------------------------------------------ (b) the temperature column
def _with_temp(tmp_path, fn, rows=None):
    log = tmp_path / "05_temp.csv"
    _rewrite(BROAD, log, None, None, extra=("temp", fn), rows=rows)
    desc = _desc(tmp_path, REAL / "broad" / "with_acc.toml", 'time_unit = "s"\n',
                 'time_unit = "s"\ntemperature = "temp"\n', "temp.toml")
    return log, desc


def test_a_constant_temperature_is_said_and_fits_no_terms(tmp_path, capsys):
    log, desc = _with_temp(tmp_path, lambda i, r: "23.5", rows=1200)
    run = tmp_path / "run.csv"
    assert main(["import", str(log), "--sensor", str(desc), "-o", str(run)]) == 0
    out = capsys.readouterr().out
    assert "note: temp_c is 23.5 degC on every row" in out and "determines no temperature terms" in out
    cal = tmp_path / "cal.json"
    assert main(["calibrate", str(run), "-o", str(cal)]) in (0, 1)
    out = capsys.readouterr().out
    assert "note: temperature terms not fitted (the run spans 0.0 degC" in out
    import json

    assert not json.loads(cal.read_text()).get("temperature")


def _counter(tmp_path):
    # a SAP6 instrument's 24 shots (no time column) with a row counter mapped as its temperature
    log = tmp_path / "sap_temp.csv"
    _rewrite(REAL / "sap6" / "BB.csv", log, None, None, extra=("n", lambda i, r: str(i)))
    desc = _desc(tmp_path, REAL / "sap6" / "sensor.toml", "static = true", 'static = true\ntemperature = "n"',
                 "temp.toml")
    return log, desc


@pytest.mark.parametrize("what, make, needle", [
    ("an accelerometer column", lambda p: _with_temp(p, lambda i, r: r[2]),
     "the sensor column ax_g up to a scale and an offset"),
])
def test_a_temperature_that_is_no_temperature_is_refused(tmp_path, capsys, what, make, needle):
    log, desc = make(tmp_path)
    run = tmp_path / "run.csv"
    assert main(["import", str(log), "--sensor", str(desc), "-o", str(run)]) == 2, what
    _one_error(capsys.readouterr().err, needle)
    assert not run.exists()
    # the same column in a run imported before: calibrate and diagnose refuse it before any fit
    ds, _ = importlog.import_log(str(log), sensor.load(str(desc)))
    dataset.write_raw(str(run), ds)
    for cmd in (["calibrate", str(run), "-o", str(tmp_path / "c.json")], ["diagnose", str(run)]):
        assert main(cmd) == 2, cmd
        _one_error(capsys.readouterr().err, "temp_c does not look like a temperature")
    # in a canonical dataset (no description to fix) a note; calibrate and diagnose leave it out
    canon = dataset.RawDataset(dict(ds.columns), {k: v for k, v in ds.meta.items() if k in ("field_nT", "dip_deg")})
    (f,) = [f for f in checks.run(canon).findings if f.check == "temperature"]
    assert f.level == "note" and "leave it out" in f.message


def test_a_canonical_temperature_that_is_no_temperature_fits_no_terms(tmp_path):
    # a SAP6 instrument's shots with temp_c a copy of its ax_g column, in the canonical format:
    # the temperature fit is never tried on it, the diagnosis tests no temperature effect against it
    from inclino.calib import thermal
    from inclino.diagnose.analysis import diagnose
    from inclino.errors import CalibrationError

    ds, _ = importlog.import_log(str(REAL / "sap6" / "BB.csv"), sensor.load(str(REAL / "sap6" / "sensor.toml")))
    canon = dataset.RawDataset({**ds.columns, "temp_c": 20.0 + 10.0 * ds.columns["ax_g"]}, {})
    info = {"notes": [], "mode": "poses"}
    cal, info2 = thermal._fit(canon, None, info, "auto", 1, 1, 1, False, 0)
    assert cal is None and "temperature terms not fitted (temp_c does not look like a temperature: it is the " \
                          "sensor column ax_g" in info2["notes"][-1]
    with pytest.raises(CalibrationError, match="temp_c does not look like a temperature"):
        thermal._fit(canon, None, {"notes": [], "mode": "poses"}, "on", 1, 1, 1, False, 0)
    r = diagnose(canon)
    assert any("temp_c left out: it does not look like a temperature" in n for n in r.baseline["selection"]["notes"])


# ------------------------------------------------------------------ (c) one orientation held
def _static(tmp_path):
    """The first 30 s of the MPU-6050 session: the board lying still (3000 rows of one orientation)."""
    lines = (MPU / "example_data_calibration.csv").read_text().splitlines()
    log = tmp_path / "still.csv"
    log.write_text("\n".join(lines[:5 + 3000]) + "\n")
    run = tmp_path / "still_run.csv"
    assert main(["import", str(log), "--sensor", str(MPU / "sensor.toml"), "-o", str(run)]) == 0
    return run


def test_one_orientation_is_noted_and_calibrate_and_diagnose_say_the_data_do_not_determine_it(tmp_path, capsys):
    run = _static(tmp_path)
    out = capsys.readouterr().out
    assert "note: every row reads one orientation (3000 rows" in out
    for cmd, code in ((["diagnose", str(run)], 2), (["diagnose", str(run), "--json"], 2),
                      (["calibrate", str(run), "-o", str(tmp_path / "c.json")], 3)):
        assert main(cmd) == code, cmd
        cap = capsys.readouterr()
        _one_error(cap.err, "the data do not determine the model")
        assert "12 or more orientations" in cap.err and "FAIL" not in cap.out + cap.err
    assert not (tmp_path / "c.json").exists()
    # attitude fits nothing: each row is computed as the probe would
    assert main(["attitude", str(run), "-o", str(tmp_path / "att.csv")]) == 0


def test_one_orientation_refused_by_the_library_too(tmp_path):
    from inclino.calib import fit
    from inclino.diagnose.analysis import diagnose
    from inclino.errors import CalibrationError, DataError

    ds = dataset.read_raw(str(_static(tmp_path)))
    with pytest.raises(CalibrationError, match="singular fit refused: every row reads one orientation"):
        fit(ds, "joint")
    with pytest.raises(DataError, match="the data do not determine the model"):
        diagnose(ds)


# ------------------------------------------------------------------ the corpus as published
CORPUS = [("imucal_ferraris/annotated_session.csv", "imucal_ferraris/sensor.toml"),
          ("ck_acc_mag/acc_mag_log.csv", "ck_acc_mag/sensor.toml"),
          ("ck_acc_mag/acc_log.csv", "ck_acc_mag/acc_only.toml"),
          ("broad/05.csv", "broad/sensor.toml"), ("broad/02.csv", "broad/with_acc.toml"),
          ("micropython_fusion/mpudata.csv", "micropython_fusion/sensor.toml"),
          ("mpu6050_tedaldi/example_data_calibration.csv", "mpu6050_tedaldi/sensor.toml"),
          ("qmc5883l/filtered_raw_data.csv", "qmc5883l/sensor.toml"), ("sap6/BB.csv", "sap6/sensor.toml")]


@pytest.mark.parametrize("log, desc", CORPUS)
def test_the_corpus_as_published_raises_none_of_these(log, desc):
    ds, rep = _found(REAL / log, REAL / desc)
    assert not [f for f in rep.findings if f.check in ("time", "temperature", "orientations")], rep.lines()
    assert rep.one_orientation is None
    if "t_s" in ds.columns and rep.time["turn"]:  # the rates the hands turned the logs at
        assert 1.0 <= rep.time["turn_deg_s"] <= 5000.0


@pytest.mark.parametrize("what, make, needle", [
    ("the time column", lambda p: _with_temp(p, lambda i, r: r[1], 250), "the time t_s up to a scale and an offset"),
    ("a row counter", _counter, "steps by exactly 1 every row"),
])
def test_a_temperature_exactly_linear_in_time_or_rows_is_a_note_and_used(tmp_path, capsys, what, make, needle):
    """A chamber ramp simulated as temp_c = a + b t (or sampled at a constant
    rate, so that it steps by the same amount every row) reads exactly like
    a clock mapped as the temperature: the data cannot tell them apart, so
    the import says so and keeps the column (refusing it would refuse every
    simulated oven run)."""
    log, desc = make(tmp_path)
    run = tmp_path / "run.csv"
    assert main(["import", str(log), "--sensor", str(desc), "-o", str(run)]) == 0, what
    out = capsys.readouterr().out
    assert "temp_c rises exactly linearly" in out and needle in out and "it is used as the temperature" in out
    ds, _ = importlog.import_log(str(log), sensor.load(str(desc)))
    assert checks.not_a_temperature(ds) is None and checks.temperature_ramp(ds) is not None


def test_a_rate_not_a_unit_off_is_given_the_rates_that_fit_not_one(tmp_path):
    """A declared rate is no unit: the MPU-6050's 100 Hz session declared
    10 000 Hz (100x off) was told a rate 1000x off (10 Hz), as an FXOS8700
    at 10 Hz declared 1000 was told 1 Hz.  The rates that make the turning a
    hand's are said; the log's own rate lies among them."""
    desc = _desc(tmp_path, MPU / "sensor.toml", "rate_hz = 100", "rate_hz = 10000")
    (f,) = _time(_found(MPU / "example_data_calibration.csv", desc)[1])
    lo, hi = f.figures["rate_hz_range"]
    assert lo <= 100 <= hi and "looks_like" not in f.figures and "rate_hz = 10 " not in f.message, f.message


def test_a_column_that_is_not_a_time_is_said_not_to_be_one():
    """A barometer's pressure mapped as the time (standing still on 82 % of
    its steps, going back on 6 %) was given a unit, "1/0.001 s"."""
    ds = importlog.import_log(str(REAL / "ck_acc_mag" / "acc_mag_log.csv"),
                              sensor.load(str(REAL / "ck_acc_mag" / "sensor.toml")))[0]
    rng = np.random.default_rng(3)
    # a reading in hundredths of a mbar, updated every 5th row
    ds.columns["t_s"] = np.repeat(1013.0 + 0.01 * rng.integers(-2, 3, size=len(ds) // 5 + 1), 5)[:len(ds)]
    (f,) = _time(checks.run(ds))
    assert "does not look like a time" in f.message and "time_unit" not in f.message, f.message


def _turntable_log(tmp_path, seed, name="tt.csv"):
    """A turntable session: 30 random positions read 5-10 rows each, a row a
    second (time in ms), the turns between them not logged (20 s each):
    written with its time column in ms and a description that declares s."""
    from scipy.spatial.transform import Rotation

    rng = np.random.default_rng(seed)
    rows, t = [], 0.0
    for body in Rotation.random(30, random_state=seed):
        g = body.inv().apply([0.0, 0.0, 1.0])
        b = body.inv().apply([24.0, 0.0, 41.6])  # uT, 60 deg dip
        for _ in range(rng.integers(5, 11)):
            rows.append([t * 1000.0, *(g + rng.normal(0, 3e-4, 3)), *(b + rng.normal(0, 0.025, 3))])
            t += 1.0
        t += 20.0
    log = tmp_path / name
    with log.open("w", newline="") as f:
        w = csv.writer(f)
        w.writerow(["time_ms", "ax", "ay", "az", "mx", "my", "mz"])
        w.writerows([[f"{x:.6g}" for x in r] for r in rows])
    desc = tmp_path / "tt.toml"
    desc.write_text('[log]\ntime = "time_ms"\ntime_unit = "s"\n'
                    '[accelerometer]\ncolumns = ["ax", "ay", "az"]\nunit = "g"\naxes = "x = ax, y = ay, z = az"\n'
                    '[magnetometer]\ncolumns = ["mx", "my", "mz"]\nunit = "uT"\naxes = "x = mx, y = my, z = mz"\n')
    return log, desc


@pytest.mark.parametrize("seed", range(6))
def test_a_turntable_session_whose_turns_are_not_logged_gets_no_unit_from_them(tmp_path, seed):
    """Consecutive rows either read one position or jump between two: no
    turn is logged, so no turning rate can name a unit (pairs of rows further
    apart compare positions that happen to lie within 30 deg: "us" was named
    on such a session, ms declared s, and its fix followed would read a row
    every millisecond)."""
    ds, rep = _found(*_turntable_log(tmp_path, seed))
    assert not [f for f in _time(rep) if f.figures.get("looks_like")], _time(rep)


def _six_faces_warming(tmp_path, declared, scale=1.0):
    """An MPU-6050-like log of six faces held 30 s each at 62.5 rows/s, its
    time an uptime counter in ms (a row every 16 ms, each face's file
    timed from its own start and joined), its die warming by 0.1 degC over
    each hold (0.0033 degC/s: a part settling on a bench) and read with a
    noise of 0.01 degC; `declared` the time unit the description gives,
    `scale` the warming rate's factor."""
    rng = np.random.default_rng(11)
    faces = [(1, 0, 0), (-1, 0, 0), (0, 1, 0), (0, -1, 0), (0, 0, 1), (0, 0, -1)]
    n = 1875  # 30 s at 62.5 rows/s
    lines = ["t_ms,ax,ay,az,temp"]
    for k, f in enumerate(faces):
        t = 410 + 16 * np.arange(n)
        T = 26.0 + 0.3 * k + scale * 0.1 * (t - t[0]) / 30_000.0 + rng.normal(0.0, 0.01, n)
        a = np.asarray(f, float) + rng.normal(0.0, 0.002, (n, 3))
        lines += [f"{ti},{x:.4f},{y:.4f},{z:.4f},{Ti:.3f}" for ti, (x, y, z), Ti in zip(t, a, T)]
    (tmp_path / "six.csv").write_text("\n".join(lines) + "\n")
    (tmp_path / "six.toml").write_text(f'''name = "six faces, millis()"
[log]
time = "t_ms"
time_unit = "{declared}"
static = true
temperature = "temp"
[accelerometer]
columns = ["ax", "ay", "az"]
unit = "g"
reads = "up"
axes = "x = ax, y = ay, z = az"
''')
    return _found(tmp_path / "six.csv", tmp_path / "six.toml")


def test_an_uptime_counter_in_ms_declared_us_is_named_by_the_temperature(tmp_path):
    # a static log: no turning tells the time; 62 500 rows/s is within what a logger writes; the die warming by
    # 0.1 degC in a 30 s hold read as 30 ms is 3.3 degC/s, which no sensor's temperature does
    ds, rep = _six_faces_warming(tmp_path, "us")
    (f,) = _time(rep)
    assert f.level == "warning" and 'time_unit = "ms" (declared "us")' in f.message and "degC/s" in f.message
    assert f.figures["looks_like"] == "ms" and 3.0 < f.figures["temp_rate_c_s"] < 3.7
    # declared as logged: nothing said
    ds, rep = _six_faces_warming(tmp_path, "ms")
    assert not _time(rep) and rep.time["temp_rate_c_s"] < 0.004
    # a chamber ramping fast, 0.33 degC/s (100x the bench's warming), timed in ms as declared, is no time slip
    ds, rep = _six_faces_warming(tmp_path, "ms", scale=100.0)
    assert not _time(rep) and 0.3 < rep.time["temp_rate_c_s"] < 0.37


def test_a_static_log_names_every_unit_its_rates_allow(tmp_path):
    # without the turning, the row rate and the temperature's are all there is: 62.5 rows/s warming 0.0033 degC/s
    # (ms) and 625 rows/s warming 0.033 degC/s (a 100 us tick counter) are both what loggers and dies do; "ms"
    # alone had been named on a factor of 10 nothing in the rows shows
    for declared in ("us", "ns"):
        ds, rep = _six_faces_warming(tmp_path, declared)
        (f,) = _time(rep)
        assert f'time_unit = "ms" (declared "{declared}"), or "100 us"' in f.message, f.message
        assert "nothing in the rows tells these apart" in f.message
        assert f.figures["looks_like"] == "ms" and f.figures["also_fits"] == ["100 us"]



@pytest.mark.parametrize("log, desc, unit, declared", [
    ("xio_fusion/sensor_data.csv", "xio_fusion/sensor.toml", "s", "h"),
    ("broad/05.csv", "broad/with_acc.toml", "s", "100 us"),
    ("pololu_minimu9/data_polulu.txt", "pololu_minimu9/sensor.toml", "ms", "100 us"),
])
def test_the_corpus_in_another_unit_is_told_its_own(tmp_path, log, desc, unit, declared):
    # x-io's seconds declared h had been told "min" (6.95 deg/s, 1.65 rows/s); declared as a tick, BROAD's seconds
    # "1/10 s" and the MinIMU's ms "1/10 s" (7.07 deg/s): a unit that puts the turning where hands turn comes first
    d = _desc(tmp_path, REAL / desc, f'time_unit = "{unit}"', f'time_unit = "{declared}"')
    (f,) = _time(_found(REAL / log, d)[1])
    assert f'time_unit = "{unit}" (declared "{declared}")' in f.message and "also_fits" not in f.figures, f.message
