"""Faults of real logs that `inclino import` read as readings, and the
sensor description's documented keys (docs/dataset.md, "The sensor
description"): signed counts logged as unsigned words, filler rows after a
log's end, the column a dropped row had no value in, two files paired in
order at different rates, poses without an azimuth beside a magnetometer,
poses in radians; and the documentation's examples, run as written."""
import csv
import math
import re
from pathlib import Path

import numpy as np
import pytest

from inclino.cli import build_parser, main
from inclino.errors import DataError
from inclino.formats import dataset, importlog, sensor

ROOT = Path(__file__).resolve().parents[1]
REAL = Path(__file__).parent / "data" / "real"
DOC = (ROOT / "docs" / "dataset.md").read_text(encoding="utf-8")


def _cli(args, capsys):
    rc = main(["import", *map(str, args)])
    cap = capsys.readouterr()
    return rc, cap.out, cap.err


def _one_line_error(rc, err, out_path):
    assert rc == 2, err
    assert len(err.strip().splitlines()) == 1 and "Traceback" not in err, err
    assert not Path(out_path).exists()


# ---- signed counts logged as unsigned words ----------------------------------------------------------------------


def _imucal_unsigned(tmp_path):
    """imucal's six faces (16-bit counts, 2048 per g, both signs) with every
    count written as the unsigned 16-bit word a register dump prints."""
    src = REAL / "imucal_ferraris" / "annotated_session.csv"
    with open(src, newline="") as f:
        rows = list(csv.reader(f))
    names = rows[0]
    acc = [names.index(c) for c in ("acc_x", "acc_y", "acc_z")]
    out = [names]
    for r in rows[1:]:
        r = list(r)
        for j in acc:
            v = int(float(r[j]))
            assert v == float(r[j]) and -32768 <= v < 32768
            r[j] = str(v % 65536)
        out.append(r)
    log = tmp_path / "unsigned.csv"
    with open(log, "w", newline="") as f:
        csv.writer(f).writerows(out)
    return log, (REAL / "imucal_ferraris" / "sensor.toml").read_text()


def test_signed_counts_read_unsigned_are_refused_naming_the_declaration(tmp_path, capsys):
    """Read as unsigned, a face's -2052 is 63484: |g| about 20 g and, before,
    an lsb advised to make it 1 g.  The import names the word instead."""
    log, desc = _imucal_unsigned(tmp_path)
    (tmp_path / "s.toml").write_text(desc)
    out = tmp_path / "run.csv"
    rc, _, err = _cli([log, "--sensor", tmp_path / "s.toml", "-o", out], capsys)
    _one_line_error(rc, err, out)
    assert 'counts = "int16"' in err and "two's-complement" in err and "lsb" not in err, err


def test_declared_int16_counts_import_as_the_signed_log(tmp_path):
    """counts = "int16" reads the unsigned words back as the published signed
    counts: the dataset equals the import of the log as published."""
    log, desc = _imucal_unsigned(tmp_path)
    (tmp_path / "s.toml").write_text(desc.replace('unit = "counts"', 'unit = "counts"\ncounts = "int16"'))
    ds, _ = importlog.import_log(str(log), sensor.load(str(tmp_path / "s.toml")))
    ref, _ = importlog.import_log(str(REAL / "imucal_ferraris" / "annotated_session.csv"),
                                  sensor.load(str(REAL / "imucal_ferraris" / "sensor.toml")))
    for c in dataset.ACC_COLS + ("inc_deg", "tf_deg", "t_s"):
        np.testing.assert_array_equal(ds.columns[c], ref.columns[c], err_msg=c)
    assert ds.meta["acc_unit"].startswith("counts (int16) x ")


def test_int16_counts_outside_the_word_are_refused(tmp_path):
    (tmp_path / "log.csv").write_text("ax,ay,az\n0,0,2048\n70000,0,2048\n")
    (tmp_path / "s.toml").write_text('[accelerometer]\ncolumns = ["ax", "ay", "az"]\nunit = "counts"\n'
                                     'lsb = "1/2048 g"\ncounts = "int16"\n')
    with pytest.raises(DataError, match=r"log.csv:3: accelerometer x \('ax'\): 70000 is no int16 count"):
        importlog.import_log(str(tmp_path / "log.csv"), sensor.load(str(tmp_path / "s.toml")))


