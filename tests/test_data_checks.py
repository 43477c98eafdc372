"""Checks before any fit (inclino.checks) on the real-data corpus and on
corrupted copies of it: each corruption gives its named error or warning,
the clean logs give none, and the commands exit 2 before any fit."""
import json
import re
from pathlib import Path

import numpy as np
import pytest

from inclino import checks
from inclino.cli import main
from inclino.formats import dataset, importlog, sensor
from rows import shifted as _shifted

REAL = Path(__file__).parent / "data" / "real"
BOTH = [("sap6/BB.csv", "sap6/sensor.toml"), ("sap6/CF.csv", "sap6/sensor.toml"), ("sap6/JG.csv", "sap6/sensor.toml"),
        ("ck_acc_mag/acc_mag_log.csv", "ck_acc_mag/sensor.toml")]
ACC_POSES = ("imucal_ferraris/annotated_session.csv", "imucal_ferraris/sensor.toml")
ALL = BOTH + [ACC_POSES, ("ck_acc_mag/acc_log.csv", "ck_acc_mag/acc_only.toml")]


def _load(log, desc):
    return importlog.import_log(str(REAL / log), sensor.load(str(REAL / desc)))[0]


def _with(ds, **cols):
    c = {k: v.copy() for k, v in ds.columns.items()}
    c.update(cols)
    return dataset.RawDataset(c, dict(ds.meta))


def _found(rep, check, level):
    return [f for f in rep.findings if f.check == check and f.level == level]


@pytest.mark.parametrize("log,desc", ALL)
def test_clean_corpus_logs_pass_the_checks(log, desc):
    rep = checks.run(_load(log, desc))
    assert not rep.errors and not rep.warnings, rep.lines()


@pytest.mark.parametrize("log,desc", BOTH + [ACC_POSES])
def test_acceleration_in_m_s2_is_named(log, desc):
    ds = _load(log, desc)
    rep = checks.run(_with(ds, **{c: ds.columns[c] * 9.80665 for c in dataset.ACC_COLS}))
    (f,) = _found(rep, "units", "error")
    assert "m/s^2" in f.message and f.triad == "acc"


@pytest.mark.parametrize("log,desc", BOTH)
def test_field_in_microtesla_is_named(log, desc):
    ds = _load(log, desc)
    rep = checks.run(_with(ds, **{c: ds.columns[c] / 1000.0 for c in dataset.MAG_COLS}))
    (f,) = _found(rep, "units", "error")
    assert "uT" in f.message and f.triad == "mag"


@pytest.mark.parametrize("log,desc", BOTH)
@pytest.mark.parametrize("col", ["my_nT", "ay_g", "mz_nT"])
def test_a_mirrored_axis_is_named(log, desc, col):
    ds = _load(log, desc)
    rep = checks.run(_with(ds, **{col: -ds.columns[col]}))
    assert _found(rep, "handedness", "error"), rep.lines()


@pytest.mark.parametrize("log,desc", BOTH)
def test_swapped_magnetometer_axes_are_named(log, desc):
    ds = _load(log, desc)
    rep = checks.run(_with(ds, mx_nT=ds.columns["my_nT"], my_nT=ds.columns["mx_nT"]))
    assert _found(rep, "handedness", "error"), rep.lines()


def test_a_mirrored_axis_against_the_poses_is_named():
    ds = _load(*ACC_POSES)
    rep = checks.run(_with(ds, ay_g=-ds.columns["ay_g"]))
    assert _found(rep, "handedness", "error"), rep.lines()


def test_a_flipped_accelerometer_sign_is_named_against_the_poses():
    ds = _load(*ACC_POSES)
    rep = checks.run(_with(ds, **{c: -ds.columns[c] for c in dataset.ACC_COLS}))
    (f,) = _found(rep, "dip-sign", "error")
    assert "sign" in f.message and "reads" in f.message


@pytest.mark.parametrize("log,desc", BOTH[:3])
def test_a_flipped_accelerometer_sign_is_named_against_the_header_dip(log, desc):
    ds = _load(log, desc)
    ds.meta["dip_deg"] = 67.8  # the instruments' own fitted dip (their .cfg)
    assert not checks.run(ds).errors
    rep = checks.run(_with(ds, **{c: -ds.columns[c] for c in dataset.ACC_COLS}))
    (f,) = _found(rep, "dip-sign", "error")
    assert "gravity sign" in f.message


@pytest.mark.parametrize("log,desc", BOTH[:3])
@pytest.mark.parametrize("k", [1, -1, 2])
def test_triads_shifted_by_rows_are_named_with_the_shift(log, desc, k):
    rep = checks.run(_shifted(_load(log, desc), k))
    (f,) = _found(rep, "row-alignment", "error")
    assert rep.lag_rows == k and f"{k:+d}" in f.message
    assert f"its row i {'+' if k > 0 else '-'} {abs(k)} belongs" in f.message and "+ -" not in f.message


@pytest.mark.parametrize("log,desc", BOTH[:3])
@pytest.mark.parametrize("k", [1, -1])
def test_a_shift_in_a_step_and_hold_log_is_named(log, desc, k):
    """Many rows per position (each shot held for 30 readings, with noise):
    a one-row shift mispairs only the rows where the position changes."""
    ds = _load(log, desc)
    rng = np.random.default_rng(7)
    c = {key: np.repeat(v, 30) for key, v in ds.columns.items()}
    for key in dataset.ACC_COLS:
        c[key] = c[key] + rng.normal(0.0, 1e-3, len(c[key]))
    for key in dataset.MAG_COLS:
        c[key] = c[key] + rng.normal(0.0, 100.0, len(c[key]))
    held = dataset.RawDataset(c, dict(ds.meta))
    assert checks.run(held, declared_static=True).lag_rows == 0
    rep = checks.run(_shifted(held, k), declared_static=True)
    (f,) = _found(rep, "row-alignment", "warning")
    assert rep.lag_rows == k and f"lag = {k}" in f.message


