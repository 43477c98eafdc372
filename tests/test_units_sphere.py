"""The units checks judge a triad by the radius of the sphere its readings lie
on (an offset does not move it), fall back to the median |v| where the
orientations span no sphere, and say which; the lsb a power of ten off is
named as a unit prefix slipped, for the magnetometer as for the
accelerometer, and every fix proposed imports when written; a fit whose
offset the probe's calibration cannot hold is refused in the user's terms
(docs/dataset.md "Checks before any fit").

Built from the corpus' MIT/BSD/Apache logs (tests/data/real): an animal
tag's log (GPL, not copied here) whose accelerometer is 0.64 g off on z read
a median |g| of 0.41 g and was told an lsb 2.4x off; its magnetometer's
0.15 uT written 0.15 nT was told unit = "uT" or counts of 0.6 uT, both
refused when written."""
import json
import re
from pathlib import Path

import numpy as np
import pytest

from inclino.cli import main

REAL = Path(__file__).parent / "data" / "real"
MPU = REAL / "micropython_fusion"  # MIT: an MPU9150 turned by hand, acc in g, mag in uT (0.3 uT counts)
POLOLU = REAL / "pololu_minimu9"   # BSD: a MinIMU-9 in raw counts, mag 1/6842 G a count
CK = REAL / "ck_acc_mag"           # Apache: an accelerometer alone, in g, tumbled through every direction


def _mpu_counts(tmp_path, acc_offset_g=(0.0, 0.0, 0.0), name="mpu.csv"):
    """micropython-fusion's log with the accelerometer in counts of 1 mg (plus
    an offset in g on each axis) and the magnetometer in counts of 0.3 uT."""
    out = []
    for line in (MPU / "mpudata.csv").read_text().splitlines():
        v = line.split(",")
        if line.startswith(("#", "t_us")) or len(v) != 10:
            out.append(line)
            continue
        a = [round((float(v[1 + i]) + acc_offset_g[i]) * 1000.0) for i in range(3)]
        m = [round(float(v[7 + i]) / 0.3) for i in range(3)]
        out.append(",".join([v[0], *map(str, a), *v[4:7], *map(str, m)]))
    log = tmp_path / name
    log.write_text("\n".join(out) + "\n")
    return log


def _mpu_toml(acc_lsb="1 mg", mag_lsb="0.3 uT"):
    return f"""name = "MPU9150 (micropython-fusion), in counts"
[log]
time = "t_us"
time_unit = "us"
[accelerometer]
columns = ["ax", "ay", "az"]
unit = "counts"
lsb = "{acc_lsb}"
reads = "up"
axes = "x = ax, y = ay, z = az"
[magnetometer]
columns = ["mx", "my", "mz"]
unit = "counts"
lsb = "{mag_lsb}"
axes = "x = mx, y = my, z = mz"
"""


def _import(tmp_path, log, toml, capsys, out="run.csv"):
    desc = tmp_path / "s.toml"
    desc.write_text(toml)
    code = main(["import", str(log), "--sensor", str(desc), "-o", str(tmp_path / out)])
    said = capsys.readouterr()
    return code, said.out + said.err  # the warnings of an import that passes are on stdout


def _proposals(err):
    """Every fix the error line proposes, as (unit or None, lsb or None)."""
    out = []
    for m in re.finditer(r'(unit = "([^"]+)"(?: with lsb = "([^"]+)")?)|((?<!with )lsb = "([^"]+)")', err):
        out.append((m.group(2), m.group(3)) if m.group(1) else (None, m.group(5)))
    return out


def _apply(toml, section, unit, lsb):
    head, _, tail = toml.partition(f"[{section}]")
    body, sep, rest = tail.partition("\n[")
    if unit is not None:
        body = re.sub(r'unit = "[^"]+"', f'unit = "{unit}"', body)
        if lsb is None:
            body = re.sub(r'lsb = "[^"]+"\n', "", body)
    if lsb is not None:
        body = re.sub(r'lsb = "[^"]+"', f'lsb = "{lsb}"', body)
    return head + f"[{section}]" + body + sep + rest