@pytest.mark.parametrize("word", ["int", "float16", "int1", 16])
def test_the_counts_word_is_checked(tmp_path, word):
    spec = f'"{word}"' if isinstance(word, str) else str(word)
    with pytest.raises(DataError, match=r"\[accelerometer\]\.counts"):
        sensor.from_toml(f'[accelerometer]\ncolumns = [1, 2, 3]\nunit = "counts"\nlsb = "1/2048 g"\ncounts = {spec}\n')
    with pytest.raises(DataError, match=r"only with unit = \"counts\""):
        sensor.from_toml('[accelerometer]\ncolumns = [1, 2, 3]\nunit = "g"\ncounts = "int16"\n')


def test_unsigned_counts_at_mid_scale_are_not_taken_for_signed(tmp_path):
    """An unsigned ADC with its zero at mid-scale (counts around 32768, both
    halves of the word) is what `zero` is for: read as two's complement its
    counts would spread over the whole word, so it is not named signed."""
    rng = np.random.default_rng(1)
    v = rng.normal(size=(200, 3))
    v /= np.linalg.norm(v, axis=1, keepdims=True)
    counts = np.round(32768 + 2048 * v).astype(int)
    (tmp_path / "log.csv").write_text("ax,ay,az\n" + "".join(f"{a},{b},{c}\n" for a, b, c in counts))
    desc = '[accelerometer]\ncolumns = ["ax", "ay", "az"]\nunit = "counts"\nlsb = "1/2048 g"\nzero = 32768\n'
    (tmp_path / "s.toml").write_text(desc)
    ds, _ = importlog.import_log(str(tmp_path / "log.csv"), sensor.load(str(tmp_path / "s.toml")))
    np.testing.assert_allclose(np.linalg.norm(ds.acc, axis=1), 1.0, atol=2e-3)
    (tmp_path / "s.toml").write_text(desc.replace("zero = 32768\n", ""))
    ds, _ = importlog.import_log(str(tmp_path / "log.csv"), sensor.load(str(tmp_path / "s.toml")))  # not refused


# ---- filler rows -------------------------------------------------------------------------------------------------

FUSION = REAL / "micropython_fusion"


def _fusion_lines():
    return (FUSION / "mpudata.csv").read_text().splitlines()


def _with_filler(tmp_path, n=300):
    """micropython-fusion's log (time in us) with `n` rows of filler after its
    end: one row repeated, the time at 2^32 - 1 us, every reading -1 count."""
    lines = _fusion_lines()
    filler = "4294967295," + ",".join(["-0.00006103516"] * 6 + ["-0.3"] * 3)
    log = tmp_path / "log.csv"
    log.write_text("\n".join(lines + [filler] * n) + "\n")
    return log, len(lines)


def test_filler_rows_are_refused_naming_their_lines(tmp_path, capsys):
    log, n_lines = _with_filler(tmp_path)
    out = tmp_path / "run.csv"
    rc, _, err = _cli([log, "--sensor", FUSION / "sensor.toml", "-o", out], capsys)
    _one_line_error(rc, err, out)
    assert f":{n_lines + 1}-{n_lines + 300}: 300 rows" in err, err
    assert "4294967295" in err and "2^32 - 1" in err and "--drop-bad-rows" in err, err
    assert "unit" not in err  # the filler is named before any unit check blames the unit


def test_filler_rows_dropped_leave_the_log_as_logged(tmp_path, capsys):
    log, n_lines = _with_filler(tmp_path)
    ds, rep = importlog.import_log(str(log), sensor.load(str(FUSION / "sensor.toml")), drop_bad_rows=True)
    ref, _ = importlog.import_log(str(FUSION / "mpudata.csv"), sensor.load(str(FUSION / "sensor.toml")))
    for c in ref.columns:
        np.testing.assert_array_equal(ds.columns[c], ref.columns[c], err_msg=c)
    (reason, n), = rep.dropped.items()
    assert n == 300 and reason.startswith("filler: ") and f"lines {n_lines + 1}-{n_lines + 300}" in reason
    out = tmp_path / "run.csv"
    rc, text, _ = _cli([log, "--sensor", FUSION / "sensor.toml", "-o", out, "--drop-bad-rows"], capsys)
    assert rc == 0 and "dropped 300 row(s): filler" in text