def test_the_lag_named_is_the_lag_that_fixes_the_import(tmp_path):
    rows = (REAL / "sap6" / "BB.csv").read_text().splitlines()
    head, body = rows[0], [r.split(",") for r in rows[1:]]
    shifted = [",".join(a[:5] + b[5:]) for a, b in zip(body[:-1], body[1:])]  # magnetometer one row ahead
    log = tmp_path / "two_files_joined.csv"
    log.write_text("\n".join([head] + shifted) + "\n")
    desc = sensor.load(str(REAL / "sap6" / "sensor.toml"))
    rep = checks.run(importlog.import_log(str(log), desc)[0])
    assert rep.lag_rows == -1
    desc.mag.lag = rep.lag_rows
    fixed = importlog.import_log(str(log), desc)[0]
    assert len(fixed) == 22 and not checks.run(fixed).errors


def test_import_refuses_data_that_cannot_be_right_and_writes_nothing(tmp_path, capsys):
    text = (REAL / "sap6" / "sensor.toml").read_text().replace('unit = "m/s2"', 'unit = "g"')
    desc = tmp_path / "wrong.toml"
    desc.write_text(text)
    out = tmp_path / "run.csv"
    assert main(["import", str(REAL / "sap6" / "BB.csv"), "--sensor", str(desc), "-o", str(out)]) == 2
    err = capsys.readouterr().err
    assert err.count("\n") == 1 and "m/s^2" in err and not out.exists()


def test_calibrate_refuses_wrong_units_before_any_fit(tmp_path, capsys):
    ds = _load("sap6/CF.csv", "sap6/sensor.toml")
    bad = _with(ds, **{c: ds.columns[c] / 1000.0 for c in dataset.MAG_COLS})
    run = tmp_path / "run.csv"
    dataset.write_raw(str(run), bad)
    cal = tmp_path / "cal.json"
    assert main(["calibrate", str(run), "-o", str(cal)]) == 2
    err = capsys.readouterr().err
    assert "uT" in err and err.count("\n") == 1 and not cal.exists()


def test_a_left_handed_map_in_a_description_is_refused_unless_declared(tmp_path):
    text = (REAL / "ck_acc_mag" / "sensor.toml").read_text().replace('axes = "x = mx, y = my, z = mz"',
                                                                      'axes = "x = mx, y = -my, z = mz"')
    with pytest.raises(Exception) as e:
        sensor.from_toml(text)
    assert "reflection" in str(e.value) and "determinant -1" in str(e.value)
    ok = sensor.from_toml(text.replace('lsb = "0.14 mG"', 'lsb = "0.14 mG"\nreflection = true'))
    assert ok.mag.det == -1


def test_saturated_rows_are_named():
    ds = _load("ck_acc_mag/acc_mag_log.csv", "ck_acc_mag/sensor.toml")
    ax = ds.columns["ax_g"].copy()
    ax[:7] = 2.0
    ds.meta["acc_range_g"] = 2.0
    rep = checks.run(_with(ds, ax_g=ax))
    (f,) = _found(rep, "saturation", "warning")
    assert rep.saturated == list(range(7))


def test_static_or_moving_from_the_readings_not_the_time_column():
    faces = _load(*ACC_POSES)  # static faces, with a time column
    assert checks.run(faces).static is True
    tumbled = _load("ck_acc_mag/acc_mag_log.csv", "ck_acc_mag/sensor.toml")  # no time column, moving
    rep = checks.run(tumbled)
    assert rep.static is False and _found(rep, "motion", "note")
    rep = checks.run(tumbled, declared_static=True)
    assert rep.declared_static and rep.static is None


def _ck_mirrored_weakly(monkeypatch, tmp_path, dip_deg):
    """The CK log with the magnetometer's y column negated, as a log whose
    mirror the checks before the fit see only weakly (a warning: the error's
    AXES_RATIO raised out of reach), with or without a header dip."""
    monkeypatch.setattr(checks, "AXES_RATIO", 1e9)
    ds = _load("ck_acc_mag/acc_mag_log.csv", "ck_acc_mag/sensor.toml")
    bad = _with(ds, my_nT=-ds.columns["my_nT"])
    if dip_deg is not None:
        bad.meta["dip_deg"] = dip_deg
    assert _found(checks.run(bad), "handedness", "warning")
    run = tmp_path / "run.csv"
    dataset.write_raw(str(run), bad)
    return run


def test_a_fit_that_turned_the_field_is_refused_against_the_header_dip(monkeypatch, tmp_path, capsys):
    """A mirrored axis fitted as a rotation (-P for the reflection P) fits
    the invariants as well as the right map, with the dip's sign turned and
    every azimuth 180 deg off: the fitted dip against the header's refuses
    it (exit 2, one line, nothing written)."""
    run = _ck_mirrored_weakly(monkeypatch, tmp_path, -17.8)  # the CK log's own dip (sensor.toml)
    cal = tmp_path / "cal.json"
    capsys.readouterr()
    assert main(["calibrate", str(run), "-o", str(cal)]) == 2
    err = capsys.readouterr().err
    assert err.count("\n") == 1 and "+17.8 deg against the header's -17.8" in err
    assert "through 180 deg" in err and "mirrored" in err and "reads" in err
    assert sorted(p.name for p in tmp_path.iterdir()) == ["run.csv"]  # nothing written, not even a part


def test_the_clean_log_with_its_header_dip_is_not_refused_after_the_fit(tmp_path):
    ds = _load("ck_acc_mag/acc_mag_log.csv", "ck_acc_mag/sensor.toml")
    ds.meta["dip_deg"] = -17.8
    run = tmp_path / "run.csv"
    dataset.write_raw(str(run), ds)
    assert main(["calibrate", str(run), "-o", str(tmp_path / "cal.json")]) in (0, 1)