def test_an_accelerometer_far_off_zero_is_judged_by_its_sphere(tmp_path, capsys):
    """0.6 g added to z: the median |g| falls to 0.42 g (an lsb error before);
    the sphere's radius is still 1 g: imported, a warning naming the offset
    per axis, and calibrate fits it."""
    log = _mpu_counts(tmp_path, (0.0, 0.0, -0.6))
    code, err = _import(tmp_path, log, _mpu_toml(), capsys)
    assert code == 0, err
    assert "units" not in err or "error" not in err
    m = re.search(r"accelerometer: the readings lie on a sphere of ([\d.]+) g centred \(([^)]+)\) g from zero", err)
    assert m, err
    assert abs(float(m.group(1)) - 1.0) < 0.05
    off = [float(x) for x in m.group(2).split(",")]
    assert abs(abs(off[2]) - 0.6) < 0.1 and max(abs(off[0]), abs(off[1])) < 0.1, off
    assert "which the calibration's offset takes out" in err
    code = main(["calibrate", str(tmp_path / "run.csv"), "-o", str(tmp_path / "cal.json")])
    err = capsys.readouterr().err
    assert code in (0, 1), err  # written (1: a verdict of FAIL, not a refusal)
    b = json.loads((tmp_path / "cal.json").read_text())["acc_b"]
    assert abs(abs(b[2]) - 0.6) < 0.1, b


def test_the_lsb_proposed_for_offset_counts_is_the_true_one_and_imports(tmp_path, capsys):
    """The same log declared at 5 mg a count: the lsb proposed is the true
    1 mg (the median |g| had proposed 2.4 mg for a 0.64 g offset), and written it
    imports; the error says the sphere's radius was the figure."""
    log = _mpu_counts(tmp_path, (0.0, 0.0, -0.6))
    toml = _mpu_toml(acc_lsb="5 mg")
    code, err = _import(tmp_path, log, toml, capsys)
    assert code == 2
    assert "the radius of the sphere the readings lie on" in err, err
    m = re.search(r'lsb = "([\d.e-]+) g" would make it so', err)
    assert m, err
    assert abs(float(m.group(1)) / 0.001 - 1.0) < 0.03, err
    code, err = _import(tmp_path, log, _apply(toml, "accelerometer", None, m.group(1) + " g"), capsys)
    assert code == 0, err


def test_a_log_at_too_few_orientations_says_the_median_was_used(tmp_path, capsys):
    """NGIMU's log holds one orientation: no sphere; its accelerometer
    declared 3x too small is judged by the median |g|, and says so."""
    from inclino import checks
    from inclino.formats import importlog, sensor

    toml = (REAL / "ngimu" / "sensor.toml").read_text()
    ds = importlog.import_log(str(REAL / "ngimu" / "sensors.csv"), sensor.from_toml(toml))[0]
    import dataclasses

    cols = dict(ds.columns)
    for k in ("ax_g", "ay_g", "az_g"):
        cols[k] = np.asarray(cols[k], float) * 3.0
    rep = checks.run(dataclasses.replace(ds, columns=cols))
    units = [f for f in rep.findings if f.check == "units" and f.triad == "acc" and f.level == "error"]
    assert units and "(the median |g|, " in units[0].message, rep.findings
    assert units[0].figures["how"] == "the median |g|"


@pytest.mark.parametrize("declared, factor, fixed", [("1/6842 mG", 1000, "1/6842 G"),
                                                     ("1/6842 uT", 100, "1/6842 G")])
def test_a_magnetometer_lsb_a_power_of_ten_off_is_named_and_the_fix_imports(tmp_path, capsys, declared,
                                                                           factor, fixed):
    """The MinIMU's magnetometer counts of 1/6842 G declared in mG (1000x) or
    uT (100x): the lsb named as the declared one a power of ten off, the exact
    one to write given (it had been told unit = "mG" for counts, refused when
    written), and every fix proposed imports."""
    toml = (POLOLU / "sensor.toml").read_text().replace('lsb = "1/6842 G"', f'lsb = "{declared}"')
    code, err = _import(tmp_path, POLOLU / "data_polulu.txt", toml, capsys)
    assert code == 2
    assert f'lsb = "{fixed}", the declared lsb {declared} {factor}x too small' in err, err
    props = _proposals(err)
    assert props == [(None, fixed)], props
    for unit, lsb in props:
        code, err = _import(tmp_path, POLOLU / "data_polulu.txt", _apply(toml, "magnetometer", unit, lsb), capsys)
        assert code == 0, (unit, lsb, err)