def test_a_time_stamp_that_stops_is_refused(tmp_path):
    """The clock stops for 200 rows while the readings go on: those rows have
    no time of their own."""
    lines = _fusion_lines()
    stuck = lines[500].split(",")[0]
    for i in range(500, 700):
        lines[i] = ",".join([stuck] + lines[i].split(",")[1:])
    (tmp_path / "log.csv").write_text("\n".join(lines) + "\n")
    with pytest.raises(DataError, match=r"log.csv:501-700: 200 rows .* share one time stamp, .*the time stops"):
        importlog.import_log(str(tmp_path / "log.csv"), sensor.load(str(FUSION / "sensor.toml")))


def test_a_few_repeated_rows_are_not_filler(tmp_path):
    lines = _fusion_lines()
    lines[100:100] = [lines[100]] * 5  # a line written 6 times in all
    (tmp_path / "log.csv").write_text("\n".join(lines) + "\n")
    ds, rep = importlog.import_log(str(tmp_path / "log.csv"), sensor.load(str(FUSION / "sensor.toml")))
    assert len(ds) == 2041 + 5 and not rep.dropped  # the log's 2041 rows (and its '# cal_end' line) and 5 more


# ---- a missing value names its column ----------------------------------------------------------------------------


def test_rows_dropped_for_a_missing_value_name_the_column_and_lines(tmp_path, capsys):
    """A temperature column empty on the last rows (a logger's filler with
    'nan' there): the rows dropped are counted under that column."""
    lines = _fusion_lines()
    lines[0] += ",temp"
    for i in range(1, len(lines)):
        lines[i] += ",nan" if i > 1500 else ",25.0"
    (tmp_path / "log.csv").write_text("\n".join(lines) + "\n")
    desc = (FUSION / "sensor.toml").read_text().replace('time_unit = "us"', 'time_unit = "us"\ntemperature = "temp"')
    (tmp_path / "s.toml").write_text(desc)
    rc, text, err = _cli([tmp_path / "log.csv", "--sensor", tmp_path / "s.toml", "-o", tmp_path / "run.csv"], capsys)
    n = len(lines) - 1501  # lines 1502 ... the last
    assert rc == 0, err
    assert f"dropped {n} row(s): a missing value in temperature ('temp') (lines 1502 ... {len(lines)})" in text, text


# ---- two files paired in order at different rates ----------------------------------------------------------------


def _two_files(tmp_path, rate_acc, rate_mag, n=600):
    rng = np.random.default_rng(3)
    with open(tmp_path / "acc.csv", "w") as f:
        f.write("t,ax,ay,az\n")
        for i in range(n):
            f.write(f"{i / rate_acc:.6f},{rng.normal(0, .01):.5f},{rng.normal(0, .01):.5f},1.0\n")
    with open(tmp_path / "mag.csv", "w") as f:
        f.write("t,mx,my,mz\n")
        for i in range(n):
            f.write(f"{i / rate_mag + 1000:.6f},20000,{rng.normal(0, 50):.1f},40000\n")
    (tmp_path / "s.toml").write_text('[log]\ntime = "t"\n[accelerometer]\ncolumns = ["ax", "ay", "az"]\n'
                                     '[magnetometer]\ncolumns = ["mx", "my", "mz"]\nfile = "mag.csv"\ntime = false\n')


def test_files_paired_in_order_at_different_rates_are_refused(tmp_path, capsys):
    """51.08 rows/s against 50: over 600 pairs in order the pairs' time apart
    grows by 599 x (51.08/50 - 1) = 12.9 of the faster's rows."""
    _two_files(tmp_path, 51.08, 50.0)
    drift = 599 * (51.08 / 50.0 - 1.0)
    with pytest.raises(DataError, match=rf"51.08 rows/s .* 50 rows/s: row i of one lies {drift:.0f} rows from row i"):
        importlog.import_log(str(tmp_path / "acc.csv"), sensor.load(str(tmp_path / "s.toml")))
    out = tmp_path / "run.csv"
    rc, _, err = _cli([tmp_path / "acc.csv", "--sensor", tmp_path / "s.toml", "-o", out], capsys)
    _one_line_error(rc, err, out)
    assert "pair them by time: leave out [magnetometer] time = false" in err