def test_a_fitted_dip_far_from_the_header_dip_of_the_same_sign_is_said(tmp_path, capsys):
    """A fitted dip far from the header's, the same sign, was written without
    a word (freeIMUCal's office log: +73.5 deg against WMM's +58.6; only
    `attitude --cal` said it).  The report says it after the fit, as the
    checks say a raw dip off before it; within 10 deg nothing is said."""
    ds = _load("ck_acc_mag/acc_mag_log.csv", "ck_acc_mag/sensor.toml")
    for hdr, said in ((-40.0, True), (-17.8, False)):
        ds.meta["dip_deg"] = hdr
        run = tmp_path / "run.csv"
        dataset.write_raw(str(run), ds)
        capsys.readouterr()
        assert main(["calibrate", str(run), "-o", str(tmp_path / "cal.json"), "--json"]) in (0, 1)
        notes = [n for n in json.loads(capsys.readouterr().out)["report"]["notes"] if "the fitted dip" in n]
        if said:
            assert len(notes) == 1 and "-17.8 deg against the header's -40.0" in notes[0], notes
            assert "22.2 deg apart" in notes[0] and "inclino reffield" in notes[0], notes[0]
        else:
            assert not notes, notes


def test_a_fit_that_may_have_turned_the_field_asks_for_the_dip(monkeypatch, tmp_path, capsys):
    run = _ck_mirrored_weakly(monkeypatch, tmp_path, None)
    capsys.readouterr()
    assert main(["calibrate", str(run), "-o", str(tmp_path / "cal.json"), "--json"]) in (0, 1)
    every = json.loads(capsys.readouterr().out)["report"]["notes"]
    notes = [n for n in every if "180 deg" in n]
    after = [n for n in notes if n.startswith("check: warning: the fitted dip is +17.8 deg")]
    assert len(after) == 1 and "may have turned the field" in after[0] and "dip_deg" in after[0], notes
    assert "with the dip's sign turned" in after[0], after[0]  # the mirror's twin named beside it
    # the checks before the fit say it too, naming the mirror and its twin, the rotation that fits alike
    before = [n for n in every if "may not fit the accelerometer's" in n]
    assert len(before) == 1 and "dip_deg" in before[0] and "right-handed" in before[0] and "left-handed" in before[0]


SAP6_TOML = (REAL / "sap6" / "sensor.toml").read_text() + "\n[header]\ndip_deg = 67.8\n"  # the instruments' own dip


def _sap6_with(tmp_path, log, text):
    """SAP6's BB log imported through the description `text`: the checks' report."""
    return checks.run(importlog.import_log(str(log), sensor.from_toml(text))[0])


def _with_mag_map(text, M):
    """The SAP6 description with its magnetometer's map replaced by M (and
    reflection = true exactly when M is a reflection)."""
    axes = ", ".join(f"{b} = {'-' if M[i, j] < 0 else ''}m{'xyz'[j]}" for i, b in enumerate("xyz")
                     for j in [int(np.argmax(np.abs(M[i])))])
    mag = text.index("[magnetometer]")
    head, tail = text[:mag], text[mag:]
    tail = tail.replace('axes = "x = -mz, y = mx, z = my"', f'axes = "{axes}"')
    tail = tail.replace("reflection = true", "reflection = true" if np.linalg.det(M) < 0 else "reflection = false")
    return head + tail


@pytest.mark.parametrize("Q", [[[0, 1, 0], [1, 0, 0], [0, 0, 1]], [[1, 0, 0], [0, -1, 0], [0, 0, 1]],
                               [[0, -1, 0], [1, 0, 0], [0, 0, 1]], [[-1, 0, 0], [0, -1, 0], [0, 0, 1]]],
                         ids=["swap-xy", "mirror-y", "turn-z-90", "turn-z-180"])
def test_the_axis_map_suggested_is_the_map_to_write(tmp_path, Q):
    """SAP6 declares a map that is neither the identity nor a rotation
    (x = -mz, y = mx, z = my, reflection = true). A wrong map Q composed
    with it is named, and the map the checks suggest is the map to write in
    [magnetometer] axes (not the permutation in the body frame as imported,
    which is that map only for an identity declared map): following it
    imports the log clean."""
    log = REAL / "sap6" / "BB.csv"
    D = sensor.from_toml(SAP6_TOML).mag.matrix
    clean = _sap6_with(tmp_path, log, SAP6_TOML)
    assert not clean.errors and not clean.warnings, clean.lines()
    wrong = np.array(Q, float) @ D
    rep = _sap6_with(tmp_path, log, _with_mag_map(SAP6_TOML, wrong))
    (f,) = [f for f in rep.findings if f.check in ("handedness", "axes") and f.level in ("error", "warning")]
    # the map the message names, as a user reads it
    write = re.search(r'deg with magnetometer (?:axes = ")?(x = -?m[xyz], y = -?m[xyz], z = -?m[xyz])', f.message)[1]
    W = sensor.from_toml(f'[magnetometer]\ncolumns = ["a", "b", "c"]\naxes = "{write}"\nreflection = true\n').mag.matrix
    assert np.array_equal(W, D), (write, f.message)
    assert f.figures["map_to_write"] == write and f'axes = "{write}"' in f.message
    # a reflection to write where the wrong map was a rotation: the message says to declare it
    assert ("with reflection = true" in f.message) == (np.linalg.det(W) < 0 < np.linalg.det(wrong))
    fixed = _sap6_with(tmp_path, log, _with_mag_map(SAP6_TOML, W))
    assert not fixed.errors and not fixed.warnings, fixed.lines()


@pytest.mark.parametrize("declared,shift", [(1, 0), (-1, 0), (2, 0), (1, -1), (-2, -1)])
def test_the_lag_suggested_adds_the_shift_found_to_the_declared_lag(tmp_path, declared, shift):
    """A declared [magnetometer] lag that does not pair the rows: the lag to
    write is the declared lag plus the shift found in the rows as imported
    (declared 1, found -1: lag = 0, the lag removed), and following it
    imports the log in step."""
    rows = (REAL / "sap6" / "BB.csv").read_text().splitlines()
    head, body = rows[0], [r.split(",") for r in rows[1:]]
    if shift:  # the magnetometer one row ahead (lag = -1 pairs it)
        body = [a[:5] + b[5:] for a, b in zip(body[:-1], body[1:])]
    log = tmp_path / "log.csv"
    log.write_text("\n".join([head] + [",".join(r) for r in body]) + "\n")
    text = SAP6_TOML.replace("reflection = true", f"reflection = true\nlag = {declared}")
    rep = _sap6_with(tmp_path, log, text)
    (f,) = [f for f in rep.findings if f.check == "row-alignment" and f.level in ("error", "warning")]
    assert rep.lag_rows == shift - declared
    assert re.search(r"re-import with \[magnetometer\] lag = (-?\d+)", f.message)[1] == str(shift), f.message
    assert f.figures["lag_to_write"] == shift and (shift != 0 or "remove" in f.message), f.message
    fixed = _sap6_with(tmp_path, log, SAP6_TOML.replace("reflection = true", f"reflection = true\nlag = {shift}"))
    assert fixed.lag_rows == 0 and not fixed.errors and not fixed.warnings, fixed.lines()