def test_a_magnetometer_lsb_given_in_nT_for_uT_is_fixed_to_the_uT_it_is(tmp_path, capsys):
    """micropython-fusion's AK8975 counts of 0.3 uT declared 0.3 nT: "lsb =
    0.3 uT, the declared lsb 0.3 nT 1000x too small", no unit guessed for
    whole counts, and the fix imports."""
    log = _mpu_counts(tmp_path)
    toml = _mpu_toml(mag_lsb="0.3 nT")
    code, err = _import(tmp_path, log, toml, capsys)
    assert code == 2
    assert 'lsb = "0.3 uT", the declared lsb 0.3 nT 1000x too small (a unit prefix off?)' in err, err
    props = _proposals(err)
    assert props == [(None, "0.3 uT")], props
    code, err = _import(tmp_path, log, _apply(toml, "magnetometer", None, "0.3 uT"), capsys)
    assert code == 0, err


def _ck_far(tmp_path, offset_x):
    out = []
    for line in (CK / "acc_log.csv").read_text().splitlines():
        v = line.split(",")
        if line.startswith("ax"):
            out.append(line)
            continue
        out.append(",".join([f"{float(v[0]) + offset_x:.7g}", v[1], v[2]]))
    log = tmp_path / "ck_far.csv"
    log.write_text("\n".join(out) + "\n")
    toml = "\n".join(x for x in (CK / "acc_only.toml").read_text().splitlines() if not x.startswith("range"))
    return log, toml


def test_an_offset_the_calibration_cannot_hold_is_refused_in_the_users_terms(tmp_path, capsys):
    """2.5 g added to x of CK's accelerometer: its sphere is 1 g, so the import
    passes with a warning that calibrate refuses it; calibrate refuses it in
    one line naming the offset in g, the format's +-2 g and the cause (it
    said only "acc_b beyond +-2"): exit 3, nothing written."""
    log, toml = _ck_far(tmp_path, 2.5)
    code, err = _import(tmp_path, log, toml + "\n", capsys)
    assert code == 0, err
    assert "beyond the +-2 g the probe's calibration holds (calibrate refuses it)" in err, err
    code = main(["calibrate", str(tmp_path / "run.csv"), "-o", str(tmp_path / "cal.json")])
    err = capsys.readouterr().err
    assert code == 3, err
    line = [x for x in err.splitlines() if x.startswith("inclino: error:")]
    assert len(line) == 1 and "Traceback" not in err, err
    m = re.search(r"the accelerometer's offset the fit needs, \(([^)]+)\) g \(x, y, z\), is beyond the \+-2 g", line[0])
    assert m, err
    assert abs(abs(float(m.group(1).split(",")[0])) - 2.5) < 0.1
    assert "zero" in line[0] and "acc_b" not in line[0]
    assert not (tmp_path / "cal.json").exists()


def test_a_fit_out_of_range_from_a_scale_declared_wrong_names_the_scale(tmp_path, capsys):
    """The tag's case past the checks (calib.fit check=False): counts 5x too
    large about a 0.6 g offset need an offset of 3 g; the refusal names the
    readings 5x the gravity they should read, a scale or unit declared wrong."""
    from inclino.calib import fit
    from inclino.errors import CalibrationError
    from inclino.formats import dataset

    log = _mpu_counts(tmp_path, (0.0, 0.0, -0.6))
    code, err = _import(tmp_path, log, _mpu_toml(), capsys)
    assert code == 0, err
    ds = dataset.read_raw(str(tmp_path / "run.csv"))
    cols = dict(ds.columns)
    for k in ("ax_g", "ay_g", "az_g"):
        cols[k] = np.asarray(cols[k], float) * 5.0
    import dataclasses

    with pytest.raises(CalibrationError) as e:
        fit(dataclasses.replace(ds, columns=cols), "joint", check=False)
    msg = str(e.value)
    assert "the accelerometer's offset the fit needs" in msg and "beyond the +-2 g" in msg, msg
    assert re.search(r"the readings are [45]\.\d+x the gravity they should read: a scale or unit declared wrong",
                     msg), msg