def test_files_paired_in_order_at_one_rate_still_pair_in_order(tmp_path):
    """One rate on two clocks (the file's 1000 s later): in order, as asked."""
    _two_files(tmp_path, 50.0, 50.0)
    ds, rep = importlog.import_log(str(tmp_path / "acc.csv"), sensor.load(str(tmp_path / "s.toml")))
    assert len(ds) == 600 and "row by row, in order" in ds.meta["pairing"]


# ---- poses -------------------------------------------------------------------------------------------------------

TWO = ('[accelerometer]\ncolumns = ["ax", "ay", "az"]\n[magnetometer]\ncolumns = ["mx", "my", "mz"]\n')
POSE_LOG = "ax,ay,az,mx,my,mz,inc,azi,tf,part\n1,0,0,35355,0,35355,90,0,180,a\n0,0,1,35355,0,35355,0,0,0,b\n"


@pytest.mark.parametrize("poses", ['[poses]\ninc = "inc"\ntf = "tf"\n',
                                   '[poses]\nlabel = "part"\n[poses.labels]\na = { inc = 90, tf = 180 }\n'
                                   'b = { inc = 0, azi = 0, tf = 0 }\n'])
def test_poses_without_an_azimuth_beside_a_magnetometer_are_refused(tmp_path, capsys, poses):
    (tmp_path / "log.csv").write_text(POSE_LOG)
    (tmp_path / "s.toml").write_text(TWO + poses)
    out = tmp_path / "run.csv"
    rc, _, err = _cli([tmp_path / "log.csv", "--sensor", tmp_path / "s.toml", "-o", out], capsys)
    _one_line_error(rc, err, out)
    assert "poses incomplete: no azi" in err, err


def test_poses_without_an_azimuth_serve_an_accelerometer_alone(tmp_path):
    (tmp_path / "log.csv").write_text(POSE_LOG)
    (tmp_path / "s.toml").write_text('[accelerometer]\ncolumns = ["ax", "ay", "az"]\n[poses]\ninc = "inc"\ntf = "tf"\n')
    ds, _ = importlog.import_log(str(tmp_path / "log.csv"), sensor.load(str(tmp_path / "s.toml")))
    assert list(ds.columns["inc_deg"]) == [90.0, 0.0]


def test_poses_in_radians(tmp_path):
    """[poses] unit = "rad": the columns (and labels) are radians, written
    as degrees; "deg" (the default) reads them as they are."""
    ang = np.array([[math.pi / 2, 1.0, math.pi], [0.25, 6.0, 0.5]])
    (tmp_path / "log.csv").write_text("ax,ay,az,mx,my,mz,inc,azi,tf,part\n" + "".join(
        f"1,0,0,35355,0,35355,{float(i)!r},{float(a)!r},{float(t)!r},p{k}\n" for k, (i, a, t) in enumerate(ang)))
    cols = '[poses]\ninc = "inc"\nazi = "azi"\ntf = "tf"\n'
    for unit, scale in (("", 1.0), ('unit = "deg"\n', 1.0), ('unit = "rad"\n', 180.0 / math.pi)):
        (tmp_path / "s.toml").write_text(TWO + cols + unit)
        ds, _ = importlog.import_log(str(tmp_path / "log.csv"), sensor.load(str(tmp_path / "s.toml")))
        for j, c in enumerate(("inc_deg", "azi_deg", "tf_deg")):
            np.testing.assert_allclose(ds.columns[c], ang[:, j] * scale, rtol=1e-15, err_msg=(unit, c))
    labels = ('[poses]\nlabel = "part"\nunit = "rad"\n[poses.labels]\np0 = { inc = 1.5707963267948966, azi = 1.0, '
              'tf = 3.141592653589793 }\np1 = { inc = 0.25, azi = 6.0, tf = 0.5 }\n')
    (tmp_path / "s.toml").write_text(TWO + labels)
    ds, _ = importlog.import_log(str(tmp_path / "log.csv"), sensor.load(str(tmp_path / "s.toml")))
    np.testing.assert_allclose(ds.columns["azi_deg"], np.degrees(ang[:, 1]), rtol=1e-15)
    with pytest.raises(DataError, match=r"\[poses\]\.unit: .*\"deg\" .* or \"rad\", not 'grad'"):
        sensor.from_toml(TWO + cols + 'unit = "grad"\n')


# ---- the documentation, run as written ---------------------------------------------------------------------------


def _doc_block(start: str) -> str:
    i = DOC.index(start)
    return DOC[i:DOC.index("```", i)]