def test_a_declared_reflection_that_does_not_fit_is_not_suggested_again(tmp_path, capsys):
    """A description that already says reflection = true, with a map that
    mirrors the data: the error says the declared reflection does not fit
    the data as mapped and names the rotation to write, instead of ending
    "(or reflection = true ...)" again.  (With the site's dip, -17.8 deg as
    the CK log's documented frames give it: without it the rotation and its
    left-handed twin fit alike, test_a_map_and_its_negative_...)"""
    text = (REAL / "ck_acc_mag" / "sensor.toml").read_text().replace(
        'axes = "x = mx, y = my, z = mz"', 'axes = "x = mx, y = -my, z = mz"\nreflection = true') \
        + "\n[header]\ndip_deg = -17.8\n"
    desc = tmp_path / "declared.toml"
    desc.write_text(text)
    out = tmp_path / "run.csv"
    assert main(["import", str(REAL / "ck_acc_mag" / "acc_mag_log.csv"), "--sensor", str(desc), "-o", str(out)]) == 2
    err = capsys.readouterr().err
    assert err.count("\n") == 1 and not out.exists()
    assert "(or reflection = true" not in err and "declared reflection" in err and "does not fit the data as mapped" in err
    assert 'axes = "x = mx, y = my, z = mz"' in err and "without reflection = true" in err
    desc.write_text(text.replace('axes = "x = mx, y = -my, z = mz"\nreflection = true', 'axes = "x = mx, y = my, z = mz"'))
    assert main(["import", str(REAL / "ck_acc_mag" / "acc_mag_log.csv"), "--sensor", str(desc), "-o", str(out)]) == 0


@pytest.mark.parametrize("dip", [-17.8, None])
def test_both_triads_declared_reflected_sends_the_reader_to_the_accelerometer_first(tmp_path, capsys, dip):
    """The CK log with its magnetometer declared left-handed as logged-and-
    mirrored (y negated, reflection = true: the data bear that out against a
    right-handed accelerometer) and its accelerometer's z negated with
    reflection = true too: the triads are mirrored against each other.  The
    advice used to be to drop the magnetometer's reflection first, which
    leaves both triads mirrored alike (the dip unchanged, every azimuth
    mirrored); with both declared it says to check the accelerometer's map
    first, with the site's dip or without it.  Following that advice
    imports the log."""
    base = (REAL / "ck_acc_mag" / "sensor.toml").read_text()
    text = base.replace('axes = "x = mx, y = my, z = mz"', 'axes = "x = mx, y = -my, z = mz"\nreflection = true') \
        .replace('axes = "x = ax, y = ay, z = az"', 'axes = "x = ax, y = ay, z = -az"\nreflection = true')
    header = "" if dip is None else f"\n[header]\ndip_deg = {dip}\n"
    # the magnetometer as logged, read through a left-handed map: its y column negated in the log
    rows = (REAL / "ck_acc_mag" / "acc_mag_log.csv").read_text().splitlines()
    names = rows[0].split(",")
    j = names.index("my")
    body = []
    for r in rows[1:]:
        c = r.split(",")
        if len(c) == len(names):
            c[j] = repr(-float(c[j]))
        body.append(",".join(c))
    log = tmp_path / "log.csv"
    log.write_text("\n".join([rows[0]] + body) + "\n")
    desc = tmp_path / "both.toml"
    desc.write_text(text + header)
    out = tmp_path / "run.csv"
    assert main(["import", str(log), "--sensor", str(desc), "-o", str(out)]) == 2
    err = capsys.readouterr().err
    assert err.count("\n") == 1 and not out.exists()
    assert "both triads declare a reflection" in err and "check the accelerometer's map first" in err, err
    desc.write_text(text.replace('axes = "x = ax, y = ay, z = -az"\nreflection = true', 'axes = "x = ax, y = ay, z = az"') + header)
    assert main(["import", str(log), "--sensor", str(desc), "-o", str(out)]) == 0, capsys.readouterr().err


def _ck_counts(tmp_path):
    """The CK log as a sensor's counts: the accelerometer at 16384 per g,
    the magnetometer at 0.14 mG a count (its quanta, sensor.toml)."""
    lines = (REAL / "ck_acc_mag" / "acc_mag_log.csv").read_text().splitlines()
    rows = [[float(x) for x in r.split(",")] for r in lines[1:]]
    log = tmp_path / "counts.csv"
    log.write_text("\n".join([lines[0]] + [",".join(str(round(v * 16384)) for v in r[:3]) + ","
                                           + ",".join(str(round(v / 0.00014)) for v in r[3:]) for r in rows]) + "\n")
    return log


CK_COUNTS = '''[accelerometer]
columns = ["ax", "ay", "az"]
unit = "counts"
lsb = "ACC_LSB"
reads = "up"

[magnetometer]
columns = ["mx", "my", "mz"]
unit = "counts"
lsb = "MAG_LSB"

[header]
field_nT = 31000
'''


@pytest.mark.parametrize("triad,lsb,level,right", [
    ("acc", "1/8192 g", "error", "1/16384 g"), ("acc", "1/4096 g", "error", "1/16384 g"),
    ("acc", "1/65536 g", "error", "1/16384 g"), ("mag", "0.28 mG", "warning", "0.014 uT"),
    ("mag", "0.07 mG", "warning", "0.014 uT"), ("mag", "0.56 mG", "error", "0.014 uT")])