def test_readings_far_beyond_any_unit_are_told_their_size_not_no_gravity(tmp_path, capsys):
    """1e200 in every sensor cell: |v| is taken without overflow (1.7e200,
    not inf), so the file is refused as a wrong scale, not as "no gravity
    in the readings"."""
    rows = ["# field_nT=48000", "# dip_deg=60", "t_s,ax_g,ay_g,az_g,mx_nT,my_nT,mz_nT"]
    rows += [f"{i},1e200,1e200,1e200,1e200,1e200,1e200" for i in range(40)]
    p = tmp_path / "huge.csv"
    p.write_text("\n".join(rows) + "\n")
    capsys.readouterr()
    assert main(["calibrate", str(p), "-o", str(tmp_path / "c.json")]) == 2
    err = capsys.readouterr().err
    assert "1.732e+200" in err and "no gravity" not in err and "inf" not in err
    assert not (tmp_path / "c.json").exists()


def test_an_accelerometer_lsb_a_fifth_off_is_a_warning(tmp_path, capsys):
    """Counts of 1 mg declared 1.21 mg: |g| 1.24 g (the log reads 1.02 g) is beyond any MEMS part's
    scale error (a few %, the ADXL345's +-10 %) and was silent (the
    tolerance was 0.8-1.25); now a warning naming the lsb, and the log is
    still imported (a suspicious scale fits).  Declared 1.05 mg: silent."""
    log = _mpu_counts(tmp_path)
    code, err = _import(tmp_path, log, _mpu_toml(acc_lsb="1.21 mg"), capsys)
    assert code == 0 and re.search(r"accelerometer: \|g\| is 1\.2\d* g .*\+2\d % from 1 g", err), err
    code, err = _import(tmp_path, log, _mpu_toml(acc_lsb="1.05 mg"), capsys, out="ok.csv")
    assert code == 0 and "accelerometer: |g|" not in err, err


def test_an_lsb_written_in_m_s2_for_g_is_told_the_number_in_g(tmp_path, capsys):
    """Counts of 1 mg declared "0.001 m/s2": 9.81x is within a scale error of
    10x, and the power of ten alone was told ("0.00101972 g", ten times the
    number as written).  The number as written in g is proposed too, and
    each fix imports; an lsb no one would write in m/s2 (0.1 mg) is not
    read as one."""
    log = _mpu_counts(tmp_path)
    toml = _mpu_toml(acc_lsb="0.001 m/s2")
    code, err = _import(tmp_path, log, toml, capsys)
    assert code == 2 and 'lsb = "0.001 g", the declared lsb 0.001 m/s2 in g (g and m/s2 swapped?)' in err, err
    fixes = _proposals(err)
    assert (None, "0.001 g") in fixes and len(fixes) == 2, fixes
    for i, (unit, lsb) in enumerate(fixes):
        code, err2 = _import(tmp_path, log, _apply(toml, "accelerometer", unit, lsb), capsys, out=f"f{i}.csv")
        assert code == 0, (lsb, err2)
    code, err = _import(tmp_path, log, _mpu_toml(acc_lsb="0.1 mg"), capsys)
    assert code == 2 and "m/s2" not in err.split("not counts")[0], err


def test_a_denormal_reading_is_no_field_not_a_traceback(tmp_path, capsys):
    """|b| of 5e-324 nT (taken without overflow, so no longer 0): its ratio
    to any unit underflows to 0, where the unit guesses took its log."""
    p = tmp_path / "tiny.csv"
    p.write_text("ax_g,ay_g,az_g,mx_nT,my_nT,mz_nT\n0.0,0.0,0.0,0.0,0.0,5e-324\n")
    assert main(["attitude", str(p), "-o", str(tmp_path / "a.csv")]) == 0
    assert "no field in the readings" in capsys.readouterr().err