def test_the_documented_sensor_description_imports_a_log(tmp_path):
    """The main example of docs/dataset.md, copied literally, loads and
    imports a log with its columns (it had both `time` and `rate_hz`)."""
    text = _doc_block('name = "MPU-9250 breakout on the bench"')
    desc = sensor.from_toml(text)
    assert desc.time == "t_ms" and desc.rate_hz is None and desc.acc.counts == "int16"
    rows = ["t_ms,temp,part,ax,ay,az,mx,my,mz,inc,heading,roll,gx,gy,gz",
            "0,25,x_p,16384,0,0,20,5,40,90,10,0,1,2,3", "10,25,x_a,49152,0,0,-20,5,40,90,10,180,1,2,3",
            "20,25,y_p,0,16384,0,20,5,40,90,10,90,1,2,3"]
    (tmp_path / "log.csv").write_text("\n".join(rows) + "\n")
    ds, rep = importlog.import_log(str(tmp_path / "log.csv"), desc)
    assert len(ds) == 2 and list(ds.columns["t_s"]) == [0.0, 0.01]  # y_p not kept
    np.testing.assert_allclose(ds.columns["ax_g"], [-1.0, 1.0])  # 49152 is -16384 (int16), reads = "up"
    assert list(ds.columns["azi_deg"]) == [10.0, 10.0]
    np.testing.assert_allclose(ds.gyro, [[1.0, -2.0, -3.0]] * 2)  # deg/s, the accelerometer's map (x, -y, -z)


def test_the_documented_sample_row_reads_its_own_pose(tmp_path, capsys):
    """docs/dataset.md's first sample: `inclino attitude` of its readings
    gives the pose the row states (its azi_deg had said 0, the readings 180)."""
    text = _doc_block("# field_nT=50000")
    (tmp_path / "run.csv").write_text(text)
    assert main(["attitude", str(tmp_path / "run.csv"), "-o", str(tmp_path / "att.csv")]) == 0
    capsys.readouterr()
    given = dataset.read_raw(str(tmp_path / "run.csv")).columns
    with open(tmp_path / "att.csv") as f:
        got = next(csv.DictReader(f))
    for c in ("inc_deg", "azi_deg", "tf_deg"):
        d = (float(got[c]) - float(given[c][0]) + 180.0) % 360.0 - 180.0
        assert abs(d) < 0.1, (c, got[c], given[c][0])


def test_the_documented_header_error_names_the_line_the_reader_names(tmp_path, capsys):
    text = _doc_block("# field_nT=50000").replace("# dip_deg=45.1", "# dip_deg=500")
    (tmp_path / "run.csv").write_text(text)
    with pytest.raises(DataError) as e:
        dataset.read_raw(str(tmp_path / "run.csv"))
    shown = re.search(r"`(run\.csv:\d+: header dip_deg=500 [^`]*)`", DOC).group(1)
    assert str(e.value) == f"{tmp_path / shown}", (str(e.value), shown)


def test_every_header_key_is_in_the_documented_list():
    i = DOC.index("- Optional leading `# key=value` lines")
    bullet = DOC[i:DOC.index("\n- Then one header row", i)]
    missing = [k for k in dataset.META_KEYS if f"`{k}`" not in bullet]
    assert not missing, missing
    assert "`# utc_s=" in bullet  # inclino acquire's description of its utc_s column


def test_every_top_level_key_of_a_description_is_in_the_documented_example():
    text = _doc_block('name = "MPU-9250 breakout on the bench"')
    top = {m.group(1) for m in re.finditer(r"^([a-z_]+) = ", text.split("[log]")[0], re.M)}
    assert top == sensor.TOP_KEYS - {"log", "accelerometer", "magnetometer", "gyroscope", "header", "poses"}, top
    assert "\n[gyroscope]" in text  # the optional table, documented in the example too


def test_a_normalised_field_is_documented_as_the_unit_the_code_reads():
    """The held-out RepoIMU paragraph had said a normalised field has no
    unit name (write it as counts) while the description reads unit = "field"."""
    i = DOC.index("A normalised\nunit")
    para = DOC[i:DOC.index("\n\n", i)]
    assert 'unit = "field"' in para and "has no name" not in para
    assert sensor.from_toml('[magnetometer]\ncolumns = [1, 2, 3]\nunit = "field"\n[header]\nfield_nT = 49500\n'
                            ).mag.scale == 49500.0