def test_an_lsb_a_range_step_off_is_named_with_the_lsb_to_write(tmp_path, triad, lsb, level, right):
    """A range setting doubles the lsb: readings 2, 4 or 8 times (or 1/2,
    1/4) what they should be are named as the lsb or range setting that many
    times off, with the lsb to write (level and thresholds as before: 0.5-2x
    g, 0.4-2.5x the header's field are warnings), and writing it imports
    the log clean."""
    log = _ck_counts(tmp_path)
    good = {"ACC_LSB": "1/16384 g", "MAG_LSB": "0.014 uT"}
    text = CK_COUNTS.replace("ACC_LSB" if triad == "acc" else "MAG_LSB", lsb)
    for k, v in good.items():
        text = text.replace(k, v)
    rep = checks.run(importlog.import_log(str(log), sensor.from_toml(text))[0])
    (f,) = _found(rep, "units", level)
    step = round(2 ** abs(np.log2(f.figures["ratio"] if "ratio" in f.figures else f.figures["median_g"])))
    assert f"lsb or range setting looks {step}x off" in f.message and f'lsb = "{right}"' in f.message, f.message
    assert f.triad == triad and "\n" not in f.message
    fixed = CK_COUNTS
    for k, v in good.items():
        fixed = fixed.replace(k, v)
    clean = checks.run(importlog.import_log(str(log), sensor.from_toml(fixed))[0])
    assert not _found(clean, "units", "error") and not _found(clean, "units", "warning"), clean.lines()


def test_a_hard_iron_offset_larger_than_the_field_changes_no_verdict_on_the_axes():
    """A phone's magnetometer reads its hard-iron offset, ~13 times the
    field, in every row: its raw directions barely turn, and the quadric
    fitted as logged is ill-conditioned.  The CK log with 5.4 fields added to
    its magnetometer gives the verdicts of the log as logged (no axis map
    advised, the same dip within a degree); fitted as logged, an iPhone's
    log had a rotation of the axes advised (spread 45 deg as given) that its
    readings less a constant did not."""
    ds = importlog.import_log(str(REAL / "ck_acc_mag/acc_mag_log.csv"),
                              sensor.load(str(REAL / "ck_acc_mag/sensor.toml")))[0]
    base = checks.run(ds)
    meta = {k: v for k, v in ds.meta.items() if k != "mag_range_nT"}  # a phone's range takes its offset
    d = dataset.RawDataset({k: v.copy() for k, v in ds.columns.items()}, meta)
    F = float(np.median(np.linalg.norm(ds.mag, axis=1)))
    for c, o in zip(dataset.MAG_COLS, (4.0, -3.0, 2.0)):
        d.columns[c] = d.columns[c] + o * F
    rep = checks.run(d)
    axes = [f for f in rep.findings if f.check in ("axes", "handedness") and f.level in ("warning", "error")]
    assert not axes, axes[0].message
    assert abs(rep.noise["dip_deg"] - base.noise["dip_deg"]) < 1.0, (rep.noise, base.noise)


def test_a_magnetometer_that_hardly_turned_is_not_called_a_wrong_range(rng):
    """A drone standing in an office: its magnetometer's readings within a
    few uT of one another, 31 uT from the origin.  A sphere fitted through
    such a blob has the blob's size (6 uT, "0.12x the field: the range
    looks 8x off", exit 2 before), while every reading's own |b| is the
    field's: the units are checked on the median |b| (a warning, -38 %),
    and the report says the sphere is not determined."""
    n = 3000
    c = np.array([21_000.0, 9_000.0, 21_000.0])
    mag = c + rng.normal(scale=3_000.0, size=(n, 3))
    cols = {"mx_nT": mag[:, 0], "my_nT": mag[:, 1], "mz_nT": mag[:, 2]}
    ds = dataset.RawDataset(cols, {"field_nT": 50_231.5})
    units = [f for f in checks.run(ds).findings if f.check == "units"]
    assert units and all(f.level == "warning" for f in units), [f.message for f in units]
    assert "not determined by their orientations" in units[0].message and "8x" not in units[0].message


def _on_sphere(rng, n, centre, radius, noise):
    u = rng.normal(size=(n, 3))
    u /= np.linalg.norm(u, axis=1, keepdims=True)
    return np.asarray(centre, float) + radius * u + rng.normal(scale=noise, size=(n, 3))


def test_a_unit_ten_times_off_is_named_through_a_hard_iron_offset_of_several_fields(rng):
    """A VMU931's magnetometer read in uT and declared mG: its readings lie
    on a sphere of 3 655 nT, 4.8 radii off the origin, so their median |b|
    (17 800 nT) is within the geomagnetic range's slack.  The sphere is a
    shell (RMS 5 % of its radius), so its radius is the field: a unit 10x
    off, not a sensor that hardly turned (the drone's blob above)."""
    mag = _on_sphere(rng, 3000, [3_000.0, -16_000.0, -9_000.0], 3_655.0, 60.0)
    cols = {"mx_nT": mag[:, 0], "my_nT": mag[:, 1], "mz_nT": mag[:, 2]}
    ds = dataset.RawDataset(cols, {"sensor": "a VMU931", "mag_unit": "mG"})
    (f,) = [f for f in checks.run(ds).findings if f.check == "units"]
    assert f.level == "error" and "the radius of the sphere" in f.message, f.message
    assert "look like uT" in f.message


def test_acceleration_with_gravity_removed_is_not_blamed_on_the_unit(rng):
    """A phone app's export of acceleration less gravity (an iPhone's Sensor
    Logger: |a| 0.022 g wandering 55 % about it) was told to fix its unit;
    no unit fixes it.  An accelerometer 0.65 g off in a wrong unit wanders
    as much, but its readings lie on a shell: that is still the unit."""
    lin = rng.normal(scale=0.02, size=(2000, 3))
    ds = dataset.RawDataset({"ax_g": lin[:, 0], "ay_g": lin[:, 1], "az_g": lin[:, 2]}, {"sensor": "a phone", "acc_unit": "m/s2"})
    (f,) = [f for f in checks.run(ds).findings if f.check == "units"]
    assert f.level == "error" and "gravity removed" in f.message and "fix the unit" not in f.message, f.message
    off = _on_sphere(rng, 2000, [0.065, 0.0, 0.0], 0.102, 0.001)  # g declared as m/s2, 0.65 g off
    ds = dataset.RawDataset({"ax_g": off[:, 0], "ay_g": off[:, 1], "az_g": off[:, 2]}, {"sensor": "a phone", "acc_unit": "m/s2"})
    (f,) = [f for f in checks.run(ds).findings if f.check == "units"]
    assert f.level == "error" and "gravity removed" not in f.message and "unit" in f.message, f.message