def test_the_import_help_says_a_counter_temperature_is_a_note():
    """A temperature column that is a row counter imports with a note
    (tests/test_input_physics.py); only a copy of another column is exit 2."""
    sub = next(a for a in build_parser()._actions if hasattr(a, "choices") and a.choices and "import" in a.choices)
    text = " ".join(sub.choices["import"].description.split())
    assert "a counter or a ramp is a note (exit 0)" in text
    row = next(line for line in (ROOT / "docs" / "cli.md").read_text().splitlines() if line.startswith("| `import "))
    exit2 = row.split("exit 2 for", 1)[1].split("(the time unit otherwise", 1)[0]
    assert "counter" not in exit2, exit2


def test_a_lone_glitch_at_the_top_of_the_word_is_not_taken_for_signed_counts(tmp_path):
    """Two rows of 65535 (a read error) among 200 small unsigned counts: too
    few in the upper half of the word to name a signed register."""
    rng = np.random.default_rng(2)
    counts = np.round(rng.normal(2000, 20, size=(200, 3))).astype(int)
    counts[[50, 120], 0] = 65535
    (tmp_path / "log.csv").write_text("ax,ay,az\n" + "".join(f"{a},{b},{c}\n" for a, b, c in counts))
    (tmp_path / "s.toml").write_text('[accelerometer]\ncolumns = ["ax", "ay", "az"]\nunit = "counts"\n'
                                     'lsb = "1/2048 g"\n')
    ds, _ = importlog.import_log(str(tmp_path / "log.csv"), sensor.load(str(tmp_path / "s.toml")))
    assert len(ds) == 200


def test_a_column_that_does_not_rise_is_not_read_as_the_files_rate(tmp_path):
    """The magnetometer's file has a column of the time's name that is no
    time (a sample counter that wraps every 100 rows): paired in order, as
    asked, with no rate read from it."""
    _two_files(tmp_path, 50.0, 50.0)
    lines = (tmp_path / "mag.csv").read_text().splitlines()
    lines[1:] = [f"{i % 100}," + r.split(",", 1)[1] for i, r in enumerate(lines[1:])]
    (tmp_path / "mag.csv").write_text("\n".join(lines) + "\n")
    ds, _ = importlog.import_log(str(tmp_path / "acc.csv"), sensor.load(str(tmp_path / "s.toml")))
    assert len(ds) == 600 and "row by row, in order" in ds.meta["pairing"]


def test_a_date_time_not_in_iso_8601_is_named_as_one(tmp_path, capsys):
    """A European export's time stamps (05.03.2024 14:00:00.016) were "not a
    number"; the line now says they are a date-time in another format."""
    log = tmp_path / "eu.csv"
    log.write_text("Date Time;ax;ay;az\n" + "".join(f"05.03.2024 14:00:{i:02d}.016;0,01;0,02;1,0\n" for i in range(30)))
    desc = tmp_path / "s.toml"
    desc.write_text('[log]\ndecimal = ","\ntime = "Date Time"\n[accelerometer]\ncolumns = ["ax", "ay", "az"]\n'
                    'unit = "g"\nreads = "up"\naxes = "x, y, z"\n')
    rc = main(["import", str(log), "--sensor", str(desc), "-o", str(tmp_path / "run.csv")])
    err = capsys.readouterr().err
    assert rc == 2 and "a date-time, but not as ISO 8601 writes one" in err, err


# ---- layouts: a tuple printed as text, a header repeated where logs were joined -----------------------------------


def _ck_rows(n=300):
    with open(REAL / "ck_acc_mag" / "acc_mag_log.csv", newline="") as f:
        rows = list(csv.reader(f))
    return rows[0], rows[1:n + 1]


def _tuple_toml(strip):
    return ("name = \"a 9-axis IMU printed as Python tuples\"\n[log]\nheader = false\n"
            + (f"strip = \"{strip}\"\n" if strip else "")
            + "[accelerometer]\ncolumns = [1, 2, 3]\nunit = \"g\"\nreads = \"up\"\naxes = \"x, y, z\"\n"
              "[magnetometer]\ncolumns = [4, 5, 6]\nunit = \"G\"\naxes = \"x, y, z\"\n")