@pytest.mark.parametrize("log,desc,triad", [("ck_acc_mag/acc_log.csv", "ck_acc_mag/acc_only.toml", "acc"),
                                            ("qmc5883l/filtered_raw_data.csv", "qmc5883l/sensor.toml", "mag")])
def test_one_triad_without_poses_says_its_handedness_is_unchecked(log, desc, triad):
    """One triad without poses reads a mirrored axis as a mirrored world:
    the import says the map was not checked, instead of nothing."""
    notes = _found(checks.run(_load(log, desc)), "handedness", "note")
    assert len(notes) == 1 and notes[0].triad == triad and "not checked for a mirror" in notes[0].message


def test_one_triad_with_poses_has_its_handedness_checked():
    notes = [f for f in checks.run(_load(*ACC_POSES)).findings if "not checked for a mirror" in f.message]
    assert not notes


def _imucal_mapped(tmp_path, axes, labels=None):
    """imucal's six faces imported through its description with another axis
    map (and, given, the pose labels column as `labels` rewrites it)."""
    text = (REAL / ACC_POSES[1]).read_text().replace('axes = "x = ax, y = ay, z = az"', f'axes = "{axes}"')
    desc = tmp_path / "s.toml"
    desc.write_text(text)
    log = REAL / ACC_POSES[0]
    if labels is not None:
        lines = log.read_text().splitlines()
        parts = [ln.split(",", 1) for ln in lines[1:]]
        lab = labels([p[0] for p in parts])
        log = tmp_path / "log.csv"
        log.write_text("\n".join([lines[0]] + [f"{a},{p[1]}" for a, p in zip(lab, parts)]) + "\n")
    return importlog.import_log(str(log), sensor.load(str(desc)))[0]


def test_an_accelerometer_map_turned_against_the_poses_is_named_with_the_map(tmp_path):
    """An MPU-6050's six faces mapped "y, -x, z" imported without a word (a
    rotation: calibrate fitted acc_m a 90 deg turn).  The warning names the
    map, and the map it names imports without one."""
    rep = checks.run(_imucal_mapped(tmp_path, "x = ay, y = -ax, z = az"))
    (f,) = [f for f in rep.findings if f.check == "axes"]
    assert f.level == "warning" and "turned 90 deg against the poses" in f.message, f.message
    named = re.search(r'axes = "([^"]+)"', f.message).group(1)
    assert named == "x = ax, y = ay, z = az"
    assert not [f for f in checks.run(_imucal_mapped(tmp_path, named)).findings if f.check == "axes"]


def test_pose_labels_out_of_step_with_the_readings_are_refused(tmp_path):
    """Each face's label moved to the next face's rows: no turn of the poses
    fits the readings.  Refused before any fit; calibrate had fitted acc_m a
    reflection and blamed a mirror "against the magnetometer" of a log with
    none."""
    order = ["x_a", "x_p", "y_a", "y_p", "z_a", "z_p"]
    moved = dict(zip(order, order[1:] + order[:1]))
    rep = checks.run(_imucal_mapped(tmp_path, "x = ax, y = ay, z = az", lambda ls: [moved.get(x, x) for x in ls]))
    (f,) = [f for f in rep.findings if f.check == "poses"]
    assert f.level == "error" and "the poses do not match the rows" in f.message, f.message