def test_a_tuple_printed_as_text_is_named_and_read_with_strip(tmp_path, capsys):
    """A logger that prints Python tuples, "((ax, ay, az), (mx, my, mz))"
    per line (an LSM303 on a robot): the first cell was "'((-0.509946' is
    not a number", and dropping bad rows dropped them all.  The error names
    the brackets and the key that takes them out; with it, the log reads
    the numbers the tuples hold."""
    _, rows = _ck_rows()
    log = tmp_path / "tuples.txt"
    log.write_text("".join(f"(({r[0]}, {r[1]}, {r[2]}), ({r[3]}, {r[4]}, {r[5]}))\n" for r in rows))
    desc = tmp_path / "t.toml"
    desc.write_text(_tuple_toml(None))
    out = tmp_path / "run.csv"
    rc, _, err = _cli([log, "--sensor", desc, "-o", out], capsys)
    _one_line_error(rc, err, out)
    assert 'strip = "()"' in err and "tuple" in err, err
    desc.write_text(_tuple_toml("()"))
    rc, _, err = _cli([log, "--sensor", desc, "-o", out], capsys)
    assert rc == 0, err
    ds = dataset.read_raw(str(out))
    plain = tmp_path / "plain.csv"
    plain.write_text("".join(",".join(r) + "\n" for r in rows))
    desc.write_text(_tuple_toml(None))
    want = importlog.import_log(str(plain), sensor.load(str(desc)))[0]
    np.testing.assert_array_equal(ds.acc, want.acc)
    np.testing.assert_array_equal(ds.mag, want.mag)


@pytest.mark.parametrize("strip", ["0", "-", ".", "a", " "])
def test_strip_never_takes_out_what_a_number_is_written_with(strip, tmp_path):
    p = tmp_path / "t.toml"
    p.write_text(_tuple_toml(strip))
    with pytest.raises(DataError, match=r"\[log\]\.strip"):
        sensor.load(str(p))


def test_a_header_repeated_where_logs_were_joined_is_dropped_and_counted(tmp_path, capsys):
    """Two logs joined into one file, the second's header line in the
    middle: "not a number" at that line before; now the line is dropped,
    counted, and every reading is imported."""
    names, rows = _ck_rows()
    log = tmp_path / "joined.csv"
    with open(log, "w", newline="") as f:
        csv.writer(f).writerows([names, *rows[:150], names, *rows[150:]])
    out = tmp_path / "run.csv"
    rc, stdout, err = _cli([log, "--sensor", REAL / "ck_acc_mag" / "sensor.toml", "-o", out], capsys)
    assert rc == 0, err
    assert "the header line repeated" in stdout, stdout
    assert len(dataset.read_raw(str(out))) == len(rows)


# ---- a log without its header line, named columns ----------------------------------------------------------------


def test_a_log_without_a_header_line_is_told_so(tmp_path, capsys):
    """A BNO055 capture of bare numbers read with a description that names
    its columns: the first row's numbers were listed as "the log's columns"
    and nothing more."""
    log = tmp_path / "bare.csv"
    log.write_text("".join(f"{-54 + i},-10,996,120,-300,-610\n" for i in range(20)))
    desc = tmp_path / "s.toml"
    desc.write_text('[accelerometer]\ncolumns = ["ax", "ay", "az"]\nunit = "mg"\n')
    rc, out, err = _cli([log, "--sensor", desc, "-o", tmp_path / "run.csv"], capsys)
    _one_line_error(rc, err, tmp_path / "run.csv")
    assert "no column 'ax' (the log's columns: -54, -10, 996" in err and "header = false" in err
    # a header line that names other columns is not told so
    log.write_text("a,b,c,d,e,f\n" + "1,0,0,0,0,0\n" * 20)
    rc, out, err = _cli([log, "--sensor", desc, "-o", tmp_path / "run.csv"], capsys)
    assert rc == 2 and "no column 'ax'" in err and "header = false" not in err


def test_a_lost_header_line_above_a_label_column_is_told_so(tmp_path, capsys):
    """An ESP32 + MPU-6050 six-face log ("timestamp_us,ax,...,temp_raw,face")
    with its header line cut: the first data row, eight numbers and a face
    label, was listed as "the log's columns" with no cause and no fix (only
    a row of numbers alone was told it had no header line)."""
    log = tmp_path / "six.csv"
    log.write_text("".join(f"{513222 + 1130 * i},17092,-628,184,-558,107,-79,-608,posX\n" for i in range(20)))
    desc = tmp_path / "s.toml"
    desc.write_text('[log]\ntime = "timestamp_us"\ntime_unit = "us"\n[accelerometer]\ncolumns = ["ax", "ay", "az"]\n'
                    'unit = "counts"\nlsb = "1/16384 g"\nreads = "up"\n')
    rc, out, err = _cli([log, "--sensor", desc, "-o", tmp_path / "run.csv"], capsys)
    _one_line_error(rc, err, tmp_path / "run.csv")
    assert "8 of its 9 names are numbers" in err and "header line lost" in err and "header = false" in err, err
    # a header whose names hold a number or two is no data row
    log.write_text("t,1,2,ax_raw,ay_raw,az_raw\n" + "1,0,0,0,0,1\n" * 20)
    rc, out, err = _cli([log, "--sensor", desc, "-o", tmp_path / "run.csv"], capsys)
    assert rc == 2 and "no column" in err and "header line lost" not in err, err


def test_a_field_outside_the_geomagnetic_range_is_said_outside_it(tmp_path, capsys):
    """No header field: |b| is compared with a range, and is outside it (it
    read "not the geomagnetic range")."""
    src = REAL / "micropython_fusion"
    desc = tmp_path / "s.toml"
    text = (src / "sensor.toml").read_text()
    assert 'unit = "uT"' in text
    desc.write_text(text.replace('unit = "uT"', 'unit = "nT"'))
    rc, out, err = _cli([src / "mpudata.csv", "--sensor", desc, "-o", tmp_path / "run.csv"], capsys)
    assert rc == 2 and "outside the geomagnetic range" in err and "not the geomagnetic range" not in err, err


def test_a_mirror_against_the_poses_names_two_swapped_faces_beside_the_map(tmp_path, capsys):
    """A six-face session whose axis map is right but whose labels of the
    +x and -x faces are swapped reads mirrored against its poses exactly as
    a left-handed map would: one axis reversed against the poses.  The
    refusal named only the map, which is right; it now names the swapped
    faces beside it.  The log is made here: a MEMS part reading +1 g on the
    axis pointing up, the body axes from docs/conventions.md (gravity in
    body axes at I = 90, T = 180 is +x, at T = 0 -x, T = 90 +y, T = 270 -y,
    I = 0 +z, I = 180 -z), sensor x = body y, sensor y = -body x."""
    rng = np.random.default_rng(3)
    faces = {"xd": ((1, 0, 0), (90, 180)), "xu": ((-1, 0, 0), (90, 0)), "yd": ((0, 1, 0), (90, 90)),
             "yu": ((0, -1, 0), (90, 270)), "zd": ((0, 0, 1), (0, 0)), "zu": ((0, 0, -1), (180, 0))}
    lines = ["face,sx,sy,sz"]
    for lab, (g, _) in faces.items():
        for _ in range(30):
            b = np.array(g, float) * 1.01 + 0.01 + rng.normal(0, 2e-3, 3)  # body reading, down convention
            up = -b                                                          # the part reads up
            lines.append(f"{lab},{up[1]:.5f},{-up[0]:.5f},{up[2]:.5f}")
    (tmp_path / "faces.csv").write_text("\n".join(lines) + "\n")

    def toml(swap):
        lab = {"xd": "xu", "xu": "xd"} if swap else {}
        return ('[accelerometer]\ncolumns = ["sx", "sy", "sz"]\nunit = "g"\nreads = "up"\n'
                'axes = "x = -y, y = x, z = z"\n[poses]\nlabel = "face"\n[poses.labels]\n'
                + "".join(f'{lab.get(k, k)} = {{ inc = {p[0]}, azi = 0, tf = {p[1]} }}\n' for k, (_, p) in faces.items()))
    (tmp_path / "s.toml").write_text(toml(False))
    assert main(["import", str(tmp_path / "faces.csv"), "--sensor", str(tmp_path / "s.toml"),
                 "-o", str(tmp_path / "ok.csv")]) == 0
    capsys.readouterr()
    (tmp_path / "s.toml").write_text(toml(True))
    rc, _, err = _cli([tmp_path / "faces.csv", "--sensor", tmp_path / "s.toml", "-o", tmp_path / "r.csv"], capsys)
    _one_line_error(rc, err, tmp_path / "r.csv")
    assert "mirrored against the poses" in err and "two opposite faces swapped" in err, err