def test_one_face_recorded_twice_is_a_label_on_the_wrong_rows_not_a_mirror(tmp_path, capsys):
    """A six-face session whose "posZ" file held a second recording of the
    -z face (an ESP32 + MPU-6050 log, one file a face): two poses 180 deg
    apart read one direction, which no axis map does.  It had been refused
    as "the accelerometer's axes are mirrored against the poses" (RMS 0.06
    with a reflection over the best 90 % of the rows, the other z face's
    rows the 10 % left out), a fix that cannot work.  Here imucal's session
    with its z_p rows replaced by the z_a face's second half."""
    lines = (REAL / ACC_POSES[0]).read_text().splitlines()
    za = [ln for ln in lines[1:] if ln.startswith("z_a,")]
    rows = [ln for ln in lines[1:] if not ln.startswith("z_p,")]
    rows = [("z_p," + ln.split(",", 1)[1]) if ln in za[len(za) // 2:] else ln for ln in rows]
    log = tmp_path / "twice.csv"
    log.write_text("\n".join([lines[0]] + rows) + "\n")
    rep = checks.run(importlog.import_log(str(log), sensor.load(str(REAL / ACC_POSES[1])))[0])
    assert not [f for f in rep.findings if f.check == "handedness"], rep.lines()
    (f,) = [f for f in rep.findings if f.check == "poses"]
    assert f.level == "error" and "read one gravity direction" in f.message, f.message
    assert "inc 180 tf 0" in f.message and "inc 0 tf 0" in f.message and "180 deg apart" in f.message
    assert main(["import", str(log), "--sensor", str(REAL / ACC_POSES[1]), "-o", str(tmp_path / "r.csv")]) == 2
    assert "check the [poses] labels" in capsys.readouterr().err
    assert not (tmp_path / "r.csv").exists()
    # the session as published: every face its own direction, nothing said
    assert not [f for f in checks.run(_load(*ACC_POSES)).findings if f.check == "poses"]


def test_counts_off_by_a_factor_are_given_the_lsb_not_a_unit(tmp_path):
    """Counts declared with an lsb 1000x too coarse: the fix is the lsb that
    makes |g| 1 g, not "look like counts at 1024 per g or mg" (that advice,
    followed, left them 1000x off)."""
    ds = _load(*ACC_POSES)
    big = _with(ds, **{c: ds.columns[c] * 1000.0 for c in ("ax_g", "ay_g", "az_g")})
    (f,) = [f for f in checks.run(big).findings if f.check == "units"]
    assert f.level == "error" and "look like" not in f.message and 'lsb = "1/2' in f.message, f.message


def test_a_time_column_that_goes_back_is_noted():
    """Six files of a six-face session joined one after another, each timed
    from its own start: the rows are used, and a note says the time goes
    back (a plot against time overlaid the faces without a word)."""
    t = np.concatenate([np.arange(100) * 0.01 + 0.41 for _ in range(3)])
    u = np.repeat(np.eye(3), 100, axis=0)
    ds = dataset.RawDataset({"t_s": t, "ax_g": u[:, 0], "ay_g": u[:, 1], "az_g": u[:, 2]}, {})
    (f,) = [f for f in checks.run(ds).findings if f.check == "time-order"]
    assert f.level == "note" and "goes back 2 times (first after row 100" in f.message, f.message


@pytest.mark.parametrize("whole", [True, False])
def test_counts_are_guessed_only_for_whole_numbers(rng, whole):
    """Readings 150x too small for nT: whole numbers look like counts of
    0.15 uT; decimals (an LSM303's uT declared nT, which read 0.6 uT counts
    "or uT") cannot be counts."""
    u = rng.normal(size=(2000, 3))
    mag = 45_000.0 / 150.0 * u / np.linalg.norm(u, axis=1, keepdims=True) + rng.normal(scale=2.0, size=(2000, 3))
    mag = np.round(mag) if whole else mag
    cols = {"mx_nT": mag[:, 0], "my_nT": mag[:, 1], "mz_nT": mag[:, 2]}
    (f,) = [f for f in checks.run(dataset.RawDataset(cols, {"sensor": "a part", "mag_unit": "nT"})).findings
            if f.check == "units"]
    assert f.level == "error" and ("counts of" in f.message) == whole, f.message


def _turned_once_about_the_vertical(rng, rock_deg=2.0):
    """A robot's LSM303 turned once about the vertical between two still
    spells, rocking rock_deg as it turns, its magnetometer 1.6 fields of
    hard iron and 15 % soft iron off, both triads' maps right."""
    n = 440
    th = np.concatenate([np.zeros(170), np.linspace(0, 2 * np.pi, 100), np.full(170, 2 * np.pi)]) + 0.3
    dip = np.radians(63.0)
    h, z = 48_000.0 * np.cos(dip), 48_000.0 * np.sin(dip)
    rock = np.radians(rock_deg) * np.sin(3 * th)
    mag = np.column_stack([h * np.cos(th), -h * np.sin(th), z + rock * h * np.cos(th)])
    mag = mag @ (np.eye(3) + 0.15 * rng.normal(size=(3, 3))).T + [-48_000.0, -59_000.0, 2_000.0]
    mag += rng.normal(scale=300.0, size=(n, 3))
    acc = np.array([0.05, 0.005, -1.0]) + rng.normal(scale=0.003, size=(n, 3))
    acc[:, 0] += rock
    return dataset.RawDataset({"ax_g": acc[:, 0], "ay_g": acc[:, 1], "az_g": acc[:, 2], "mx_nT": mag[:, 0],
                               "my_nT": mag[:, 1], "mz_nT": mag[:, 2], "t_s": np.arange(n) * 0.1}, {})


@pytest.mark.parametrize("seed", [0, 1, 2, 4])
def test_a_single_turn_about_the_vertical_names_no_axis_map(seed):
    """The magnetometer of a sensor turned about one axis reads a circle,
    which lies on a family of ellipsoids: the noise picked one, and the
    checks named a turned axis map of the magnetometer (8 of 10 draws of
    this log, on a log whose maps are right; an LSM303 on a robot turned
    once, "x = -mz, y = -mx, z = my", where the same board's log of many
    turns said nothing).  Its readings are planar: no ellipsoid is fitted,
    and nothing is named."""
    ds = _turned_once_about_the_vertical(np.random.default_rng(seed))
    rep = checks.run(ds)
    named = [f.message for f in rep.findings if f.check in ("axes", "handedness") and f.level != "note"]
    assert not named, named[0]
    from inclino.calib.ellipsoid import ellipsoid_start
    from inclino.errors import UndeterminedError

    with pytest.raises(UndeterminedError, match="in a plane"):
        ellipsoid_start(ds.mag, 48_000.0, "the magnetometer")


def _still_with_vibration(rng, n=512):
    """A board standing still (an LSM303 on a robot, 1.6 fields of hard
    iron), its motor shaking it now and then for a few rows."""
    acc = np.array([-0.05, -0.007, 1.075]) + rng.normal(scale=0.002, size=(n, 3))
    mag = np.array([-39_000.0, -60_000.0, 3_300.0]) + rng.normal(scale=200.0, size=(n, 3))
    for s in rng.choice(np.arange(20, n - 20), 6, replace=False):
        acc[s:s + 8] += rng.normal(scale=0.02, size=(8, 3))
        mag[s:s + 8] += rng.normal(scale=600.0, size=(8, 3))
    return dataset.RawDataset({"ax_g": acc[:, 0], "ay_g": acc[:, 1], "az_g": acc[:, 2], "mx_nT": mag[:, 0],
                               "my_nT": mag[:, 1], "mz_nT": mag[:, 2], "t_s": np.arange(n) * 0.1}, {})


@pytest.mark.parametrize("seed", [0, 1, 2, 3])
def test_a_still_log_says_one_orientation_and_nothing_it_cannot_see(seed):
    """At one orientation the shaken rows are jitter, not moves between
    holds, and nothing shows a mirror or a shift: the still LSM303 was said
    to move between 7 holds, to have its handedness checked on too little,
    and (one draw in four here) to be paired out of step.  Only the
    orientations' note speaks of the model."""
    rep = checks.run(_still_with_vibration(np.random.default_rng(seed)))
    assert rep.one_orientation
    said = [(f.check, f.message) for f in rep.findings if f.check in ("motion", "handedness", "row-alignment", "axes")]
    assert not said, said


def test_a_map_and_its_negative_are_both_named_without_the_site_dip(tmp_path, capsys):
    """A map P and its negative -P spread the dip alike, the dip's sign
    turned: one is a rotation of the axes as given, the other a reflection.
    An ICM-20948's magnetometer map written turned 180 deg about z (x and y
    negated) was called mirrored (z), and the reflection advised imported
    with every azimuth 180 deg off.  Without the site's dip both are named
    (exit 2: which one is right the data do not say); with it, the one whose
    dip has the header's sign."""
    text = (REAL / "ck_acc_mag" / "sensor.toml").read_text().replace(
        'axes = "x = mx, y = my, z = mz"', 'axes = "x = -mx, y = -my, z = mz"')
    desc = tmp_path / "turned.toml"
    desc.write_text(text)
    out = tmp_path / "run.csv"
    log = str(REAL / "ck_acc_mag" / "acc_mag_log.csv")
    assert main(["import", log, "--sensor", str(desc), "-o", str(out)]) == 2
    err = capsys.readouterr().err
    assert err.count("\n") == 1 and not out.exists()
    assert 'axes = "x = mx, y = my, z = mz" (right-handed: dip -17.8 deg)' in err, err
    assert 'axes = "x = -mx, y = -my, z = -mz" (left-handed, with reflection = true: dip +17.8 deg)' in err, err
    desc.write_text(text + "\n[header]\ndip_deg = -17.8\n")  # the CK log's own dip (sensor.toml)
    assert main(["import", log, "--sensor", str(desc), "-o", str(out)]) == 0
    err = capsys.readouterr().out
    (line,) = [x for x in err.splitlines() if "magnetometer's axes" in x]
    assert "warning" in line and 'axes = "x = mx, y = my, z = mz" (a rotation' in line, line


@pytest.mark.parametrize("triad,lsb,right", [("mag", "0.14 uT", "0.014 uT"), ("mag", "0.0014 uT", "0.014 uT"),
                                              ("acc", "0.61 mg", "6.1e-05 g")])
@pytest.mark.parametrize("field", [None, 31_000])
def test_an_lsb_a_power_of_ten_off_is_named_with_the_lsb_it_is(tmp_path, triad, lsb, right, field):
    """A unit prefix slipped in the lsb (an LSM9DS1's 0.14 mG written
    0.14 uT): the error named "lsb = 0.01267 uT", the lsb that puts the field
    mid-range, and told the user to fix the unit.  The lsb a power of ten
    off is named, as the lsb to fix."""
    log = _ck_counts(tmp_path)
    good = {"ACC_LSB": "1/16384 g", "MAG_LSB": "0.014 uT"}
    text = CK_COUNTS.replace("ACC_LSB" if triad == "acc" else "MAG_LSB", lsb)
    for k, v in good.items():
        text = text.replace(k, v)
    if field is None:
        text = text.replace("[header]\nfield_nT = 31000\n", "")
    (f,) = _found(checks.run(importlog.import_log(str(log), sensor.from_toml(text))[0]), "units", "error")
    assert f'lsb = "{right}"' in f.message and "fix the lsb" in f.message and "fix the unit" not in f.message, f.message


@pytest.mark.parametrize("declared,data,want", [("m/s2", 1.0, "g"), ("mg", 1.0, "g"), ("g", 9.80665, "m/s2")])
def test_the_unit_to_write_is_the_one_the_readings_look_like(declared, data, want):
    """A log in g declared m/s2 was told to "fix the unit (unit = "m/s2",
    "mg", or "counts" with lsb)": the unit it had declared, and not g.  The
    fix names the unit the readings look like."""
    ds = _load("ck_acc_mag/acc_log.csv", "ck_acc_mag/acc_only.toml")
    size = sensor.unit_size(declared, "acc")
    meta = {**ds.meta, "acc_unit": declared}
    bad = dataset.RawDataset({**{c: ds.columns[c] * data * size for c in dataset.ACC_COLS}}, meta)
    (f,) = _found(checks.run(bad), "units", "error")
    assert f'fix the unit (unit = "{want}")' in f.message, f.message


def _held_near_the_equator(seed=1):
    """40 positions held 60 rows each, turned between over 20 rows, the field
    dipping 2.5 deg, noisy readings (3 000 nT, 10 mg): a step-and-hold log whose
    pairing the checks cannot see to a row."""
    from scipy.spatial.transform import Rotation, Slerp

    rng = np.random.default_rng(seed)
    poses = Rotation.from_quat(rng.normal(size=(40, 4)))
    path = []
    for p in range(40):
        path += [poses[p]] * 60
        if p < 39:
            path += list(Slerp([0.0, 1.0], poses[[p, p + 1]])(np.linspace(0.0, 1.0, 22)[1:-1]))
    body = Rotation.concatenate(path).inv()
    n, dip = len(body), np.radians(2.5)
    acc = body.apply([0.0, 0.0, 1.0]) + rng.normal(0, 0.01, (n, 3))
    mag = body.apply(50_000.0 * np.array([np.cos(dip), 0.0, np.sin(dip)])) + rng.normal(0, 3000.0, (n, 3))
    return dataset.RawDataset(dict(zip(dataset.ACC_COLS, acc.T)) | dict(zip(dataset.MAG_COLS, mag.T)),
                              {"field_nT": 50_000.0})


def test_an_unchecked_pairing_on_a_held_log_is_not_told_to_hold_still():
    """A hand-held controller's 197 holds, moved between over 18 rows each
    (freeIMUCal's office log, the field's dip near zero as its triads'
    frames read it), were told "a session held still at each position ...
    checks it": the log was one.  The note now says it is held already and
    that quick moves between the holds check it."""
    (f,) = [f for f in checks.run(_held_near_the_equator()).findings if f.check == "row-alignment"]
    assert f.level == "note" and "not checked to a row" in f.message, f.message
    assert "held still already" in f.message and "holds found" in f.message and "in a few rows each" in f.message
    assert "a session held still at each position" not in f.message
